"""Every page a phone meets, as people meet them: a student, an instructor and a stranger
walk through the core pages, the census map and the brain atlas on one server. Each page
must fit 360, 390 and 430 px wide phones without sideways scrolling, with thumb-sized
controls and readable type, and axe-core must find no serious or critical problem on it
or on the dashboard. With TAGWALL_SCREENSHOTS=DIR set, a full-page screenshot of every
page at 360 px lands in DIR, with the widths and findings of every page in report.json."""

from __future__ import annotations

import io
import json
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import segno
from PIL import Image
from playwright.sync_api import Browser, BrowserContext, Page, expect

from tests.browser.conftest import serve
from tests.browser.phone_audit import PHONE_WIDTHS, SERIOUS, Fit, axe_violations, fits
from tests.webapp.apps.census_map.test_acs import INCOME, VALUE, downloaded
from tests.webapp.apps.census_map.test_importer import write_shapefile
from webapp.apps.census_map.importer import import_files
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.people.security import operator_token

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
WALL = "demo"


class Tour:
    """Pages visited, each measured at every phone width and audited once."""

    def __init__(self, browser: Browser, server: ServerProcess, shots: Path | None) -> None:
        self.browser = browser
        self.server = server
        self.shots = shots
        self.contexts: list[BrowserContext] = []
        self.fits: dict[str, dict[int, Fit]] = {}
        self.violations: dict[str, list[dict[str, Any]]] = {}

    def phone(self) -> Page:
        context = self.browser.new_context(**PHONE)  # type: ignore[arg-type]
        self.contexts.append(context)
        return context.new_page()

    def codes(self) -> dict[str, str]:
        _, layout = fetch_layout(self.server.url, WALL, operator_token(self.server.secret))
        return {code.label: code.payload for code in layout.placed}

    def look(
        self, name: str, page: Page, *, open_details: bool = False, tables_scroll: bool = False
    ) -> None:
        """Measure the page where it stands, screenshot it on the narrowest phone, audit it."""
        page.wait_for_load_state()
        if open_details:
            page.evaluate("document.querySelectorAll('details').forEach((d) => d.open = true)")
        self.fits[name] = fits(page, tables_scroll=tables_scroll)
        if self.shots:
            page.set_viewport_size({"width": PHONE_WIDTHS[0], "height": 800})
            page.screenshot(path=self.shots / f"{name}.png", full_page=True)
        self.violations[name] = axe_violations(page)
        page.set_viewport_size(PHONE["viewport"])  # type: ignore[arg-type]

    def visit(self, name: str, page: Page, url: str) -> None:
        page.goto(url)
        self.look(name, page)

    def close(self) -> None:
        for context in self.contexts:
            context.close()


@pytest.fixture
def tour(browser: Browser, tmp_path: Path, database_url: str) -> Iterator[Tour]:
    server = serve(
        tmp_path,
        database_url,
        TAGWALL_PUBMED_URL="http://127.0.0.1:9/",  # nothing listens: the offline list
        TAGWALL_PUBMED_TIMEOUT="2",
    )
    folder = os.environ.get("TAGWALL_SCREENSHOTS")
    shots = Path(folder) if folder else None
    if shots:
        shots.mkdir(parents=True, exist_ok=True)
    walk = Tour(browser, server, shots)
    yield walk
    walk.close()
    server.stop()


def submit(page: Page, name: str) -> None:
    """A thumb on a form's button (fails when anything else lies over it), then the
    page the form leads to: loaded, or, for a form kept through a dropped connection
    (``data-keep``, static/js/keptforms.js), shown in place of the one sent."""
    button = page.get_by_role("button", name=name)
    if button.evaluate("(b) => b.form !== null && 'keep' in b.form.dataset"):
        sent = button.element_handle()
        button.tap()
        page.wait_for_function("(b) => !b.isConnected", arg=sent)
        return
    with page.expect_navigation():
        button.tap()


def choose(page: Page, url: str, field: str, value: str) -> None:
    """Change one thing on /me and save."""
    page.goto(f"{url}/me")
    page.locator(f"select[name={field}]").select_option(value)
    submit(page, "Save")


def core_pages(tour: Tour) -> tuple[Page, Page]:
    """Registration, profile, photo scanning, a code's page, publishing, problem pages,
    sign-in and pairing: returns the student's and the instructor's phones."""
    server, url = tour.server, tour.server.url
    codes = tour.codes()
    student = tour.phone()
    tour.visit("start", student, f"{url}/")
    tour.visit("wall-start", student, f"{url}/wall/{WALL}")
    student.goto(codes["Student"])
    expect(student.locator("#role")).to_have_text("student")
    tour.look("registered-student", student)
    tour.visit("me-student", student, f"{url}/me")

    tour.visit("scan", student, f"{url}/scan")
    photo(student, "note.txt", b"no photo", "text/plain")
    tour.look("scan-not-a-picture", student)
    student.goto(f"{url}/scan")
    photo(student, "blank.png", picture_of([]))
    tour.look("scan-no-code", student)
    two = [
        httpx.get(f"{url}/codes/{codes[label].rsplit('/', 1)[1]}.png?scale=8").content
        for label in ("Display r2c2", "Display r2c3")
    ]
    photo(student, "codes.png", picture_of(two))  # neither nearer the middle: it asks
    expect(student.locator("h1")).to_have_text("Which code did you mean?")
    tour.look("scan-ask", student)
    student.goto(f"{url}/scan")
    photo(student, "wifi.png", picture_of([segno_png("WIFI:T:WPA;S:room;;")]))
    expect(student.locator("h1")).to_have_text("What the photo shows")
    tour.look("scan-found", student)

    tour.visit("locate", student, codes["Display r2c2"])
    submit(student, "Publish to the public screen")
    expect(student.locator("#outcome")).to_contain_text("on the public screen")
    tour.look("published", student)
    for _ in range(Settings().publish_rate_per_minute):
        student.goto(codes["Display r2c3"])
        submit(student, "Publish to the public screen")
    expect(student.locator("h1")).to_have_text("Slow down")
    tour.look("published-slow-down", student)

    tour.visit("code-unknown", student, f"{url}/t/ZZZZZZZ")
    tour.visit("not-found", student, f"{url}/no/such/page")
    hasty = tour.phone()
    for _ in range(Settings().scan_rate_per_minute + 1):
        hasty.request.get(codes["Display r1c1"], max_redirects=0)
    hasty.goto(codes["Display r1c1"])
    expect(hasty.locator("h1")).to_have_text("Slow down")
    tour.look("code-slow-down", hasty)

    instructor = tour.phone()
    instructor.goto(codes["Instructor"])
    expect(instructor.locator("h1")).to_have_text("Sign in")
    tour.look("login", instructor)
    instructor.get_by_label("Username").fill("nobody")
    instructor.get_by_label("Password").fill("wrong password")
    submit(instructor, "Sign in")
    tour.look("login-failed", instructor)
    pairing = httpx.post(f"{url}/api/pairing", headers=server.operator()).json()["url"]
    tour.visit("pair", instructor, pairing)
    submit(instructor, "Become instructor")
    expect(instructor.locator("#role")).to_have_text("instructor")
    tour.look("me-instructor", instructor)
    late = tour.phone()
    late.goto(pairing)
    expect(late.locator("h1")).to_have_text("Pairing did not work")
    tour.look("pairing-used", late)
    tour.visit("registered-instructor", instructor, codes["Instructor"])
    return student, instructor


def photo(page: Page, name: str, content: bytes, mime: str = "image/png") -> None:
    page.set_input_files("#photo", files=[{"name": name, "mimeType": mime, "buffer": content}])
    submit(page, "Read the code")


def segno_png(text: str) -> bytes:
    out = io.BytesIO()
    segno.make(text, micro=False).save(out, kind="png", scale=8)
    return out.getvalue()


def picture_of(codes: list[bytes]) -> bytes:
    """A photo-like picture: the code images side by side on white."""
    images = [Image.open(io.BytesIO(c)).convert("L") for c in codes]
    width = sum(i.width for i in images) + 40 * (len(images) + 1) or 400
    height = max((i.height for i in images), default=300) + 80
    picture = Image.new("L", (width, height), 255)
    x = 40
    for image in images:
        picture.paste(image, (x, 40))
        x += image.width + 40
    out = io.BytesIO()
    picture.save(out, format="PNG")
    return out.getvalue()


def census_pages(tour: Tour, student: Page, instructor: Page) -> str:
    """The tract index, a cluster code's list, a tract's pages at every information
    class, the wall coloured from one (and the pages saying where the tract stands), a
    balloon and a toggle; returns a toggle code's URL (retired when the map
    leaves the wall)."""
    url = tour.server.url
    codes = tour.codes()
    toggle = next(payload for label, payload in codes.items() if label[:1].isdigit())
    student.goto(f"{url}/apps/census/{WALL}/tracts")
    tour.look("tract-index", student, open_details=True)
    # the whole map's codes stand mostly over neighbourhoods of small tracts
    cluster = next(payload for label, payload in codes.items() if label.endswith(" tracts"))
    student.goto(cluster)
    expect(student.locator("h1")).to_have_text(re.compile(r"\d+ tracts here"))
    tour.look("cluster", student)
    tract = student.locator(".tract-list a").first.get_attribute("href")
    assert tract is not None
    tour.visit("tract", student, url + tract)
    for info_class, phone in [(1, student), (2, student), (3, student), (4, instructor),
                              (5, instructor)]:  # fmt: skip
        choose(phone, url, "info_class", str(info_class))
        phone.goto(f"{url}{tract}/here")
        expect(phone.locator(".hint").first).to_contain_text(f"information class {info_class}")
        tour.look(f"tract-here-class-{info_class}", phone)
    labels = instructor.locator("#values th").all_inner_texts()
    assert len(labels) == 27, labels  # every value at class 5
    raw = [label for label in labels if re.search(r"\b[A-Z0-9]+_[A-Z0-9_]*\b", label)]
    assert not raw, f"column codes instead of words: {raw}"
    # the instructor colours the wall from the tract's page; each page says where it stands
    instructor.locator("#colour-wall select").select_option("HH_INC")
    with instructor.expect_navigation():
        instructor.locator("#colour-wall button").tap()
    expect(instructor.locator("#outcome")).to_contain_text("coloured by this now")
    tour.look("coloured", instructor)
    for info_class, phone in [(1, student), (5, instructor)]:
        choose(phone, url, "info_class", str(info_class))
        phone.goto(f"{url}{tract}/here")
        expect(phone.locator("#standing")).to_contain_text("Median household income")
        expect(phone.locator("#standing .swatch rect")).to_have_attribute(
            "fill", re.compile(r"#[0-9a-f]{6}")
        )
        tour.look(f"tract-here-coloured-class-{info_class}", phone)
    student.goto(url + tract)
    submit(student, "Show on the wall")
    expect(student.locator("#outcome")).to_contain_text("on the wall")
    tour.look("balloon", student)
    student.goto(f"{url}/apps/census/{WALL}/tracts")
    group = student.locator(f'details:has(a[href="{tract}"])')  # the tract's own group
    group.evaluate("(d) => d.open = true")
    with student.expect_navigation():
        group.get_by_role("button").tap()
    expect(student.locator("#outcome")).to_contain_text("Hidden on the wall now")
    tour.look("toggled", student)
    # the tract's group is hidden now: no balloon into empty map, the way to show it
    tour.visit("tract-group-hidden", student, url + tract)
    expect(student.locator("#hidden-group")).to_contain_text("is hidden on the wall now")
    expect(student.locator("#show-on-wall")).to_have_count(0)
    with student.expect_navigation():
        student.locator("#show-group").tap()
    expect(student.locator("#outcome")).to_have_text("Shown on the wall now.")
    tour.look("toggled-back-to-tract", student)
    with student.expect_navigation():
        student.locator("#back-to-tract").tap()
    expect(student.locator("#show-on-wall")).to_be_visible()
    return toggle


def brain_pages(tour: Tour, student: Page, instructor: Page, retired: str) -> None:
    """Groups, a pin's question, the quiz from nothing answered to the results, the
    instructor's answer, tutor pages for every group and the literature list."""
    server, url = tour.server, tour.server.url
    server.change(WALL, {"app": "brain"})
    student.goto(retired)
    expect(student.locator("h1")).to_have_text("This code is no longer in use")
    tour.look("code-retired", student)

    tour.visit("groups", student, f"{url}/apps/brain/{WALL}/groups")
    submit(student, "Undergraduate")
    tour.look("group", student)

    pins = all_pin_codes(server)
    number, first = next(
        (int(c.label.removeprefix("Pin ")), c.payload)
        for c in fetch_layout(url, WALL, operator_token(server.secret))[1].placed
        if c.label.startswith("Pin ")
    )  # a pin on the wall now
    student.goto(first)
    expect(student.locator("h1")).to_have_text(f"Pin {number}")
    tour.look("question", student)
    student.locator("#answer").fill("   ")
    submit(student, "Send")
    tour.look("question-problem", student)
    tour.visit("quiz-nothing-answered", student, f"{url}/apps/brain/{WALL}/quiz/full")
    student.goto(first)
    student.locator("#answer").fill("superior frontal gyrus")
    submit(student, "Send")
    tour.look("quiz-one-answered", student)
    student.goto(first)
    csrf = student.locator("input[name=csrf]").first.get_attribute("value") or ""
    for pin, payload in pins.items():
        code = payload.rsplit("/", 1)[1]
        answer = f"a long and thorough answer naming region number {pin} in full"
        response = student.request.post(
            f"{url}/apps/brain/{WALL}/pins/{code}/answer",
            form={"csrf": csrf, "answer": answer},
            max_redirects=0,
        )
        assert response.status == 303, response.text()
    student.goto(f"{url}/apps/brain/{WALL}/quiz/full")
    expect(student.locator("#finish")).to_be_visible()
    tour.look("quiz-all-answered", student)
    submit(student, "Finish")
    expect(student.locator("#waiting")).to_be_visible()
    tour.look("quiz-finished", student)

    tour.visit("question-instructor", instructor, first)
    submit(instructor, "Answer")
    expect(instructor.locator("#correct-name")).to_be_visible()
    tour.look("revealed", instructor)

    httpx.post(
        f"{url}/api/apps/brain/walls/{WALL}/quiz/close", headers=server.operator()
    ).raise_for_status()
    student.goto(f"{url}/apps/brain/{WALL}/quiz/full")
    expect(student.locator("#score")).to_be_visible()
    tour.look("quiz-results", student)

    httpx.post(
        f"{url}/api/apps/brain/walls/{WALL}", json={"mode": "tutor"}, headers=server.operator()
    ).raise_for_status()
    for group in ("k5", "undergraduate", "medical", "research"):
        choose(student, url, "user_group", group)
        student.goto(first)
        expect(student.locator("#tutor-text")).to_be_visible()
        tour.look(f"tutor-{group}", student, open_details=True)
    with student.expect_navigation():
        student.get_by_role("link", name="Search the literature").tap()
    expect(student.locator("#source")).to_contain_text("Offline")
    tour.look("literature", student)

    httpx.post(
        f"{url}/api/apps/brain/walls/{WALL}", json={"mode": "quiz"}, headers=server.operator()
    ).raise_for_status()
    student.goto(first)  # a code of the round before
    expect(student.locator("h1")).to_have_text("A new round has started")
    tour.look("new-round", student)


def all_pin_codes(server: ServerProcess) -> dict[int, str]:
    """Every full-set pin's URL, collected by turning the brain through its presets."""
    status = httpx.get(
        f"{server.url}/api/apps/brain/walls/{WALL}", headers=server.operator()
    ).json()
    pins: dict[int, str] = {}
    for preset in status["presets"]:
        httpx.post(
            f"{server.url}/api/apps/brain/walls/{WALL}",
            json={"preset": preset["id"]},
            headers=server.operator(),
        ).raise_for_status()
        _, layout = fetch_layout(server.url, WALL, operator_token(server.secret))
        for code in layout.placed:
            if match := re.fullmatch(r"Pin (\d+)", code.label):
                pins[int(match.group(1))] = code.payload
    return pins


def dashboard_first_use(tour: Tour) -> Page:
    """The dashboard of a new installation, audited; the instructor puts the census map
    on the wall from it, and its data set list fills without a reload."""
    context = tour.browser.new_context(viewport={"width": 1280, "height": 900})
    tour.contexts.append(context)
    page = context.new_page()
    page.goto(f"{tour.server.url}/login/operator?token={operator_token(tour.server.secret)}")
    expect(page.locator("#live")).to_have_text("live")
    expect(page.locator("#app")).to_have_text("pattern")
    datasets = page.locator("#census-dataset option")
    expect(datasets).to_have_text(["none yet: put the census map on the wall"])
    tour.violations["dashboard"] = axe_violations(page)

    page.locator("#app-choice").select_option("census")
    page.get_by_role("button", name="Switch").click()
    # the first time on a wall the shipped tracts are imported: seconds on a busy machine
    expect(page.locator("#app")).to_have_text("census", timeout=60_000)
    expect(datasets).to_have_count(1)
    expect(datasets).to_contain_text("Sacramento MSA census tracts, 2000 (403 tracts")
    expect(datasets).to_contain_text("current")
    expect(page.locator("#census-groups li")).to_have_count(10)
    expect(page.locator("#census-attribute option")).to_have_count(28)  # 27 values, or none
    expect(page.locator("#census-scheme option")).to_have_count(12)
    return page


def test_every_phone_page_fits_phones_and_passes_the_accessibility_audit(tour: Tour) -> None:
    student, instructor = core_pages(tour)
    desk = dashboard_first_use(tour)
    retired = census_pages(tour, student, instructor)
    brain_pages(tour, student, instructor, retired)
    # the new round the mode switch started
    expect(desk.locator("#brain-participants")).to_contain_text("0 taking part")
    if tour.shots:
        desk.screenshot(path=tour.shots / "dashboard.png", full_page=True)
    tour.violations["dashboard with the brain quiz"] = axe_violations(desk)
    # the instructor's paired phone opens it from its profile page
    instructor.goto(f"{tour.server.url}/me")
    with instructor.expect_navigation():
        instructor.get_by_role("link", name="Dashboard").tap()
    expect(instructor.locator("#brain-participants")).to_contain_text("0 taking part")
    tour.look("dashboard-on-a-phone", instructor, open_details=True, tables_scroll=True)
    desk.goto(f"{tour.server.url}/dashboard/admin")
    expect(desk.locator("#audit tbody tr").first).to_be_visible()
    tour.violations["admin"] = axe_violations(desk)
    tour.look("admin-on-a-phone", desk, tables_scroll=True)

    report = []
    for name, measured in tour.fits.items():
        for width, fit in measured.items():
            report += [f"{name} at {width} px: {problem}" for problem in fit.problems]
    for name, violations in tour.violations.items():
        report += [
            f"{name}: axe {v['impact']} {v['id']} ({v['help']}) at {', '.join(v['nodes'])}"
            for v in violations
            if v["impact"] in SERIOUS
        ]
    widths = {name: [fit.width for fit in m.values()] for name, m in tour.fits.items()}
    findings = {name: {w: fit.problems for w, fit in m.items()} for name, m in tour.fits.items()}
    if tour.shots:
        (tour.shots / "report.json").write_text(
            json.dumps({"widths": widths, "problems": findings, "axe": tour.violations}, indent=1)
        )
    assert not report, "\n".join(report)


def test_tract_pages_with_margins_of_error_fit_phones_and_pass_the_audit(
    tour: Tour, tmp_path: Path, database_url: str
) -> None:
    """A data set imported from data.census.gov tables: the long labels of its metadata,
    the margins and the "uncertain" mark fit every phone at every class."""
    server, url = tour.server, tour.server.url
    database = Database(database_url)
    try:
        import_files(
            database,
            shapes=write_shapefile(tmp_path / "tracts"),
            key="GEOID",
            tables=downloaded(tmp_path, INCOME, VALUE),
        )
    finally:
        database.dispose()
    server.change(WALL, {"app": "census"})
    tract = f"{url}/apps/census/{WALL}/tracts/06067000100/here"
    student = tour.phone()
    student.goto(tour.codes()["Student"])
    instructor = tour.phone()
    instructor.goto(httpx.post(f"{url}/api/pairing", headers=server.operator()).json()["url"])
    submit(instructor, "Become instructor")
    for info_class, phone, shown in [
        (1, student, "$52,941 uncertain"),
        (2, student, "$52,941 ± $6,123 uncertain"),
        (5, instructor, "$52,941 ± $6,123 (12%) uncertain"),
    ]:
        choose(phone, url, "info_class", str(info_class))
        phone.goto(tract)
        cell = phone.locator("#values tr").first.locator("td")
        assert " ".join(cell.inner_text().split()) == shown
        expect(phone.locator("#margins")).to_be_visible()
        tour.look(f"tract-margins-class-{info_class}", phone)
    report = [
        f"{name} at {width} px: {problem}"
        for name, measured in tour.fits.items()
        for width, fit in measured.items()
        for problem in fit.problems
    ]
    report += [
        f"{name}: axe {v['impact']} {v['id']} ({v['help']})"
        for name, violations in tour.violations.items()
        for v in violations
        if v["impact"] in SERIOUS
    ]
    assert not report, "\n".join(report)
