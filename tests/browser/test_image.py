"""An instructor's whole lesson with the image app, in Chromium, through the dashboard
(issue 30): an image uploaded and shown, each native-size tile showing exactly its
region of it, fetching only its own pyramid tiles, zoomed and panned in step; three
hotspots placed on the panel's picture, each one's code read off the tiles' screenshots;
two 390 px phones answering a round's question, the round closed and its CSV
downloaded; a hotspot edited; the lesson exported and imported on a fresh server, whose
wall shows the same picture with the three hotspots' codes."""

from __future__ import annotations

import csv
import io
import re
import zipfile
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image, ImageDraw
from playwright.sync_api import Browser, Locator, Page, expect

from tag_service.verify import decode_image
from tests.browser.conftest import open_tiles, serve, version_of
from tests.browser.phone_audit import measure
from tests.conftest import POSTGRES_URL
from tests.webapp.apps.image.samples import quadrants
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess, fresh_database, wait_until
from webapp.people.security import operator_token
from webapp.tags.schemas import LayoutInfo

PHONE = {"viewport": {"width": 390, "height": 844}, "is_mobile": True, "has_touch": True}
DEMO = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
STAGE = ["r2c2", "r2c3"]  # the demo's stage: the two displays clear of the screens
SHRINK = 8  # screenshots are compared at an eighth of their size: tolerant of filtering


def source_image(path: Path) -> np.ndarray:
    """A 4000 x 1120 px image (the stage's shape) whose colour says where it lies: red
    left to right, green top to bottom, blue in 250 px squares (a region off by a tenth
    of a square shows)."""
    pixels = quadrants(4000, 1120)
    y, x = np.mgrid[0:1120, 0:4000]
    pixels[..., 2] = np.where((x // 250 + y // 250) % 2 == 0, 40, 230)
    Image.fromarray(pixels).save(path)
    return pixels


def expected_tile(pixels: np.ndarray, display: dict, stage: list[float], view: dict) -> Image.Image:
    """What ``display`` should show, by the placement docs/image.md describes: the image
    as large as fits on the stage at zoom 1, the view's centre at the stage's middle."""
    height, width = pixels.shape[:2]
    sx, sy, sw, sh = stage
    zoom, (cx, cy) = view["zoom"], view["center"]
    fit = min(sw / width, sh / height)
    a = zoom * fit
    e = sx + sw / 2 + zoom * ((0.5 - cx) * sw - width * fit / 2)
    f = sy + sh / 2 + zoom * ((0.5 - cy) * sh - height * fit / 2)
    p = display["to_pixels"]  # scene mm -> native px
    to_pixels = np.array([[p[0], p[2], p[4]], [p[1], p[3], p[5]], [0, 0, 1]])
    to_scene = np.array([[a, 0, e], [0, a, f], [0, 0, 1]])  # image px -> scene mm
    back = np.linalg.inv(to_pixels @ to_scene)  # native px -> image px
    return Image.fromarray(pixels).transform(
        tuple(display["resolution"]),
        Image.Transform.AFFINE,
        tuple(back[:2].ravel()),
        Image.Resampling.BILINEAR,
        fillcolor=(0, 0, 0),
    )


def difference(shot: Image.Image, expected: Image.Image) -> float:
    """Mean absolute difference per channel (0-255) of the two, shrunk alike."""
    size = (shot.width // SHRINK, shot.height // SHRINK)
    ours = np.asarray(shot.convert("RGB").resize(size, Image.Resampling.BOX), dtype=float)
    theirs = np.asarray(expected.resize(size, Image.Resampling.BOX), dtype=float)
    return float(np.abs(ours - theirs).mean())


def screenshot(page: Page) -> Image.Image:
    return Image.open(io.BytesIO(page.screenshot()))


def marked(page: Page) -> str:
    return str(page.evaluate("document.body.dataset.image || ''"))


def without_codes(image: Image.Image, layout: LayoutInfo, display: dict) -> Image.Image:
    """``image`` (a tile's picture at ``display``'s native size) with every code of the
    layout blacked out where ``display`` would draw it, caption, pin and leader
    included: what is left is the image alone."""
    p = display["to_pixels"]  # scene mm -> native px
    bare = image.convert("RGB")
    draw = ImageDraw.Draw(bare)
    for code in layout.placed:
        x, y, w, h = code.footprint
        points = [(x, y), (x + w, y + h), code.anchor, *(code.leader or ())]
        xs = [p[0] * u + p[2] * v + p[4] for u, v in points]
        ys = [p[1] * u + p[3] * v + p[5] for u, v in points]
        draw.rectangle((min(xs) - 8, min(ys) - 8, max(xs) + 8, max(ys) + 8), fill=(0, 0, 0))
    return bare


def placed_codes(
    server: ServerProcess, labels: list[str], tiles: dict[str, Page], path: Path
) -> dict[str, str]:
    """The URL of each code labelled in ``labels`` once every tile shows the wall's
    newest state, each decoded from a native screenshot of the tile the layout puts it
    on (saved at ``path``-<tile>.png)."""
    wait_until(
        lambda: all(version_of(page) == server.version("demo") for page in tiles.values()),
        what="every tile to show the new codes",
    )
    layout = fetch_layout(server.url, "demo", operator_token(server.secret))[1]
    placed = {c.label: c for c in layout.placed if c.label in labels}
    assert sorted(placed) == sorted(labels), [c.label for c in layout.placed]
    seen: set[str] = set()
    for name in sorted({c.display for c in placed.values()}):
        shot = screenshot(tiles[name])
        shot.save(f"{path}-{name}.png")
        seen |= {code.payload for code in decode_image(shot)}
    payloads = {label: code.payload for label, code in placed.items()}
    assert set(payloads.values()) <= seen, (payloads, seen)
    return payloads


def place_hotspot(hotspots: Locator, at: tuple[int, int], fields: dict[str, str]) -> None:
    """Click the panel's picture at ``at`` (CSS px) and add a hotspot there with the
    form's ``fields`` (by name)."""
    hotspots.locator("#hotspot-canvas").click(position={"x": at[0], "y": at[1]})
    for name, value in fields.items():
        hotspots.locator(f"#hotspot-form [name={name}]").fill(value)
    hotspots.get_by_role("button", name="Add hotspot").click()
    expect(hotspots.locator("#hotspot-status")).to_have_text(f"added {fields['title']}")


def answer(phone: Page, code: str, text: str, shot: Path) -> None:
    """A phone answers the round's question behind ``code``: its page keeps the question
    secret, and fits the phone."""
    phone.goto(code)
    expect(phone.locator("h1")).to_have_text("Question 1")
    expect(phone.locator("#hotspot-title")).to_have_count(0)  # secret while it runs
    phone.locator("#answer").fill(text)
    phone.get_by_role("button", name="Send").click()
    expect(phone.locator("#answer")).to_have_value(text.strip())
    phone.screenshot(path=shot)
    assert measure(phone).problems == []


def signed_in_dashboard(page: Page, server: ServerProcess) -> Locator:
    """The image panel of ``server``'s dashboard, the wall switched to the image app."""
    page.goto(f"{server.url}/login/operator?token={operator_token(server.secret)}")
    page.locator("#app-choice").select_option("image")
    page.locator("#apply-app").click()
    panel = page.locator("#image-panel")
    expect(panel).to_be_visible()
    return panel


# Where the three hotspots go on the panel's 320 x 90 px picture of the 4000 x 1120 px
# image (12.5 image px a CSS px): all three inside the zoomed view, on the stage.
HOTSPOTS = [
    (
        (160, 45),
        {
            "title": "Middle",
            "text-undergraduate": "The **middle** of it all.",
            "question": "What colour is it here?",
            "accepted": "khaki\nolive",
        },
    ),
    ((100, 30), {"title": "Left", "text-k5": "Dark red and green."}),
    ((240, 60), {"title": "Right", "text-k5": "Pink and blue."}),
]


def test_an_instructor_gives_a_whole_lesson_from_the_dashboard_and_takes_it_elsewhere(
    browser: Browser, server: ServerProcess, tmp_path: Path
) -> None:
    pixels = source_image(tmp_path / "gradient.png")
    tiles = dict(zip(DEMO, open_tiles(browser, server, "demo", DEMO, native=True), strict=True))
    fetched: dict[str, list[str]] = {name: [] for name in DEMO}
    for name, page in tiles.items():
        page.on("request", lambda r, name=name: fetched[name].append(r.url))
    dashboard = browser.new_page()
    panel = signed_in_dashboard(dashboard, server)

    panel.locator("#image-upload input[name=file]").set_input_files(tmp_path / "gradient.png")
    panel.locator("#image-upload input[name=title]").fill("Gradient")
    panel.get_by_role("button", name="Upload").click()
    expect(panel.locator("#image-upload-status")).to_have_text(
        "added Gradient (4000 \u00d7 1120 px)", timeout=30_000
    )
    panel.get_by_role("button", name="Show on the wall").click()
    expect(panel.get_by_role("button", name="On the wall")).to_be_visible()
    expect(panel.get_by_role("button", name="Delete")).to_be_disabled()  # it is on the wall

    wall = httpx.get(f"{server.url}/api/walls/demo").json()
    displays = {d["id"]: d for d in wall["displays"]}
    state = server.status("demo")["state"]
    image = state["apps"]["image"]["image"]
    wait_until(
        lambda: all(marked(tiles[name]) == "refined 12" for name in STAGE),
        timeout=30,
        what="the stage's tiles to show the full-size level",
    )
    version = server.version("demo")
    assert all(version_of(page) == version for page in tiles.values())
    for name in STAGE:
        shot = screenshot(tiles[name])
        shot.save(tmp_path / f"{name}.png")  # to look at
        own = difference(shot, expected_tile(pixels, displays[name], wall["stage"], state["view"]))
        other = STAGE[1 - STAGE.index(name)]
        theirs = difference(
            shot, expected_tile(pixels, displays[other], wall["stage"], state["view"])
        )
        assert own < 8 < theirs, (name, own, theirs)
    # Each display fetched only the pyramid tiles it shows, each once: of level 12's 8
    # columns (512 px each), the left display columns 0-3 (up to image x 1994), the right
    # one 3-7 (from x 2006: column 3 straddles the bezel), all 3 rows; the other
    # displays none at all.
    pyramid = re.compile(rf"/apps/image/images/{image}/(\d+)/(\d+)_(\d+)\.jpg$")
    for name, columns in [("r2c2", range(4)), ("r2c3", range(3, 8))]:
        found = [m.groups() for url in fetched[name] if (m := pyramid.search(url))]
        level_12 = sorted((int(col), int(row)) for level, col, row in found if level == "12")
        assert level_12 == [(col, row) for col in columns for row in range(3)], (name, found)
    assert not any(
        pyramid.search(url) for name in DEMO if name not in STAGE for url in fetched[name]
    )

    panel.get_by_role("button", name="zoom in").click()
    expect(dashboard.locator("#version")).to_have_text(str(version + 1))  # its state is new
    panel.get_by_role("button", name="pan right").click()
    wait_until(lambda: server.version("demo") == version + 2, what="zoom and pan to be stored")
    wait_until(
        lambda: all(version_of(page) == version + 2 for page in tiles.values()),
        what="every tile to swap to the zoomed view",
    )
    zoomed = server.status("demo")["state"]["view"]
    assert zoomed["zoom"] == 1.25 and zoomed["center"] == pytest.approx([0.58, 0.5])
    wait_until(
        lambda: all(marked(tiles[name]) == "refined 12" for name in STAGE),
        timeout=30,
        what="the zoomed view to refine",
    )
    for name in STAGE:
        shot = screenshot(tiles[name])
        shot.save(tmp_path / f"{name}-zoomed.png")
        assert difference(shot, expected_tile(pixels, displays[name], wall["stage"], zoomed)) < 8

    # three hotspots, each placed by a click on the panel's picture of the image
    hotspots = panel.locator("#image-hotspots")
    expect(hotspots).to_be_visible()
    expect(hotspots.locator("#hotspot-canvas")).to_have_attribute("height", "90")  # its shape
    hotspots.locator("#hotspot-canvas").click(position={"x": 160, "y": 45})
    # the canvas's CSS box may round a pixel: within a few image pixels of the middle
    expect(hotspots.locator("#hotspot-place")).to_have_text(
        re.compile(r"At \(20\d\d, 5[4-7]\d\) px")
    )
    for at, fields in HOTSPOTS:
        place_hotspot(hotspots, at, fields)
    expect(hotspots.locator("#hotspot-list li")).to_have_count(3)
    expect(hotspots.locator("#hotspot-place")).to_have_text("No place chosen yet.")
    codes = placed_codes(server, ["Middle", "Left", "Right"], tiles, tmp_path / "hotspots")

    reader, other = (browser.new_context(**PHONE).new_page() for _ in range(2))
    reader.goto(codes["Middle"])
    expect(reader.locator("#hotspot-title")).to_have_text("Middle")
    reader.goto(f"{server.url}/me")  # an undergraduate reads the undergraduates' text
    reader.locator("select[name=user_group]").select_option("undergraduate")
    with reader.expect_navigation():
        reader.locator("form[action='/me'] button[type=submit]").click()
    reader.goto(codes["Middle"])
    expect(reader.locator("#hotspot-text strong")).to_have_text("middle")
    reader.screenshot(path=tmp_path / "phone-hotspot.png")
    assert measure(reader).problems == []
    other.goto(codes["Right"])
    expect(other.locator("#hotspot-title")).to_have_text("Right")

    # a round: new codes, the question labelled by its number; one phone right, one wrong
    hotspots.get_by_role("button", name="Start round").click()
    expect(hotspots.locator("#image-quiz-status")).to_contain_text("Round 1 running")
    question = placed_codes(server, ["Question 1"], tiles, tmp_path / "question")["Question 1"]
    assert question not in codes.values()
    answer(reader, question, "  Olive! ", tmp_path / "phone-right.png")
    answer(other, question, "blue", tmp_path / "phone-wrong.png")
    hotspots.get_by_role("button", name="Close round").click()
    expect(hotspots.locator("#image-quiz-status")).to_contain_text("Round 1 closed")
    expect(hotspots.locator("#image-quiz-status")).to_contain_text("2 answered, 50 % right")
    with dashboard.expect_download() as answers:
        hotspots.get_by_role("link", name="Answers (CSV)").click()
    assert re.fullmatch(r"demo-round-1-\d{4}-\d\d-\d\d\.csv", answers.value.suggested_filename)
    rows = list(csv.DictReader(io.StringIO(Path(answers.value.path()).read_text())))
    assert sorted((row["answer"], row["correct"]) for row in rows) == [
        ("Olive!", "yes"),
        ("blue", "no"),
    ]
    reader.reload()
    expect(reader.locator("#your-answer")).to_have_text("Your answer: Olive! \u2713")

    # an edit: the form takes the hotspot, a click on the picture moves it, a new title
    hotspots.locator("#hotspot-list li", has_text="Right").get_by_role(
        "button", name="edit"
    ).click()
    form = hotspots.locator("#hotspot-form")
    expect(form.locator("[name=title]")).to_have_value("Right")
    expect(form.locator("[name=text-k5]")).to_have_value("Pink and blue.")
    hotspots.locator("#hotspot-canvas").click(position={"x": 250, "y": 60})
    expect(hotspots.locator("#hotspot-place")).to_have_text(re.compile(r"At \(31\d\d, 7\d\d\) px"))
    form.locator("[name=title]").fill("East")
    form.get_by_role("button", name="Save hotspot").click()
    expect(hotspots.locator("#hotspot-status")).to_have_text("saved East")
    expect(form.get_by_role("button", name="Add hotspot")).to_be_visible()
    expect(hotspots.locator("#hotspot-list li", has_text="East (31")).to_have_count(1)
    hotspots.screenshot(path=tmp_path / "panel-hotspots.png")

    def labels(on: ServerProcess) -> set[str]:
        return {c.label for c in fetch_layout(on.url, "demo", operator_token(on.secret))[1].placed}

    wait_until(lambda: "East" in labels(server), what="the edited hotspot's code")

    # the lesson, exported through the panel's link, goes to a fresh server
    with dashboard.expect_download() as exported:
        panel.get_by_role("link", name="Export lesson").click()
    assert exported.value.suggested_filename == "gradient.tagwall-lesson"
    lesson = tmp_path / "gradient.tagwall-lesson"
    exported.value.save_as(lesson)
    broken = tmp_path / "broken.tagwall-lesson"
    with zipfile.ZipFile(lesson) as whole, zipfile.ZipFile(broken, "w") as without_image:
        without_image.writestr("lesson.json", whole.read("lesson.json"))
    for page in [reader, other, dashboard, *tiles.values()]:
        page.context.close()

    with fresh_database(POSTGRES_URL, tmp_path / "elsewhere") as elsewhere_db:
        elsewhere = serve(tmp_path / "elsewhere", elsewhere_db)
        try:
            there = dict(
                zip(STAGE, open_tiles(browser, elsewhere, "demo", STAGE, native=True), strict=True)
            )
            instructor = browser.new_context(**PHONE).new_page()  # from a phone this time
            imports = signed_in_dashboard(instructor, elsewhere)
            said = imports.locator("#lesson-import-status")
            imports.locator("#lesson-import input[name=file]").set_input_files(broken)
            imports.get_by_role("button", name="Import lesson").click()
            expect(said).to_have_text("broken.tagwall-lesson: the image 'image.tif' is missing.")
            expect(imports.locator("#image-list tbody tr")).to_have_count(0)  # nothing stored
            imports.locator("#lesson-import input[name=file]").set_input_files(lesson)
            imports.get_by_role("button", name="Import lesson").click()
            expect(said).to_have_text(
                "imported Gradient (4000 \u00d7 1120 px, 3 hotspots)", timeout=30_000
            )
            imports.get_by_role("button", name="Show on the wall").click()
            expect(imports.locator("#hotspot-list li")).to_have_count(3)
            expect(imports.locator("#hotspot-list")).to_contain_text("East (31")
            assert measure(instructor, tables_scroll=True).problems == []
            instructor.screenshot(path=tmp_path / "elsewhere-dashboard-390.png", full_page=True)

            wait_until(
                lambda: all(marked(page) == "refined 12" for page in there.values()),
                timeout=30,
                what="the fresh wall's stage to show the imported image",
            )
            placed_codes(elsewhere, ["Middle", "Left", "East"], there, tmp_path / "elsewhere")
            layout = fetch_layout(elsewhere.url, "demo", operator_token(elsewhere.secret))[1]
            view = elsewhere.status("demo")["state"]["view"]
            for name, page in there.items():
                shot = screenshot(page)
                expected = expected_tile(pixels, displays[name], wall["stage"], view)
                own = difference(
                    without_codes(shot, layout, displays[name]),
                    without_codes(expected, layout, displays[name]),
                )
                assert own < 8, (name, own)
            for page in [instructor, *there.values()]:
                page.context.close()
        finally:
            elsewhere.stop()
