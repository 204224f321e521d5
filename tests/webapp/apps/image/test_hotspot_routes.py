"""Hotspots through the API and on phones: instructors mark them (CSRF, validated,
nothing stored on error), the wall carries a code at each, a phone reads the page for
its group, and a question runs in the shared quiz engine with its answers secret until
the round closes."""

from __future__ import annotations

import csv
import io
import re
from datetime import datetime
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

from fastapi.testclient import TestClient

from tests.conftest import (
    csrf_of,
    migrate,
    operator_headers,
    register_student,
    services_of,
    sign_in,
    wall_files,
)
from tests.webapp.apps.image.test_routes import png_bytes, upload
from webapp.apps.image.state import ImageState
from webapp.core.settings import Settings
from webapp.engine.wall_state import read_state
from webapp.server.app import create_app
from webapp.tags.registry import get_layout, wall_tags

NUCLEUS: dict[str, Any] = {
    "x": 150,
    "y": 100,
    "title": "Nucleus",
    "texts": {"undergraduate": "Holds the **DNA**.\n\nAnd more.", "k5": "The boss."},
    "question": "What is this part called?",
    "accepted": ["Nucleus", "cell nucleus"],
}
WALL_TEXT: dict[str, Any] = {
    "x": 450,
    "y": 300,
    "title": "Cell wall",
    "texts": {"k5": "A fence <script>alert(1)</script> around the cell."},
}


def shown_image(client: TestClient) -> str:
    """An image uploaded and put on the demo wall; its id."""
    operator = operator_headers(client)
    image = upload(client, png_bytes(), **operator).json()["id"]
    shown = client.post("/api/apps/image/walls/demo/show", json={"image": image}, headers=operator)
    assert shown.status_code == 200
    return str(image)


def hotspot_codes(client: TestClient) -> dict[str, str]:
    """Hotspot id -> code of the live hotspot tags placed on the demo wall now."""
    db = services_of(client).db
    _, state = read_state(db, "demo")
    layout = get_layout(db, "demo", state.tag_layout)
    assert layout is not None
    placed = {p["code"] for p in layout.placed}
    return {
        str(t.params["hotspot"]): t.code
        for t in wall_tags(db, "demo")
        if t.app == "image" and t.active and t.code in placed
    }


def test_instructors_add_edit_and_delete_hotspots_and_bad_input_is_refused(
    client: TestClient,
) -> None:
    image = shown_image(client)
    url = f"/api/apps/image/images/{image}/hotspots"
    assert client.post(url, json=NUCLEUS).status_code == 401
    sign_in(client, "instructor")
    assert client.post(url, json=NUCLEUS).status_code == 403  # no CSRF token
    csrf = {"X-CSRF-Token": csrf_of(client)}
    for body, message in [
        ({**NUCLEUS, "x": 601}, "(601, 100) is outside the image (600 x 400 px)."),
        ({**NUCLEUS, "accepted": []}, "A question needs at least one accepted answer."),
    ]:
        refused = client.post(url, json=body, headers=csrf)
        assert (refused.status_code, refused.json()["detail"]) == (422, message)
    assert client.post(url, json={**NUCLEUS, "title": "x" * 121}, headers=csrf).status_code == 422
    assert client.get(url).json() == []  # nothing stored
    assert hotspot_codes(client) == {}

    added = client.post(url, json=NUCLEUS, headers=csrf)
    assert added.status_code == 201, added.text
    spot = added.json()
    assert client.get(url).json() == [spot]
    assert set(hotspot_codes(client)) == {spot["id"]}  # its code is on the wall at once

    moved = client.put(f"{url}/{spot['id']}", json={**NUCLEUS, "x": 10}, headers=csrf)
    assert moved.status_code == 200 and moved.json()["x"] == 10
    refused = client.put(f"{url}/{spot['id']}", json={**NUCLEUS, "y": 401}, headers=csrf)
    assert refused.status_code == 422 and client.get(url).json()[0]["y"] == 100
    assert client.put(f"{url}/{'f' * 12}", json=NUCLEUS, headers=csrf).status_code == 404
    assert client.post(f"/api/apps/image/images/{'f' * 12}/hotspots", json=NUCLEUS, headers=csrf)\
        .status_code == 404  # fmt: skip

    deleted = client.delete(f"{url}/{spot['id']}", headers=csrf)
    assert deleted.status_code == 200 and deleted.json() == []
    assert client.get(url).json() == [] and hotspot_codes(client) == {}


def test_a_phone_reads_a_hotspot_and_answers_its_question_in_a_round(client: TestClient) -> None:
    image = shown_image(client)
    operator = operator_headers(client)
    url = f"/api/apps/image/images/{image}/hotspots"
    nucleus = client.post(url, json=NUCLEUS, headers=operator).json()
    fence = client.post(url, json=WALL_TEXT, headers=operator).json()
    codes = hotspot_codes(client)
    assert set(codes) == {nucleus["id"], fence["id"]}

    # no round yet: every hotspot's page, in Markdown rendered safely
    register_student(client)
    page = client.get(f"/t/{codes[fence['id']]}").text
    assert "Cell wall" in page and "Written for the K-5 group" in page
    assert "<script>alert" not in page and "&lt;script&gt;" in page
    csrf = csrf_of(client)
    published = client.post("/publish", data={"csrf": csrf, "code": codes[fence["id"]]})
    assert published.status_code == 200, published.text

    # a round: new codes, the question numbered, its title and answers secret
    started = client.post("/api/apps/image/walls/demo/quiz/start", headers=operator)
    assert started.status_code == 200, started.text
    number = started.json()["round"]["number"]
    _, state = read_state(services_of(client).db, "demo")
    assert ImageState.of(state).quiz_round == number
    old, codes = codes, hotspot_codes(client)
    assert codes[nucleus["id"]] != old[nucleus["id"]]
    page = client.get(f"/t/{codes[nucleus['id']]}").text
    assert "Question 1" in page and "What is this part called?" in page
    assert "data-keep" in page
    assert not re.search("nucleus|DNA", page, re.IGNORECASE)
    assert client.post("/publish", data={"csrf": csrf, "code": codes[nucleus["id"]]})\
        .status_code == 400  # fmt: skip
    stale = client.get(f"/t/{old[nucleus['id']]}").text
    assert "earlier round" in stale and "answer-form" not in stale

    answer_url = f"/apps/image/demo/hotspots/{codes[nucleus['id']]}/answer"
    sent = client.post(
        answer_url, data={"csrf": csrf, "answer": "  CELL-nucleus! "}, follow_redirects=False
    )
    assert sent.status_code == 303
    page = client.get(sent.headers["location"]).text
    assert "CELL-nucleus!" in page and "✓" not in page and "DNA" not in page
    empty = client.post(answer_url, data={"csrf": csrf, "answer": " "})
    assert empty.status_code == 422 and "Please type" in empty.text

    status = client.get("/api/apps/image/walls/demo", headers=operator).json()
    assert (status["questions"], status["participants"], status["answers"]) == (1, 1, 1)
    assert status["items"][0]["share_correct"] == 1.0

    closed = client.post("/api/apps/image/walls/demo/quiz/close", headers=operator)
    assert closed.status_code == 200 and closed.json()["round"]["open"] is False
    page = client.get(f"/t/{codes[nucleus['id']]}").text
    assert "Nucleus" in page and "DNA" in page and "✓" in page and "round is closed" in page
    late = client.post(answer_url, data={"csrf": csrf, "answer": "nucleus"})
    assert late.status_code == 422 and "closed" in late.text

    exported = client.get("/api/apps/image/walls/demo/answers.csv", headers=operator)
    assert exported.status_code == 200
    assert f"round-{number}" in exported.headers["content-disposition"]
    rows = list(csv.DictReader(io.StringIO(exported.text)))
    assert [
        (r["image"], r["hotspot"], r["title"], r["question"], r["answer"], r["correct"])
        for r in rows
    ] == [(image, nucleus["id"], "Nucleus", "What is this part called?", "CELL-nucleus!", "yes")]
    assert client.get("/api/apps/image/walls/demo/answers.csv?round=99", headers=operator)\
        .status_code == 404  # fmt: skip


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
