"""What phones ask for of the brain and do (``routes/phones``); above all, who may
learn a pin's name and when."""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from typing import Any

import anyio.to_thread
import pytest
from fastapi.testclient import TestClient
from markupsafe import escape
from sqlalchemy import event

from tests.conftest import (
    csrf_of,
    migrate,
    operator_headers,
    register_student,
    services_of,
    sign_in,
)
from tests.webapp.apps.brain_atlas.walls import (
    answer,
    answer_every_pin,
    brain,
    brain_codes,
    control,
    every_pin,
    finish_set,
    pins_on_wall,
    region_of,
    show_brain,
    state_of,
)
from webapp.apps.brain_atlas.routes import phones
from webapp.core.markdown import markdown_html
from webapp.core.settings import Settings
from webapp.engine.wall_state import read_state
from webapp.people.person import assume, load_person
from webapp.people.tokens import load_tokens
from webapp.people.visitors import Visitor
from webapp.quiz.engine import Quiz
from webapp.server.app import create_app
from webapp.tags.registry import find, wall_tags


def test_a_student_cannot_get_an_answer_early_by_any_route(on_wall: TestClient) -> None:
    register_student(on_wall)
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    region = region_of(on_wall, "full", number)
    csrf = csrf_of(on_wall)

    # the instructor's Answer button, posted by a student (a replayed URL and form)
    reveal = on_wall.post(f"/apps/brain/demo/pins/{code}/reveal", data={"csrf": csrf})
    assert reveal.status_code == 403
    assert escape(region.name) not in reveal.text
    # the staff API with the class's statistics and the CSV export
    assert on_wall.get("/api/apps/brain/walls/demo").status_code == 401
    assert on_wall.get("/api/apps/brain/walls/demo/answers.csv").status_code == 401
    # the progress page before finishing, and finishing before answering everything
    answer(on_wall, code, "no idea")
    progress = on_wall.get("/apps/brain/demo/quiz/full")
    assert progress.status_code == 200 and escape(region.name) not in progress.text
    finish = on_wall.post("/apps/brain/demo/quiz/full/finish", data={"csrf": csrf})
    assert "still need" in finish.text and escape(region.name) not in finish.text
    # the tutor page and its literature search while the quiz is on
    assert on_wall.get(f"/apps/brain/demo/pins/{code}/literature").status_code == 409
    # publishing the pin's page to the public screen
    published = on_wall.post("/publish", data={"csrf": csrf, "code": code})
    assert region.name not in published.text
    public = state_of(on_wall).public
    assert public is None or region.name not in public.html


def test_an_instructor_sees_the_answer_at_once(on_wall: TestClient) -> None:
    sign_in(on_wall, "instructor")
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    region = region_of(on_wall, "full", number)
    page = on_wall.get(f"/t/{code}")
    assert 'id="reveal"' in page.text

    revealed = on_wall.post(f"/apps/brain/demo/pins/{code}/reveal", data={"csrf": csrf_of(on_wall)})

    assert revealed.status_code == 200
    assert escape(region.name) in revealed.text


def test_the_reveal_needs_the_csrf_token(on_wall: TestClient) -> None:
    sign_in(on_wall, "instructor")
    _, code = next(iter(pins_on_wall(on_wall, "full").items()))
    assert on_wall.post(f"/apps/brain/demo/pins/{code}/reveal").status_code == 403


def test_finishing_shows_no_name_until_the_instructor_closes_the_round(
    on_wall: TestClient,
) -> None:
    control(on_wall, tag_set="k5")
    pins = every_pin(on_wall, "k5")
    names = {n: region_of(on_wall, "k5", n).name for n in pins}
    register_student(on_wall)
    answer_every_pin(on_wall, pins, {n: names[n] if n % 2 else "the wrong thing" for n in pins})
    # answers may change until finishing
    answer(on_wall, pins[2], names[2].upper())

    before = on_wall.get("/apps/brain/demo/quiz/k5").text
    assert 'id="finish"' in before
    finished = finish_set(on_wall, "k5")

    assert "You are done" in finished
    wrong = [names[n] for n in pins if n % 2 == 0 and n != 2]
    assert not [name for name in wrong if escape(name) in finished]
    assert "✓" not in finished and "✗" not in finished and 'id="score"' not in finished
    late = answer(on_wall, pins[4], names[4])
    assert late.status_code == 422 and "final" in late.text

    on_wall.post("/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall))

    results = on_wall.get("/apps/brain/demo/quiz/k5").text
    right = sum(1 for n in pins if n % 2) + 1
    assert f"{right} of {len(pins)} right" in results
    assert all(escape(name) in results for name in names.values())


def test_a_throw_away_visitor_learns_nothing_that_still_counts(on_wall: TestClient) -> None:
    """The harvest of issue 16: a private tab answers "x" everywhere and finishes,
    hoping to read the key, then the real phone answers. Nothing is shown until the
    round closes; once it has, no answer counts any more."""
    pins = every_pin(on_wall, "full")
    names = {n: region_of(on_wall, "full", n).name for n in pins}
    real = TestClient(on_wall.app, base_url=str(on_wall.base_url))
    register_student(real)
    register_student(on_wall)  # the throw-away visitor
    answer_every_pin(on_wall, pins, dict.fromkeys(pins, "x"))

    harvest = finish_set(on_wall, "full")
    for code in pins.values():
        harvest += on_wall.get(f"/apps/brain/demo/pins/{code}").text
        harvest += on_wall.get(f"/t/{code}").text
    assert not [name for name in names.values() if escape(name) in harvest]

    on_wall.post("/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall))
    results = on_wall.get("/apps/brain/demo/quiz/full").text
    assert all(escape(name) in results for name in names.values())  # the key, worthless now
    number, code = next(iter(pins.items()))
    late = answer(real, code, names[number])
    assert late.status_code == 422 and "closed" in late.text
    assert control(on_wall)["quiz"]["full"]["participants"] == 1


def test_names_at_finishing_when_the_instructor_chose_that_for_the_round(
    on_wall: TestClient,
) -> None:
    reset = on_wall.post(
        "/api/apps/brain/walls/demo/quiz/reset",
        json={"reveal": "finish"},
        headers=operator_headers(on_wall),
    )
    assert reset.status_code == 200 and reset.json()["round"]["reveal"] == "finish"
    control(on_wall, tag_set="k5")
    pins = every_pin(on_wall, "k5")
    names = {n: region_of(on_wall, "k5", n).name for n in pins}
    register_student(on_wall)
    answer_every_pin(on_wall, pins, names)

    results = finish_set(on_wall, "k5")

    assert f"{len(pins)} of {len(pins)} right" in results
    assert all(escape(name) in results for name in names.values())


def test_my_quiz_sends_students_only_to_views_where_the_pin_has_a_code(
    on_wall: TestClient,
) -> None:
    """Issue 17: hints named views where the pin had no code (pin 9 -> "Left side",
    unplaced there). Every view named for an open pin places that pin's code."""
    register_student(on_wall)
    page = on_wall.get("/apps/brain/demo/quiz/full").text
    hints = re.findall(r"<li>([^<:]+): ([^<]+)</li>", page.split('id="open-by-view"')[1])
    assert hints
    named = {str(escape(p.name)): p.id for p in brain(on_wall).views}
    for view, pins in hints:
        control(on_wall, preset=named[view])
        placed = pins_on_wall(on_wall, "full")
        numbers = {int(n.removeprefix("pin ")) for n in pins.split(", ")}
        assert numbers <= set(placed), f"{view}: pins {numbers - set(placed)} have no code"
    # and the pins placed now are the ones "on the wall now"
    now = on_wall.get("/apps/brain/demo/quiz/full").text
    shown = re.search(r'id="open-now">On the wall now: ([^<]+)</p>', now)
    assert shown is not None
    assert {int(n.removeprefix("pin ")) for n in shown.group(1).split(", ")} == set(
        pins_on_wall(on_wall, "full")
    )


def test_my_quiz_follows_each_turn_of_the_view(on_wall: TestClient) -> None:
    """The hints are kept per layout of the wall (a class's phones ask for the same
    few): each turn of the view places the codes anew, and the page says so."""
    register_student(on_wall)
    seen = set()
    for preset in brain(on_wall).views:
        control(on_wall, preset=preset.id)
        page = on_wall.get("/apps/brain/demo/quiz/full").text
        shown = re.search(r'id="open-now">On the wall now: ([^<]+)</p>', page)
        placed = set(pins_on_wall(on_wall, "full"))
        now = {int(n.removeprefix("pin ")) for n in shown.group(1).split(", ")} if shown else set()
        assert now == placed, preset.name
        seen.add(frozenset(now))
    assert len(seen) > 1, "the views place different pins"


def test_answers_are_judged_tolerantly(on_wall: TestClient) -> None:
    register_student(on_wall)
    pins = pins_on_wall(on_wall, "full")
    number, code = next(iter(pins.items()))
    region = region_of(on_wall, "full", number)
    answer(on_wall, code, f"  left {region.name.lower()}  ")

    stats = control(on_wall)["quiz"]["full"]["regions"][number - 1]

    assert stats["answered"] == 1 and stats["share_correct"] == 1.0


@pytest.mark.parametrize(
    "form",
    [{}, {"answer": ""}, {"answer": "x" * 1001}],
    ids=["missing", "empty", "too long"],
)
def test_malformed_answers_get_a_clear_error_and_store_nothing(
    on_wall: TestClient, form: dict[str, str]
) -> None:
    register_student(on_wall)
    _, code = next(iter(pins_on_wall(on_wall, "full").items()))

    response = on_wall.post(
        f"/apps/brain/demo/pins/{code}/answer", data={**form, "csrf": csrf_of(on_wall)}
    )

    assert response.status_code == 422
    assert 'role="alert"' in response.text and 'id="answer-form"' in response.text
    assert control(on_wall)["quiz"]["full"]["participants"] == 0


def test_unknown_pins_and_sets_are_404(on_wall: TestClient) -> None:
    register_student(on_wall)
    assert on_wall.get("/apps/brain/demo/pins/NOPE0000").status_code == 404
    assert on_wall.get("/apps/brain/demo/quiz/medical").status_code == 400
    census_like = next(
        t.code for t in wall_tags(services_of(on_wall).db, "demo") if t.app == "core"
    )
    assert on_wall.get(f"/apps/brain/demo/pins/{census_like}").status_code == 404


def scan_group(client: TestClient, group: str) -> str:
    page = client.get(f"/t/{brain_codes(client)[f'brain:group:{group}']}")
    assert page.status_code == 200
    return page.text


def test_a_group_scan_sets_the_phones_group_and_leaves_the_walls_pins(
    on_wall: TestClient,
) -> None:
    """Issue 17: one child's K-5 scan removed the full set from the medical students'
    wall mid-quiz. The group is the phone's; the wall keeps its pins."""
    register_student(on_wall)
    version = read_state(services_of(on_wall).db, "demo")[0]

    page = scan_group(on_wall, "k5")

    assert "You are in the K-5 group" in page and "your instructor chooses" in page
    assert 'value="k5" selected' in on_wall.get("/me").text
    assert state_of(on_wall).tag_set == "brain-full"
    assert read_state(services_of(on_wall).db, "demo")[0] == version


def test_the_audience_switches_the_wall_only_where_allowed_never_mid_round_once_a_cooldown(
    on_wall: TestClient,
) -> None:
    status = control(on_wall, audience_switches=True)
    assert status["audience_switches"] and status["round"]["open"]
    register_student(on_wall)

    running = scan_group(on_wall, "k5")

    assert "a quiz round is running" in running
    assert state_of(on_wall).tag_set == "brain-full"

    on_wall.post("/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall))
    switched = scan_group(on_wall, "k5")
    assert "The wall now shows the pins for young explorers" in switched
    assert state_of(on_wall).tag_set == "brain-k5"
    assert pins_on_wall(on_wall, "k5") and not pins_on_wall(on_wall, "full")

    again = scan_group(on_wall, "medical")  # within the cooldown
    assert "switched a moment ago" in again
    assert state_of(on_wall).tag_set == "brain-k5"
    # the instructor's own switch does not wait
    assert control(on_wall, tag_set="full")["tag_set"] == "full"


def test_phones_choose_their_group_without_the_menu_screen(on_wall: TestClient) -> None:
    """Walls whose menu screen holds fewer codes (or none) still let phones choose;
    the choice is the phone's, whatever the wall allows."""
    control(on_wall, audience_switches=True)
    on_wall.post("/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall))
    register_student(on_wall)
    listed = on_wall.get("/apps/brain/demo/groups")
    assert listed.status_code == 200
    assert all(f'data-group="{g}"' in listed.text for g in ("k5", "research"))

    chosen = on_wall.post("/apps/brain/demo/groups/k5", data={"csrf": csrf_of(on_wall)})

    assert chosen.status_code == 200 and "K-5 group" in chosen.text
    assert state_of(on_wall).tag_set == "brain-full"
    unknown = on_wall.post("/apps/brain/demo/groups/wizards", data={"csrf": csrf_of(on_wall)})
    assert unknown.status_code == 404
    assert on_wall.post("/apps/brain/demo/groups/k5").status_code == 403  # no CSRF token


def test_tutor_mode_shows_the_page_for_the_visitors_group_and_publishes_it_in_full(
    on_wall: TestClient,
) -> None:
    control(on_wall, mode="tutor")
    register_student(on_wall)
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    region = region_of(on_wall, "full", number)

    page = on_wall.get(f"/t/{code}")

    assert page.status_code == 200 and escape(region.name) in page.text
    assert "For the Undergraduate group" in page.text
    published = on_wall.post("/publish", data={"csrf": csrf_of(on_wall), "code": code})
    assert published.status_code in (200, 303)
    public = state_of(on_wall).public
    assert public is not None and public.title == region.name
    assert "<script" not in public.html
    # journal and book titles are italics, not asterisks, on the phone and the screen
    assert "<em>" in page.text and "*" not in page.text.split('id="tutor-text"')[1]
    assert "<em>" in public.html and "*" not in public.html


def opening(text: str) -> str:
    """A tutor text's first paragraph as the phone shows it."""
    return str(markdown_html(text.strip().split("\n\n")[0])).strip()


def test_a_child_on_a_full_set_pin_gets_the_childrens_text(on_wall: TestClient) -> None:
    control(on_wall, mode="tutor")
    register_student(on_wall)
    on_wall.post("/apps/brain/demo/groups/k5", data={"csrf": csrf_of(on_wall)})
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    region = region_of(on_wall, "full", number)
    tutor = brain(on_wall).content.tutors[region.id]
    assert tutor.k5 is not None and tutor.undergraduate is not None

    page = on_wall.get(f"/t/{code}").text

    assert "For the K-5 group" in page
    assert opening(tutor.k5.text) in page
    assert opening(tutor.undergraduate.text) not in page
    # and an undergraduate on a K-5 pin is told whom its text was written for
    on_wall.post("/apps/brain/demo/groups/undergraduate", data={"csrf": csrf_of(on_wall)})
    control(on_wall, tag_set="k5")
    _, k5_code = next(iter(pins_on_wall(on_wall, "k5").items()))
    assert "For the K-5 group" in on_wall.get(f"/t/{k5_code}").text


def test_a_child_is_asked_in_a_childs_words(on_wall: TestClient) -> None:
    """Issue 17: the K-5 quiz asked a child to "enter the name of the tagged region"."""
    control(on_wall, tag_set="k5")
    register_student(on_wall)
    _, code = next(iter(pins_on_wall(on_wall, "k5").items()))

    page = on_wall.get(f"/t/{code}").text

    assert "Look at the red pin on the wall" in page
    assert "tagged region" not in page


def test_the_offline_reading_list_sets_journal_titles_in_italics(settings: Settings) -> None:
    """Issue 17: journal titles showed raw Markdown asterisks in literature lists."""
    offline = settings.model_copy(
        update={"pubmed_url": "http://127.0.0.1:9/", "pubmed_timeout": 1.0}
    )  # nothing listens: the atlas's own reading list
    migrate(offline.resolved_database_url)
    with TestClient(create_app(offline)) as client:
        show_brain(client)
        control(client, mode="tutor")
        register_student(client)
        pages = [
            client.get(f"/apps/brain/demo/pins/{code}/literature")
            for code in pins_on_wall(client, "full").values()
        ]
        listed = [p.text.split('id="articles"')[1] for p in pages if p.status_code == 200]

    assert listed and all("Offline" in p.text for p in pages if p.status_code == 200)
    assert all("<em>" in items and "*" not in items for items in listed)


def test_an_answer_takes_one_connection_for_its_reads_and_one_for_its_write(
    on_wall: TestClient,
) -> None:
    """Every answer of a room reads its pin (the wall's state, the round) and writes in a
    transaction of its own: two connections from the pool, not one per read."""
    services = services_of(on_wall)
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    tag = find(services.db, code)
    assert tag is not None
    newcomer = load_person(services.db, Visitor.fresh(), "10.0.0.9", services.settings)
    person = assume(services.db, newcomer, "student", services.settings, "10.0.0.9")
    here, checkouts = threading.get_ident(), []

    def checked_out(*_: object) -> None:
        if threading.get_ident() == here:  # not the server's own threads meanwhile
            checkouts.append(1)

    name = region_of(on_wall, "full", number).name
    event.listen(services.db.engine, "checkout", checked_out)
    try:
        pin, refused = phones.store_answer(
            brain(on_wall), services, services.walls["demo"], tag, person, name
        )
    finally:
        event.remove(services.db.engine, "checkout", checked_out)
    assert refused is None and pin.number == number
    assert len(checkouts) == 2
    progress = Quiz(services.db, "brain").progress(
        "demo", pin.round.number, person.visitor.id, "full"
    )
    assert progress.answers[pin.region.id].correct


def test_each_phone_step_hands_at_most_its_write_to_a_thread(
    on_wall: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A hand-off to a worker thread cost a phone's request more than its SQLite reads
    (issue 32): a scan, the pin's page and the progress page hand none over, a
    registration and an answer one each, their write (the scan log's batches are
    written by a task of their own, as the token salts are read). A database server's
    reads go to a thread too (their round trips must not hold the event loop), one per
    request's reads where a route can read them together: a scan's class roll and
    person in one, then its page's; a page's person, then what it shows."""
    services = services_of(on_wall)
    register = next(t.code for t in wall_tags(services.db, "demo") if t.name == "register-student")
    number, pin = next(iter(pins_on_wall(on_wall, "full").items()))
    name = region_of(on_wall, "full", number).name
    handed: list[str] = []
    real = anyio.to_thread.run_sync

    async def counting(function: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        work = getattr(function, "func", function)
        if work not in (services.scan_log.flush, load_tokens):  # the server's own timers
            handed.append(getattr(work, "__name__", repr(work)))
        return await real(function, *args, **kwargs)

    def hand_offs(step: Callable[[], Any], status: int) -> list[str]:
        handed.clear()
        assert step().status_code == status
        return handed.copy()

    read = [] if services.db.embedded else ["_reading_through"]  # on the loop for SQLite

    services.codes.ttl_s = 60.0  # the codes stay cached, as a busy room's do
    for code in (register, pin):
        assert on_wall.get(f"/t/{code}").status_code == 200
    monkeypatch.setattr(anyio.to_thread, "run_sync", counting)
    on_wall.cookies.clear()  # a new phone
    assert hand_offs(lambda: on_wall.get(f"/t/{register}"), 200) == [*read, "assume"]
    assert hand_offs(lambda: on_wall.get(f"/t/{pin}"), 200) == read * 2
    assert hand_offs(lambda: on_wall.get(f"/apps/brain/demo/pins/{pin}"), 200) == read * 2
    csrf = csrf_of(on_wall)
    form = {"answer": name, "csrf": csrf}
    post = lambda: on_wall.post(  # noqa: E731
        f"/apps/brain/demo/pins/{pin}/answer", data=form, follow_redirects=False
    )
    assert hand_offs(post, 303) == [*read, "store_answer"]
    assert hand_offs(lambda: on_wall.get("/apps/brain/demo/quiz/full"), 200) == read * 2
