"""The video app's API: upload (instructors, CSRF) and its refusals, list, remove, the
file served to tiles in ranges, and a wall's video played, paused, sought and looped."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from httpx import Response

from tests.conftest import csrf_of, operator_headers, services_of, sign_in
from tests.webapp.apps.video.conftest import Samples
from webapp.apps.video.app import VideoApp
from webapp.apps.video.settings import VideoSettings
from webapp.apps.video.state import VideoClock, VideoState
from webapp.engine.wall_state import read_state


def video_app(client: TestClient) -> VideoApp:
    app = services_of(client).apps["video"]
    assert isinstance(app, VideoApp)
    return app


def stored(client: TestClient) -> list[str]:
    root = video_app(client).store(services_of(client).settings).root
    return sorted(p.name for p in root.iterdir()) if root.exists() else []


def upload(client: TestClient, path: Path, name: str | None = None, **headers: str) -> Response:
    return client.post(
        "/api/apps/video/videos",
        files={"file": (name or path.name, path.read_bytes(), "video/mp4")},
        data={"title": "Valves"},
        headers=headers,
    )


def slot(client: TestClient) -> VideoState:
    _, state = read_state(services_of(client).db, "demo")
    return VideoState.of(state)


def test_an_instructor_uploads_and_shows_a_video_and_tiles_stream_it_in_ranges(
    client: TestClient, video_sample: Samples
) -> None:
    lecture = video_sample("lecture.mp4")
    sign_in(client, "instructor")
    assert upload(client, lecture).status_code == 403  # no CSRF token
    csrf = {"X-CSRF-Token": csrf_of(client)}
    added = upload(client, lecture, **csrf)
    assert added.status_code == 201, added.text
    video = added.json()
    assert (video["title"], video["container"], video["fps"], video["bytes"]) == (
        "Valves", "mp4", 30.0, lecture.stat().st_size,
    )  # fmt: skip
    assert [v["id"] for v in client.get("/api/apps/video/videos").json()] == [video["id"]]

    shown = client.post(
        "/api/apps/video/walls/demo/show", json={"video": video["id"]}, headers=csrf
    )
    assert shown.status_code == 200, shown.text
    assert shown.json()["on_wall"] and not shown.json()["playing"]
    _, state = read_state(services_of(client).db, "demo")
    assert state.app == "video" and VideoState.of(state).video == video["id"]

    client.cookies.clear()  # tiles and the overview need no session
    assert client.get(f"/apps/video/videos/{video['id']}/info.json").json() == video
    url = f"/apps/video/videos/{video['id']}/video.mp4"
    whole = client.get(url)
    assert whole.status_code == 200 and whole.content == lecture.read_bytes()
    assert whole.headers["content-type"] == "video/mp4"
    assert whole.headers["accept-ranges"] == "bytes"
    assert "immutable" in whole.headers["cache-control"]
    part = client.get(url, headers={"Range": "bytes=100-199"})
    assert part.status_code == 206 and part.content == lecture.read_bytes()[100:200]
    assert part.headers["content-range"] == f"bytes 100-199/{lecture.stat().st_size}"
    beyond = client.get(url, headers={"Range": f"bytes={lecture.stat().st_size + 10}-"})
    assert beyond.status_code == 416
    for missing in [
        f"/apps/video/videos/{video['id']}/video.webm",
        f"/apps/video/videos/{video['id']}/manifest.json",
        "/apps/video/videos/0123456789ab/video.mp4",
        "/apps/video/videos/nothing/info.json",
    ]:
        assert client.get(missing).status_code == 404, missing


def test_only_instructors_upload_list_show_and_control(
    client: TestClient, video_sample: Samples
) -> None:
    lecture = video_sample("lecture.mp4")
    assert upload(client, lecture).status_code == 401
    for method, path, body in [
        ("GET", "/api/apps/video/videos", None),
        ("GET", "/api/apps/video/walls/demo", None),
        ("POST", "/api/apps/video/walls/demo/show", {"video": "0123456789ab"}),
        ("POST", "/api/apps/video/walls/demo/play", None),
        ("POST", "/api/apps/video/walls/demo/pause", None),
        ("POST", "/api/apps/video/walls/demo/seek", {"to_s": 1}),
        ("PUT", "/api/apps/video/walls/demo/loop", {"loop": True}),
        ("PUT", "/api/apps/video/walls/demo/sound", {"display": None}),
        ("GET", "/api/apps/video/walls/demo/remote", None),
        ("DELETE", "/api/apps/video/videos/0123456789ab", None),
    ]:
        assert client.request(method, path, json=body).status_code == 401, path
    remote = client.get("/apps/video/demo/remote", follow_redirects=False)
    assert remote.status_code == 303
    assert remote.headers["location"] == "/login?next=/apps/video/demo/remote"
    assert client.get("/me").status_code == 200  # a visitor's session: still not staff
    assert client.get("/apps/video/demo/remote", follow_redirects=False).status_code == 303

    operator = operator_headers(client)
    unknown = client.post(
        "/api/apps/video/walls/demo/show", json={"video": "0123456789ab"}, headers=operator
    )
    assert unknown.status_code == 404
    assert client.get("/api/apps/video/walls/nowhere", headers=operator).status_code == 404
    nothing_up = client.post("/api/apps/video/walls/demo/play", headers=operator)
    assert nothing_up.status_code == 409
    assert nothing_up.json()["detail"] == "No video is on Demo wall (3 x 2, 55-inch)."


BAD_UPLOADS = [
    ("hevc.mp4", 422, "hevc.mp4 is MP4 with H.265 video, which browsers do not all play"),
    ("talk.m4a", 422, "talk.m4a has no video stream (AAC sound only)."),
    ("four-hours.mp4", 422, "four-hours.mp4 lasts 4 h 0 min, longer than the 3 h 0 min taken"),
    ("lecture.avi", 422, "lecture.avi is AVI (Audio Video Interleaved), not MP4 or WebM"),
]


@pytest.mark.parametrize("name,status,said", BAD_UPLOADS, ids=[n for n, _, _ in BAD_UPLOADS])
def test_a_bad_upload_gets_its_status_and_one_line_and_nothing_is_kept(
    client: TestClient, video_sample: Samples, name: str, status: int, said: str
) -> None:
    response = upload(client, video_sample(name), **operator_headers(client))
    assert response.status_code == status, response.text
    detail = response.json()["detail"]
    assert said in detail and "\n" not in detail, detail
    assert stored(client) == []  # no video, no upload copy


def test_an_upload_over_the_byte_limit_is_refused_as_sent_or_as_read(
    client: TestClient, video_sample: Samples, tmp_path: Path
) -> None:
    operator = operator_headers(client)
    video_app(client).settings = VideoSettings(max_bytes=2_000)
    lecture = video_sample("lecture.mp4")
    declared = upload(client, lecture, **operator)  # its Content-Length says it all
    assert declared.status_code == 413
    assert declared.json()["detail"] == (
        "The file is larger than 0 MB, the most taken (TAGWALL_VIDEO_MAX_BYTES)."
    )
    video_app(client).settings = VideoSettings(max_bytes=lecture.stat().st_size - 1)
    read = upload(client, lecture, **operator)  # within the envelope: counted as read
    assert read.status_code == 413, read.text
    text = tmp_path / "notes.mp4"
    text.write_text("not a video")
    assert upload(client, text, **operator).json()["detail"] == (
        "notes.mp4 is not a video (ffprobe cannot read it)."
    )
    empty = client.post("/api/apps/video/videos", data={"title": "x"}, headers=operator)
    assert empty.status_code == 400
    assert stored(client) == []


def test_play_pause_seek_loop_and_sound_state_one_continuous_clock(
    client: TestClient, video_sample: Samples
) -> None:
    operator = operator_headers(client)
    video = upload(client, video_sample("lecture.mp4"), **operator).json()
    client.post("/api/apps/video/walls/demo/show", json={"video": video["id"]}, headers=operator)
    assert slot(client).clock == VideoClock()

    def step(method: str, path: str, body: object = None) -> dict[str, object]:
        answer = client.request(
            method, f"/api/apps/video/walls/demo/{path}", json=body, headers=operator
        )
        assert answer.status_code == 200, answer.text
        result: dict[str, object] = answer.json()
        return result

    lead = video_app(client).settings.lead_ms
    played = step("POST", "play")
    clock = slot(client).clock
    assert clock.playing and clock.media_s == 0.0
    assert clock.wall_ms - played["server_ms"] in range(lead - 100, lead + 1)  # type: ignore[operator]
    paused = step("POST", "pause")["clock"]
    assert paused["playing"] is False  # type: ignore[index]
    assert step("POST", "seek", {"to_s": 0.5})["clock"]["media_s"] == 0.5  # type: ignore[index]
    back = step("POST", "seek", {"by_s": -10})
    assert back["position_s"] == 0.0 and not back["playing"]
    looped = step("PUT", "loop", {"loop": True})
    assert looped["loop"] is True and slot(client).loop
    assert step("PUT", "sound", {"display": "r2c2"})["sound"] == "r2c2"
    assert slot(client).sound == "r2c2"
    assert step("PUT", "sound", {"display": None})["sound"] is None
    nowhere = client.put(
        "/api/apps/video/walls/demo/sound", json={"display": "r9c9"}, headers=operator
    )
    assert nowhere.status_code == 422
    assert nowhere.json()["detail"] == "Demo wall (3 x 2, 55-inch) has no display 'r9c9'."
    for body in [{}, {"to_s": 1, "by_s": 1}, {"to_s": -1}]:
        refused = client.post("/api/apps/video/walls/demo/seek", json=body, headers=operator)
        assert refused.status_code == 422, body


def test_another_app_pauses_the_video_and_a_removal_waits_until_no_wall_shows_it(
    client: TestClient, video_sample: Samples
) -> None:
    operator = operator_headers(client)
    older = upload(client, video_sample("lecture.mp4"), **operator).json()["id"]
    newer = upload(client, video_sample("lecture.webm"), **operator).json()["id"]
    client.post("/api/apps/video/walls/demo/show", json={"video": older}, headers=operator)
    client.post("/api/apps/video/walls/demo/play", headers=operator)
    shown = client.delete(f"/api/apps/video/videos/{older}", headers=operator)
    assert shown.status_code == 409
    assert shown.json()["detail"] == (
        "'Valves' is shown on Demo wall (3 x 2, 55-inch): show another video there first."
    )
    away = client.post("/api/walls/demo/state", json={"app": "pattern"}, headers=operator)
    assert away.status_code == 200, away.text
    assert not slot(client).clock.playing  # nothing plays behind the next app
    removed = client.delete(f"/api/apps/video/videos/{older}", headers=operator)
    assert [v["id"] for v in removed.json()] == [newer]
    assert stored(client) == [newer]
    back = client.post("/api/walls/demo/state", json={"app": "video"}, headers=operator)
    assert back.status_code == 200, back.text
    assert slot(client).video == newer and slot(client).clock == VideoClock()


def test_the_remote_is_an_instructors_page_with_a_code_to_reach_it(client: TestClient) -> None:
    sign_in(client, "instructor")
    page = client.get("/apps/video/demo/remote")
    assert page.status_code == 200
    assert "data-video-toggle" in page.text and 'data-csrf="' in page.text
    assert client.get("/apps/video/nowhere/remote").status_code == 404
    code = client.get("/api/apps/video/walls/demo/remote").json()
    assert code["url"] == "http://192.168.1.20:8000/apps/video/demo/remote"
    assert code["image"].startswith("data:image/svg+xml;base64,")
