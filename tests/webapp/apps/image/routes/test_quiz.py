"""The image's quiz rounds as the instructor and a class run them (``routes/quiz``):
starting, closing, and a round's answers as a CSV named in the wall's time."""

from __future__ import annotations

import csv
import io
from datetime import datetime
from pathlib import Path
from zoneinfo import ZoneInfo

from fastapi.testclient import TestClient

from tests.conftest import (
    csrf_of,
    migrate,
    operator_headers,
    register_student,
    services_of,
    wall_files,
)
from tests.webapp.apps.image.samples import NUCLEUS, hotspot_codes, shown_image
from webapp.apps.image.state import ImageState
from webapp.core.settings import Settings
from webapp.engine.wall_state import read_state
from webapp.server.app import create_app


def test_a_round_needs_an_image_with_questions(client: TestClient) -> None:
    shown_image(client)
    operator = operator_headers(client)
    refused = client.post("/api/apps/image/walls/demo/quiz/start", headers=operator)
    assert refused.status_code == 409 and "No image with questions" in refused.json()["detail"]
    assert client.post("/api/apps/image/walls/demo/quiz/close", headers=operator).status_code == 409


def test_a_class_runs_a_fresh_round_closes_it_and_offers_its_answers(client: TestClient) -> None:
    image = shown_image(client)
    operator = operator_headers(client)
    client.post(f"/api/apps/image/images/{image}/hotspots", json=NUCLEUS, headers=operator)
    began = client.post("/api/walls/demo/class", json={"app": "image"}, headers=operator)
    assert began.status_code == 200, began.text
    _, state = read_state(services_of(client).db, "demo")
    number = ImageState.of(state).quiz_round
    assert number is not None and ImageState.of(state).image == image
    status = client.get("/api/apps/image/walls/demo", headers=operator).json()
    assert status["round"]["open"] and status["questions"] == 1

    ended = client.post("/api/walls/demo/class/end", headers=operator)
    assert ended.status_code == 200, ended.text
    url = f"/api/apps/image/walls/demo/answers.csv?round={number}"
    assert ended.json()["exports"] == [{"label": f"Round {number} answers (CSV)", "url": url}]
    assert not client.get("/api/apps/image/walls/demo", headers=operator).json()["round"]["open"]
    assert client.get(url, headers=operator).status_code == 200


def test_an_untitled_class_is_named_in_the_walls_time_zone_as_its_answers_are(
    settings: Settings, tmp_path: Path
) -> None:
    """Issue 41: an untitled class was named by its start in UTC while the dashboard and
    the export read the wall's time; its title, the CSV's class column and the file's
    name now agree, and the file's name says the day once."""
    [demo] = wall_files("demo")
    config = tmp_path / "demo.toml"
    config.write_text('time_zone = "Asia/Kolkata"\n' + demo.read_text())
    zoned = settings.model_copy(update={"wall_configs": [config]})
    migrate(zoned.resolved_database_url)
    with TestClient(create_app(zoned)) as client:
        image = shown_image(client)
        operator = operator_headers(client)
        url = f"/api/apps/image/images/{image}/hotspots"
        nucleus = client.post(url, json=NUCLEUS, headers=operator).json()
        began = client.post("/api/walls/demo/class", json={"app": "image"}, headers=operator)
        held = began.json()
        register_student(client)
        code = hotspot_codes(client)[nucleus["id"]]
        answer = {"csrf": csrf_of(client), "answer": "nucleus"}
        assert client.post(f"/apps/image/demo/hotspots/{code}/answer", data=answer).is_success
        ended = client.post("/api/walls/demo/class/end", headers=operator).json()
        exported = client.get(ended["exports"][0]["url"], headers=operator)

    local = datetime.fromisoformat(held["started_at"]).astimezone(ZoneInfo("Asia/Kolkata"))
    assert held["title"] == f"Class of {local:%Y-%m-%d %H:%M}"
    [row] = csv.DictReader(io.StringIO(exported.text))
    assert (row["class"], row["title"], row["answered_at"][-6:]) == (
        held["title"],
        "Nucleus",
        "+05:30",
    )
    number = row["round"]
    assert exported.headers["content-disposition"] == (
        f'attachment; filename="demo-class-of-{local:%Y-%m-%d-%H-%M}-round-{number}.csv"'
    )


def test_the_first_question_added_during_a_class_starts_its_round(client: TestClient) -> None:
    """Issue 41: an instructor who added a question once the class ran (the image had
    none at Start class) found no round running and was not told why. During a class the
    question starts the round Start class would have; outside one, nothing starts and
    the dashboard's status says to start a round."""
    image = shown_image(client)
    operator = operator_headers(client)
    url = f"/api/apps/image/images/{image}/hotspots"
    client.post(url, json=NUCLEUS, headers=operator)
    status = client.get("/api/apps/image/walls/demo", headers=operator).json()
    assert status["questions"] == 1 and status["round"] is None  # no class: no round

    began = client.post("/api/walls/demo/class", json={"app": "image"}, headers=operator)
    assert began.status_code == 200, began.text
    status = client.get("/api/apps/image/walls/demo", headers=operator).json()
    first = status["round"]
    assert first is not None and first["open"]  # the class asked the question already
    client.post("/api/apps/image/walls/demo/quiz/close", headers=operator)

    second = {**NUCLEUS, "x": 400, "title": "Membrane", "accepted": ["membrane"]}
    assert client.post(url, json=second, headers=operator).status_code == 201
    status = client.get("/api/apps/image/walls/demo", headers=operator).json()
    assert status["round"]["open"] and status["round"]["number"] == first["number"] + 1
    assert status["questions"] == 2 and len(hotspot_codes(client)) == 2
