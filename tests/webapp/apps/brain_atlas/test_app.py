"""The brain atlas as a wall app: what it puts on the wall (the template, its pins,
the group menu), how it comes and goes, its rounds across restarts and the content
folder it reads."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import yaml
from fastapi.testclient import TestClient

from tests.conftest import migrate, operator_headers, register_student, services_of
from tests.webapp.apps.brain_atlas.walls import (
    answer,
    brain,
    brain_codes,
    control,
    every_pin,
    pins_on_wall,
    placed_codes,
    region_of,
    show_brain,
    state_of,
)
from webapp.apps.brain_atlas.content import ATLAS_DIR
from webapp.apps.brain_atlas.state import BrainState
from webapp.core.settings import Settings
from webapp.server.app import create_app


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
