"""A class over HTTP, as the dashboard starts and ends it and as phones join it."""

from __future__ import annotations

import csv
import io
from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, services_of, sign_in
from webapp.apps.brain_atlas.atlas import brain_atlas
from webapp.apps.brain_atlas.state import BrainState
from webapp.classes.roll import roll_names, running_class
from webapp.engine.wall_state import PublicItem, WallState, read_state
from webapp.quiz.engine import Quiz
from webapp.tags.registry import get_layout, wall_tags


def state_of(client: TestClient) -> WallState:
    return read_state(services_of(client).db, "demo")[1]


def start(client: TestClient, **choice: Any) -> dict[str, Any]:
    response = client.post("/api/walls/demo/class", json=choice, headers=operator_headers(client))
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def end(client: TestClient) -> dict[str, Any]:
    response = client.post("/api/walls/demo/class/end", headers=operator_headers(client))
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def code_named(client: TestClient, name: str) -> str:
    return next(t.code for t in wall_tags(services_of(client).db, "demo") if t.name == name)


def a_pin(client: TestClient) -> str:
    """The code of a brain pin placed on the wall now."""
    state = state_of(client)
    layout = get_layout(services_of(client).db, "demo", state.tag_layout)
    assert layout is not None
    placed = {p["code"] for p in layout.placed}
    return next(
        t.code
        for t in wall_tags(services_of(client).db, "demo")
        if t.action == "pin" and t.active and t.code in placed
    )


def phone(client: TestClient) -> TestClient:
    """Another phone in the room (the server is the same)."""
    return TestClient(client.app, follow_redirects=False)  # type: ignore[arg-type]


def test_start_class_brings_the_app_fresh_on_every_tile(client: TestClient) -> None:
    services = services_of(client)
    # A wall left as the last class left it: another app, a publication up.
    client.post(
        "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(client)
    ).raise_for_status()
    item = PublicItem(title="Old", html="<p>old</p>", author="x", published_at=1)
    client.portal.call(  # type: ignore[union-attr]
        services.change_wall,
        services.walls["demo"],
        lambda s: s.model_copy(update={"public": item}),
    )
    assert state_of(client).public == item

    held = start(client, title="Anatomy <b>B</b>", app="brain", mode="quiz", names="roster")

    state = state_of(client)
    assert state.app == "brain" and state.mode == "quiz" and state.public is None
    assert state.tag_set == "brain-full"
    first = brain_atlas(services).views[0]
    assert state.view == first.view
    number = BrainState.of(state).quiz_round
    assert number is not None
    round_now = Quiz(services.db, "brain").get_round("demo", number)
    assert round_now is not None and round_now.open
    assert held["title"] == "Anatomy <b>B</b>" and held["running"] and held["joined"] == 0
    assert held["names"] == "roster"


def test_a_new_class_in_quiz_mode_opens_a_new_round_with_new_codes(client: TestClient) -> None:
    start(client, app="brain", mode="quiz")
    first_round = BrainState.of(state_of(client)).quiz_round
    first_pin = a_pin(client)

    start(client, app="brain", mode="quiz")

    assert BrainState.of(state_of(client)).quiz_round == (first_round or 0) + 1
    assert a_pin(client) != first_pin
    old = Quiz(services_of(client).db, "brain").get_round("demo", first_round or 0)
    assert old is not None and not old.open


def test_a_class_in_tutor_mode_runs_no_round(client: TestClient) -> None:
    start(client, app="brain", mode="quiz")
    number = BrainState.of(state_of(client)).quiz_round or 0

    start(client, app="brain", mode="tutor")

    assert state_of(client).mode == "tutor"
    shown = Quiz(services_of(client).db, "brain").get_round("demo", number)
    assert shown is not None and not shown.open


@pytest.mark.parametrize(
    ("choice", "status", "says"),
    [
        ({"app": "nope"}, 422, "There is no app 'nope'"),
        ({"app": "core"}, 422, "There is no app 'core'"),  # the registration codes show nothing
        ({"app": "brain", "mode": "karaoke"}, 422, "no mode 'karaoke' (its modes: quiz, tutor)"),
        ({"app": "census", "mode": "quiz"}, 422, "its modes: default"),
        ({"names": "full legal name"}, 422, ""),
        ({"title": "t" * 201}, 422, ""),
        ({"colour": "red"}, 422, ""),
    ],
)
def test_a_start_that_cannot_be_is_refused_and_changes_nothing(
    client: TestClient, choice: dict[str, Any], status: int, says: str
) -> None:
    before = state_of(client)
    response = client.post("/api/walls/demo/class", json=choice, headers=operator_headers(client))
    assert response.status_code == status
    assert says in response.text
    assert running_class(services_of(client).db, "demo") is None
    assert state_of(client) == before


def test_only_instructors_start_and_end_classes(client: TestClient) -> None:
    assert client.post("/api/walls/demo/class", json={}).status_code == 401
    assert client.post("/api/walls/demo/class/end").status_code == 401
    assert client.get("/api/walls/demo/class").status_code == 401


def test_ending_no_class_is_a_conflict(client: TestClient) -> None:
    response = client.post("/api/walls/demo/class/end", headers=operator_headers(client))
    assert response.status_code == 409
    assert "No class is running" in response.json()["detail"]


def test_a_roster_class_asks_each_student_their_id_once(client: TestClient) -> None:
    held = start(client, app="brain", mode="quiz", names="roster")
    student = phone(client)
    register = code_named(client, "register-student")

    asked = student.get(f"/t/{register}")
    assert asked.status_code == 303
    assert asked.headers["location"] == f"/classes/{held['id']}/join?next=/t/{register}"
    page = student.get(asked.headers["location"])
    assert page.status_code == 200 and "roster id" in page.text
    csrf = csrf_of(student, asked.headers["location"])

    empty = student.post(
        f"/classes/{held['id']}/join", data={"name": " ", "next": f"/t/{register}", "csrf": csrf}
    )
    assert empty.status_code == 400 and "Please type your roster id" in empty.text
    joined = student.post(
        f"/classes/{held['id']}/join",
        data={"name": "<script>alert(1)</script>", "next": f"/t/{register}", "csrf": csrf},
    )
    assert joined.status_code == 303 and joined.headers["location"] == f"/t/{register}"
    assert student.get(f"/t/{register}").status_code == 200  # on the roll: not asked again
    assert student.get(f"/t/{a_pin(client)}").status_code == 200

    names = roll_names(services_of(client).db, held["id"])
    assert list(names.values()) == ["<script>alert(1)</script>"]
    info = client.get("/api/walls/demo/class", headers=operator_headers(client)).json()
    assert info["joined"] == 1


def test_the_join_page_escapes_and_refuses_what_it_should(client: TestClient) -> None:
    held = start(client, app="brain", mode="quiz", names="nickname", title="<i>Bio</i>")
    student = phone(client)
    page = student.get(f"/classes/{held['id']}/join?next=https://evil.example/")
    assert "&lt;i&gt;Bio&lt;/i&gt;" in page.text
    assert 'name="next" value="/me"' in page.text  # only a code of ours to go back to
    csrf = csrf_of(student, f"/classes/{held['id']}/join")
    too_long = student.post(f"/classes/{held['id']}/join", data={"name": "<b>" * 30, "csrf": csrf})
    assert too_long.status_code == 400
    assert "&lt;b&gt;" in too_long.text and "<b><b>" not in too_long.text
    forged = student.post(f"/classes/{held['id']}/join", data={"name": "Ann", "csrf": "x"})
    assert forged.status_code == 403
    end(client)
    gone = student.get(f"/classes/{held['id']}/join")
    assert gone.status_code == 410 and "This class has ended" in gone.text
    late = student.post(f"/classes/{held['id']}/join", data={"name": "Ann", "csrf": csrf})
    assert late.status_code == 410
    assert student.get("/classes/99999/join").status_code == 410


@pytest.mark.parametrize("class_id", [0, -1, 2**31, 2**63, 10**30])
def test_a_class_id_no_class_can_have_is_an_unknown_class(
    client: TestClient, class_id: int
) -> None:
    """Larger than the database's integers too (SQLite's 64 bits, PostgreSQL's 32): the
    page every unknown class gets, never a 500."""
    start(client, app="brain", mode="quiz", names="nickname")
    student = phone(client)
    csrf = csrf_of(student, "/me")
    for method, form in (("GET", None), ("POST", {"name": "Ann", "csrf": csrf})):
        answer = student.request(method, f"/classes/{class_id}/join", data=form)
        assert answer.status_code == 410, (method, answer.text)
        assert "This class has ended" in answer.text


def test_an_anonymous_class_counts_students_without_asking(client: TestClient) -> None:
    start(client, app="brain", mode="quiz", names="anonymous")
    pin = a_pin(client)
    for _ in range(3):
        student = phone(client)
        assert student.get(f"/t/{pin}").status_code == 200
        assert student.get(f"/t/{pin}").status_code == 200  # counted once
    sign_in(client, "instructor")
    assert client.get(f"/t/{pin}").status_code == 200  # instructors are not on the roll

    info = client.get("/api/walls/demo/class").json()
    assert info["joined"] == 3


def test_staff_are_never_asked_a_name(client: TestClient) -> None:
    start(client, app="brain", mode="quiz", names="roster")
    sign_in(client, "instructor")
    assert client.get(f"/t/{a_pin(client)}", follow_redirects=False).status_code == 200
    instructor_code = code_named(client, "register-instructor")
    newcomer = phone(client)
    going = newcomer.get(f"/t/{instructor_code}")  # on its way to sign in, not asked
    assert going.status_code == 303 and going.headers["location"].startswith("/login")


def test_end_class_closes_the_round_and_offers_its_answers(client: TestClient) -> None:
    held = start(client, app="brain", mode="quiz", names="nickname", title="Anatomy B")
    number = BrainState.of(state_of(client)).quiz_round
    student = phone(client)
    pin = a_pin(client)
    location = student.get(f"/t/{pin}").headers["location"]
    csrf = csrf_of(student, location)
    student.post(
        f"/classes/{held['id']}/join", data={"name": "=Ann", "next": f"/t/{pin}", "csrf": csrf}
    )
    sent = student.post(
        f"/apps/brain/demo/pins/{pin}/answer", data={"answer": "thalamus", "csrf": csrf}
    )
    assert sent.status_code == 303

    ended = end(client)

    assert not ended["running"] and ended["joined"] == 1
    shown = Quiz(services_of(client).db, "brain").get_round("demo", number or 0)
    assert shown is not None and not shown.open
    url = f"/api/apps/brain/walls/demo/answers.csv?round={number}"
    assert ended["exports"] == [{"label": f"Round {number} answers (CSV)", "url": url}]
    export = client.get(url, headers=operator_headers(client))
    disposition = export.headers["content-disposition"]
    day = shown.started_at.date().isoformat()
    assert disposition == f'attachment; filename="demo-anatomy-b-round-{number}-{day}.csv"'
    rows = list(csv.DictReader(io.StringIO(export.text)))
    assert [(r["name"], r["answer"], r["class"]) for r in rows] == [
        ("'=Ann", "thalamus", "Anatomy B")
    ]
    assert client.get("/api/walls/demo/class", headers=operator_headers(client)).json() == ended


def test_a_scan_feed_starts_from_the_last_scans(client: TestClient) -> None:
    pin_less = code_named(client, "register-student")
    phone(client).get(f"/t/{pin_less}")
    services_of(client).scan_log.flush()
    sign_in(client, "instructor")

    page = client.get("/dashboard").text

    assert f"&#34;code&#34;: &#34;{pin_less}&#34;" in page or f'"code": "{pin_less}"' in page


def test_the_roll_call_of_a_scan_reads_on_the_loop_for_sqlite(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every scan asks whether a class runs: on SQLite that short read is made where the
    request runs, not handed to a worker thread and back (which cost more than it); on a
    database server it goes to a worker thread, as every other read does."""
    import asyncio

    from webapp.classes import roll

    original, on_loop = roll.standing, []

    def standing(*args: Any) -> Any:
        try:
            on_loop.append(asyncio.get_running_loop() is not None)
        except RuntimeError:  # a worker thread has no loop running
            on_loop.append(False)
        return original(*args)

    monkeypatch.setattr(roll, "standing", standing)
    start(client, app="brain", mode="quiz", names="anonymous")
    assert phone(client).get(f"/t/{a_pin(client)}").status_code == 200
    assert on_loop == [services_of(client).db.embedded]
    info = client.get("/api/walls/demo/class", headers=operator_headers(client)).json()
    assert info["joined"] == 1  # the class was seen, and the student joined it
