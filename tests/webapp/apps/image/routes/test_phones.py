"""Hotspots on phones (``routes/phones``): a phone reads the page for its group, and a
question runs in the shared quiz engine with its answers secret until the round
closes."""

from __future__ import annotations

import csv
import io
import re

from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, register_student, services_of
from tests.webapp.apps.image.samples import NUCLEUS, WALL_TEXT, hotspot_codes, shown_image
from webapp.apps.image.state import ImageState
from webapp.engine.wall_state import read_state


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
