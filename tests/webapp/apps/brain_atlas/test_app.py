"""The brain atlas over HTTP, as the dashboard and phones use it; above all, who may
learn a pin's name and when."""

from __future__ import annotations

import json
import re
import shutil
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import anyio.to_thread
import pytest
import yaml
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
from webapp.apps.brain_atlas import pages
from webapp.apps.brain_atlas.app import BrainApp
from webapp.apps.brain_atlas.atlas import Atlas
from webapp.apps.brain_atlas.content import ATLAS_DIR, Region, TagSetName
from webapp.apps.brain_atlas.state import BrainState
from webapp.core.markdown import markdown_html
from webapp.core.settings import Settings
from webapp.engine.wall_state import WallState, events_since, read_state
from webapp.people.person import assume, load_person
from webapp.people.tokens import load_tokens
from webapp.people.visitors import Visitor
from webapp.quiz.engine import Quiz
from webapp.server.app import create_app
from webapp.tags.registry import find, get_layout, wall_tags


def state_of(client: TestClient) -> WallState:
    return read_state(services_of(client).db, "demo")[1]


def brain(client: TestClient) -> Atlas:
    """The brain atlas the server reads (that of its content folder)."""
    services = services_of(client)
    app = services.apps["brain"]
    assert isinstance(app, BrainApp)
    return app.atlas(services.settings)


def show_brain(client: TestClient) -> WallState:
    response = client.post(
        "/api/walls/demo/state", json={"app": "brain"}, headers=operator_headers(client)
    )
    assert response.status_code == 200, response.text
    return state_of(client)


def control(client: TestClient, **choice: Any) -> dict[str, Any]:
    response = client.post(
        "/api/apps/brain/walls/demo", json=choice, headers=operator_headers(client)
    )
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def brain_codes(client: TestClient) -> dict[str, str]:
    """Live brain tags by name -> code."""
    tags = wall_tags(services_of(client).db, "demo")
    return {t.name: t.code for t in tags if t.app == "brain" and t.active and t.name}


def placed_codes(client: TestClient) -> set[str]:
    state = state_of(client)
    layout = get_layout(services_of(client).db, "demo", state.tag_layout)
    assert layout is not None
    return {p["code"] for p in layout.placed}


def pins_on_wall(client: TestClient, tag_set: str) -> dict[int, str]:
    """Pin number -> code of the set's pins placed on the wall now."""
    on_wall = placed_codes(client)
    prefix = f"brain:{tag_set}:r{BrainState.of(state_of(client)).quiz_round}:pin:"
    return {
        int(name.removeprefix(prefix)): code
        for name, code in brain_codes(client).items()
        if name.startswith(prefix) and code in on_wall
    }


def region_of(client: TestClient, tag_set: TagSetName, number: int) -> Region:
    """The region pin ``number`` marks in the round on the wall (the key: tests only)."""
    app = brain(client)
    quiz_round = app.round_on_wall(services_of(client), "demo", state_of(client))
    assert quiz_round is not None
    return app.pins(quiz_round, tag_set)[number]


def every_pin(client: TestClient, tag_set: str) -> dict[int, str]:
    """Pin number -> code of every pin of a set, turning the brain through the presets."""
    found: dict[int, str] = {}
    for preset in brain(client).views:
        control(client, preset=preset.id)
        found |= pins_on_wall(client, tag_set)
    return found


def answer(client: TestClient, code: str, text: str) -> Any:
    return client.post(
        f"/apps/brain/demo/pins/{code}/answer",
        data={"answer": text, "csrf": csrf_of(client)},
        follow_redirects=False,
    )


@pytest.fixture
def on_wall(client: TestClient) -> TestClient:
    show_brain(client)
    return client


def test_putting_the_brain_up_shows_the_template_with_pins_and_the_group_menu(
    on_wall: TestClient,
) -> None:
    state = state_of(on_wall)
    assert state.volume is not None and state.volume.volume == "mni152"
    assert state.mode == "quiz" and state.tag_set == "brain-full"
    codes = brain_codes(on_wall)
    menu = [f"brain:group:{g}" for g in ("k5", "undergraduate", "medical", "research")]
    assert set(menu) <= set(codes)
    assert {codes[name] for name in menu} <= placed_codes(on_wall)
    pins = pins_on_wall(on_wall, "full")
    assert pins, "the first view shows some pins"
    assert not pins_on_wall(on_wall, "k5"), "only the active set's pins are placed"


def test_a_tile_gets_every_pin_that_reaches_its_display(on_wall: TestClient) -> None:
    """A pin's line and head may cross into a neighbouring display; that display's
    tile must get the code too, or it never draws them (left-side preset, full set:
    a code on r2c3 marks a point on r2c2)."""
    control(on_wall, preset="left-side", tag_set="full")
    wall = services_of(on_wall).walls["demo"]
    layout_id = state_of(on_wall).tag_layout
    crossing = 0
    for display in wall.displays:
        drawn = on_wall.get(f"/api/walls/demo/layouts/{layout_id}?display={display.id}")
        assert drawn.status_code == 200
        codes = {p["code"] for p in drawn.json()["placed"]}
        for placed in on_wall.get(f"/api/walls/demo/layouts/{layout_id}").json()["placed"]:
            head = placed["leader"][1] if placed["leader"] else None
            if head is not None and display.rect.contains(tuple(head)):
                assert placed["code"] in codes, f"{display.id} lacks the head of {placed['label']}"
                crossing += placed["display"] != display.id
            if placed["display"] == display.id:
                assert placed["code"] in codes
    assert crossing, "the preset has a pin whose head stands on another display"
    unknown = on_wall.get(f"/api/walls/demo/layouts/{layout_id}?display=r9c9")
    assert unknown.status_code == 404 and "r2c2" in unknown.json()["detail"]


def test_the_brain_leaving_the_wall_takes_its_volume(on_wall: TestClient) -> None:
    """Back to the setup pattern: no brain volume left in the state for tiles to draw."""
    assert state_of(on_wall).volume is not None
    response = on_wall.post(
        "/api/walls/demo/state", json={"app": "pattern"}, headers=operator_headers(on_wall)
    )
    assert response.status_code == 200, response.text
    state = state_of(on_wall)
    assert state.app == "pattern" and state.volume is None and state.tag_set == "setup"
    assert show_brain(on_wall).volume is not None, "and it comes back with the brain"


def test_every_region_of_both_sets_gets_a_pin_in_some_preset(on_wall: TestClient) -> None:
    app = brain(on_wall)
    for tag_set in ("k5", "full"):
        control(on_wall, tag_set=tag_set)
        assert sorted(every_pin(on_wall, tag_set)) == list(range(1, len(app.regions(tag_set)) + 1))


def test_the_dashboard_names_the_regions_whose_pin_no_view_shows(
    on_wall: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: on a wall of smaller displays 6 of 23 pins had no code in any view and
    the dashboard did not say so. It asks, from the views the phones' hints name: on
    the demo wall every pin has one; with a view that places no code for pin 2, its
    region is named (to staff only: names are the answers)."""
    url = "/api/apps/brain/walls/demo/unshown"
    assert on_wall.get(url).status_code == 401
    ours = operator_headers(on_wall)
    unshown = on_wall.get(url, headers=ours).json()
    assert unshown == {"round": 1, "tag_set": "full", "pins": 23, "regions": []}
    app = brain(on_wall)
    found = app._pin_views

    def without_pin_two(*args: Any) -> dict[int, list[str]]:
        return {n: views for n, views in found(*args).items() if n != 2}

    monkeypatch.setattr(app, "_pin_views", without_pin_two)
    unshown = on_wall.get(url, headers=ours).json()
    assert unshown["regions"] == [region_of(on_wall, "full", 2).name]
    on_wall.post("/api/walls/demo/state", json={"app": "pattern"}, headers=ours)
    away = on_wall.get(url, headers=ours)  # its pins stand on the brain the wall shows
    assert away.status_code == 409 and "not on" in away.json()["detail"]


def test_pins_are_numbered_and_never_named_anywhere_a_student_can_read(
    on_wall: TestClient,
) -> None:
    state = state_of(on_wall)
    layout = on_wall.get(f"/api/walls/demo/layouts/{state.tag_layout}")
    assert layout.status_code == 200
    names = [r.name.casefold() for r in brain(on_wall).regions("full")]
    text = json.dumps(layout.json()).casefold()
    assert "pin 1" in text or "pin " in text
    assert not [name for name in names if name in text]
    register_student(on_wall)
    number, code = next(iter(pins_on_wall(on_wall, "full").items()))
    page = on_wall.get(f"/t/{code}").text
    assert "What is this? Please enter the name of the tagged region." in page
    assert f"Pin {number}" in page
    assert not [name for name in names if name in page.casefold()]
    assert 'id="reveal"' not in page


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


def answer_every_pin(client: TestClient, pins: dict[int, str], texts: dict[int, str]) -> None:
    for number, code in sorted(pins.items()):
        response = answer(client, code, texts[number])
        assert response.status_code == 303, response.text


def finish_set(client: TestClient, tag_set: str) -> str:
    client.post(f"/apps/brain/demo/quiz/{tag_set}/finish", data={"csrf": csrf_of(client)})
    return client.get(f"/apps/brain/demo/quiz/{tag_set}").text


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


def test_each_round_numbers_the_pins_afresh_under_new_codes(on_wall: TestClient) -> None:
    app = brain(on_wall)
    first = app.round_on_wall(services_of(on_wall), "demo", state_of(on_wall))
    old = pins_on_wall(on_wall, "full")
    version = read_state(services_of(on_wall).db, "demo")[0]

    status = on_wall.post(
        "/api/apps/brain/walls/demo/quiz/reset", headers=operator_headers(on_wall)
    )

    assert status.json()["round"]["number"] == 2 and status.json()["round"]["open"]
    second = app.round_on_wall(services_of(on_wall), "demo", state_of(on_wall))
    assert first is not None and second is not None
    closed = Quiz(services_of(on_wall).db, "brain").get_round("demo", first.number)
    assert closed is not None and not closed.open
    assert first.orders["full"] != second.orders["full"]
    assert {r.id for r in app.regions("full")} == set(second.orders["full"])
    new = pins_on_wall(on_wall, "full")
    assert new and not set(new.values()) & set(old.values())
    # the round's codes and numbering came in one change of the wall state
    changes = events_since(services_of(on_wall).db, "demo", version)
    assert changes is not None and len(changes) == 1
    assert "tag_layout" in changes[0].changes
    assert "quiz_round" in changes[0].changes["apps"]["brain"]
    # an old code: a friendly page, not an error
    register_student(on_wall)
    page = on_wall.get(f"/t/{next(iter(old.values()))}")
    assert page.status_code == 200 and "A new round has started" in page.text
    again = on_wall.get(f"/apps/brain/demo/pins/{next(iter(old.values()))}")
    assert again.status_code == 200 and "A new round has started" in again.text
    stale = answer(on_wall, next(iter(old.values())), "thalamus")
    assert stale.status_code == 409 and "A new round has started" in stale.text


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


def test_a_round_starts_with_the_brain_and_pin_one_is_not_always_the_same_region(
    client: TestClient,
) -> None:
    firsts = set()
    for _ in range(3):
        show_brain(client)
        firsts.add(region_of(client, "full", 1).id)
        client.post("/api/apps/brain/walls/demo/quiz/reset", headers=operator_headers(client))
        firsts.add(region_of(client, "full", 1).id)
    assert len(firsts) > 1  # 6 draws from 23: all equal has chance 23**-5


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


def test_the_server_reads_the_tutor_texts_of_its_content_folder(
    settings: Settings, tmp_path: Path
) -> None:
    """Issue 30: an instructor edits a copy of the content, not the checkout: the server
    shows the text of ``TAGWALL_CONTENT_DIR``."""
    folder = tmp_path / "our-content" / "brain_atlas"
    shutil.copytree(ATLAS_DIR, folder, ignore=shutil.ignore_patterns("*.nii.gz"))
    for volume in ATLAS_DIR.glob("*.nii.gz"):
        (folder / volume.name).symlink_to(volume)
    edited = "Edited by our instructor: the region as our course teaches it."
    for path in (folder / "tutor").glob("*.yaml"):
        tutor = yaml.safe_load(path.read_text())
        if tutor.get("undergraduate"):
            tutor["undergraduate"]["text"] = f"{edited}\n\n{tutor['undergraduate']['text']}"
        path.write_text(yaml.safe_dump(tutor, sort_keys=False))
    ours = settings.model_copy(update={"content_dir": folder.parent})
    migrate(ours.resolved_database_url)
    with TestClient(create_app(ours)) as client:
        show_brain(client)
        control(client, mode="tutor")
        register_student(client)
        code = next(iter(pins_on_wall(client, "full").values()))
        page = client.get(f"/t/{code}")

    assert page.status_code == 200 and "For the Undergraduate group" in page.text
    assert edited in page.text


def test_the_dashboard_switches_modes_presets_and_sets_and_resets_the_quiz(
    on_wall: TestClient,
) -> None:
    app = brain(on_wall)
    status = control(on_wall, mode="tutor", tag_set="k5", preset=app.views[1].id)
    assert (status["mode"], status["tag_set"]) == ("tutor", "k5")
    state = state_of(on_wall)
    assert state.view == app.views[1].view
    # tutor pages name every pin: the running round closed with the switch
    assert (status["round"]["number"], status["round"]["open"]) == (1, False)
    back = control(on_wall, mode="quiz")  # and quiz mode starts the next one
    assert (back["round"]["number"], back["round"]["open"]) == (2, True)
    assert BrainState.of(state_of(on_wall)).quiz_round == 2

    reset = on_wall.post("/api/apps/brain/walls/demo/quiz/reset", headers=operator_headers(on_wall))

    assert reset.status_code == 200 and reset.json()["round"]["number"] == 3
    bad = on_wall.post(
        "/api/apps/brain/walls/demo", json={"preset": "nowhere"}, headers=operator_headers(on_wall)
    )
    assert bad.status_code == 404
    extra = on_wall.post(
        "/api/apps/brain/walls/demo", json={"colour": "red"}, headers=operator_headers(on_wall)
    )
    assert extra.status_code == 422


def test_the_csv_export_lists_the_rounds_answers(on_wall: TestClient) -> None:
    register_student(on_wall)
    _, code = next(iter(pins_on_wall(on_wall, "full").items()))
    answer(on_wall, code, "thalamus")

    export = on_wall.get(
        "/api/apps/brain/walls/demo/answers.csv", headers=operator_headers(on_wall)
    )

    assert export.status_code == 200
    assert export.headers["content-type"].startswith("text/csv")
    header, row = export.text.splitlines()
    assert header == "round,visitor,name,tag_set,region,answer,correct,answered_at,class"
    assert row.split(",")[5:7] in (["thalamus", "yes"], ["thalamus", "no"])


def test_controls_refuse_when_the_brain_is_not_on_the_wall(client: TestClient) -> None:
    response = client.post(
        "/api/apps/brain/walls/demo", json={"mode": "tutor"}, headers=operator_headers(client)
    )
    assert response.status_code == 409


def _restarted(settings: Settings) -> TestClient:
    """The same wall and database under a server started again (its start settles the
    app on the wall, as every restart does)."""
    return TestClient(create_app(settings))


def test_tutor_mode_survives_a_restart_with_no_round_opened(
    settings: Settings, on_wall: TestClient
) -> None:
    """Issue 31: a restart opened a new round in tutor mode, and every pin answered 409."""
    control(on_wall, mode="tutor")
    before = BrainState.of(state_of(on_wall)).quiz_round
    with _restarted(settings) as again:
        register_student(again)
        status = control(again)
        assert status["mode"] == "tutor" and status["round"]["open"] is False
        assert BrainState.of(state_of(again)).quiz_round == before
        _, code = next(iter(pins_on_wall(again, "full").items()))
        assert again.get(f"/t/{code}").status_code == 200  # the tutor page, not 409


def test_a_closed_round_stays_closed_across_a_restart_and_students_keep_their_results(
    settings: Settings, on_wall: TestClient
) -> None:
    register_student(on_wall)
    pins = pins_on_wall(on_wall, "full")
    number, code = next(iter(pins.items()))
    answer(on_wall, code, region_of(on_wall, "full", number).name)
    closed = on_wall.post(
        "/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall)
    )
    assert closed.status_code == 200, closed.text
    cookies = dict(on_wall.cookies)
    with _restarted(settings) as again:
        again.cookies.update(cookies)
        status = control(again)
        assert (status["round"]["number"], status["round"]["open"]) == (1, False)
        assert BrainState.of(state_of(again)).quiz_round == 1
        mine = again.get("/apps/brain/demo/quiz/full")
        assert mine.status_code == 200
        assert "Round 1 · closed" in mine.text and "✓" in mine.text  # their result, shown


def test_a_round_opens_again_only_when_an_instructor_opens_one(on_wall: TestClient) -> None:
    """Leaving the wall and coming back keeps the closed round; quiz mode or a reset opens
    the next."""
    on_wall.post("/api/apps/brain/walls/demo/quiz/close", headers=operator_headers(on_wall))
    on_wall.post(
        "/api/walls/demo/state", json={"app": "pattern"}, headers=operator_headers(on_wall)
    )
    show_brain(on_wall)
    shown = control(on_wall)["round"]
    assert (shown["number"], shown["open"]) == (1, False)
    reset = on_wall.post("/api/apps/brain/walls/demo/quiz/reset", headers=operator_headers(on_wall))
    assert reset.json()["round"]["number"] == 2 and reset.json()["round"]["open"] is True


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
        pin, refused = pages.store_answer(
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
