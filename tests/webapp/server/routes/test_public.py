"""Publishing from a phone page, moderation and the lock, over HTTP."""

from __future__ import annotations

from fastapi import FastAPI
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, register_student, services_of, sign_in
from webapp.core.settings import Settings
from webapp.engine.wall_state import read_state
from webapp.publishing.screen import waiting
from webapp.server.app import create_app
from webapp.tags.registry import wall_tags


def setup_code(client: TestClient, tile: str = "r2c2") -> str:
    return next(
        t.code for t in wall_tags(services_of(client).db, "demo") if t.name == f"setup-{tile}"
    )


def publish(client: TestClient, code: str) -> object:
    return client.post("/publish", data={"code": code, "csrf": csrf_of(client)})


def public_item(client: TestClient) -> object:
    return read_state(services_of(client).db, "demo")[1].public


def test_the_phone_page_has_a_publish_button_and_publishing_shows_it(client: TestClient) -> None:
    register_student(client)
    code = setup_code(client)
    page = client.get(f"/t/{code}").text
    assert 'action="/publish"' in page and f'value="{code}"' in page
    assert page.rindex('action="/publish"') > page.rindex("</dl>"), "at the bottom"
    response = publish(client, code)
    assert response.status_code == 200  # type: ignore[attr-defined]
    assert "on the public screen" in response.text  # type: ignore[attr-defined]
    item = public_item(client)
    assert item is not None and item.title == "Display r2c2"  # type: ignore[attr-defined]
    assert "Published by a student" in item.html  # type: ignore[attr-defined]


def test_what_a_visitor_typed_is_escaped_on_the_public_screen(client: TestClient) -> None:
    register_student(client)
    client.post(
        "/me",
        data={
            "csrf": csrf_of(client),
            "display_name": '<script>alert("x")</script><img src=x onerror=alert(1)>',
            "user_group": "k5",
            "info_class": "1",
        },
    )
    publish(client, setup_code(client))
    html = public_item(client).html  # type: ignore[attr-defined]
    assert "<script>" not in html and "<img src=x" not in html
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt;" in html


def test_moderation_holds_students_until_approved(client: TestClient) -> None:
    with TestClient(client.app) as instructor:  # type: ignore[arg-type]
        sign_in(instructor, "instructor")
        headers = {"X-CSRF-Token": csrf_of(instructor)}
        policy = instructor.put(
            "/api/walls/demo/public/policy",
            json={"moderated": True, "locked": False},
            headers=headers,
        )
        assert policy.status_code == 200
        register_student(client)
        response = publish(client, setup_code(client))
        assert "instructor will look at it" in response.text  # type: ignore[attr-defined]
        assert public_item(client) is None
        queue = instructor.get("/api/walls/demo/public").json()["waiting"]
        assert [item["title"] for item in queue] == ["Display r2c2"]
        approved = instructor.post(
            f"/api/walls/demo/public/{queue[0]['id']}/approve", headers=headers
        )
        assert approved.status_code == 200 and approved.json()["status"] == "shown"
        assert public_item(client).id == queue[0]["id"]  # type: ignore[attr-defined]
        again = instructor.post(f"/api/walls/demo/public/{queue[0]['id']}/reject", headers=headers)
        assert again.status_code == 404  # decided already
        # an instructor's own publication skips the queue
        publish(instructor, setup_code(instructor, "r2c3"))
        assert public_item(client).title == "Display r2c3"  # type: ignore[attr-defined]


def test_a_student_learns_on_their_page_that_a_publication_was_declined(
    client: TestClient,
) -> None:
    """Issue 31: a student was never told that the instructor rejected their
    publication."""
    with TestClient(client.app) as instructor:  # type: ignore[arg-type]
        sign_in(instructor, "instructor")
        headers = {"X-CSRF-Token": csrf_of(instructor)}
        instructor.put(
            "/api/walls/demo/public/policy",
            json={"moderated": True, "locked": False},
            headers=headers,
        )
        register_student(client)
        sent = publish(client, setup_code(client))
        assert 'href="/me#published"' in sent.text  # type: ignore[attr-defined]
        me = client.get("/me").text
        assert "Display r2c2: waiting for the instructor to look at it" in me
        (queued,) = instructor.get("/api/walls/demo/public").json()["waiting"]
        instructor.post(f"/api/walls/demo/public/{queued['id']}/reject", headers=headers)
        me = client.get("/me").text
        assert "Display r2c2: not shown: the instructor declined it" in me
        assert "Display r2c2" not in TestClient(client.app).get("/me").text, "only its author"


def test_a_locked_screen_refuses_students_not_instructors(client: TestClient) -> None:
    with TestClient(client.app) as instructor:  # type: ignore[arg-type]
        sign_in(instructor, "instructor")
        instructor.put(
            "/api/walls/demo/public/policy",
            json={"moderated": False, "locked": True},
            headers={"X-CSRF-Token": csrf_of(instructor)},
        )
        register_student(client)
        refused = publish(client, setup_code(client))
        assert refused.status_code == 403  # type: ignore[attr-defined]
        assert "locked" in refused.text  # type: ignore[attr-defined]
        assert public_item(client) is None
        assert publish(instructor, setup_code(instructor)).status_code == 200  # type: ignore[attr-defined]
        cleared = instructor.post(
            "/api/walls/demo/public/clear", headers={"X-CSRF-Token": csrf_of(instructor)}
        )
        assert cleared.status_code == 200 and public_item(client) is None


def test_publishing_is_rate_limited_per_visitor(client: TestClient) -> None:
    register_student(client)
    code = setup_code(client)
    limit = services_of(client).settings.publish_rate_per_minute
    for _ in range(limit):
        assert publish(client, code).status_code == 200  # type: ignore[attr-defined]
    slow = publish(client, code)
    assert slow.status_code == 429  # type: ignore[attr-defined]
    assert int(slow.headers["retry-after"]) >= 1  # type: ignore[attr-defined]


def test_nothing_to_publish_for_bad_codes(client: TestClient) -> None:
    for code in ("ZZZZZZZ", "nope", "<script>"):
        response = publish(client, code)
        assert response.status_code == 404, code  # type: ignore[attr-defined]
        assert "Traceback" not in response.text  # type: ignore[attr-defined]
    registration = next(
        t.code for t in wall_tags(services_of(client).db, "demo") if t.name == "register-student"
    )
    assert publish(client, registration).status_code == 400  # type: ignore[attr-defined]


def test_the_screen_and_the_queue_survive_a_restart(settings: Settings, app: FastAPI) -> None:
    with TestClient(app) as instructor, TestClient(app) as student:
        sign_in(instructor, "instructor")
        publish(instructor, setup_code(instructor, "r2c3"))
        instructor.put(
            "/api/walls/demo/public/policy",
            json={"moderated": True, "locked": False},
            headers={"X-CSRF-Token": csrf_of(instructor)},
        )
        register_student(student)
        publish(student, setup_code(student))
    with TestClient(create_app(settings)) as restarted:
        state = read_state(services_of(restarted).db, "demo")[1]
        assert state.public is not None and state.public.title == "Display r2c3"
        assert state.public_policy.moderated
        assert [p.title for p in waiting(services_of(restarted).db, "demo")] == ["Display r2c2"]
