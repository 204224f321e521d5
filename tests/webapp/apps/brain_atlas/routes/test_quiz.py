"""The brain's quiz rounds as the instructor runs them (``routes/quiz``): new rounds
under new codes, and a round's answers as a CSV."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.conftest import operator_headers, register_student, services_of
from tests.webapp.apps.brain_atlas.walls import answer, brain, pins_on_wall, state_of
from webapp.engine.wall_state import events_since, read_state
from webapp.quiz.engine import Quiz


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
