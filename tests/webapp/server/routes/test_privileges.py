"""The privilege matrix: anonymous, student, instructor and admin against every endpoint.

Every request carries its session's CSRF token, so what is tested here is the role;
CSRF has its own tests. A route added without a row here fails
``test_the_matrix_covers_every_route``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlencode

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from tests.conftest import (
    TEST_PASSWORD,
    build_test_volume,
    csrf_of,
    register_student,
    routes_of,
    services_of,
    sign_in,
)
from tests.webapp.apps.image.samples import quadrants, save
from tests.webapp.apps.video.samples import make
from webapp.apps.census_map.state import CensusState
from webapp.apps.image import hotspots, lesson
from webapp.apps.image.hotspots import HotspotFields
from webapp.apps.image.library import ImageLibrary
from webapp.apps.video.library import VideoLibrary
from webapp.engine.wall_state import VolumeLayer, commit_change, read_state
from webapp.people.accounts import add_account
from webapp.people.address_rules import add_rule
from webapp.tags.registry import get_layout, wall_tags

ROLES = ("anonymous", "student", "instructor", "admin")
OK, LOGIN = "ok", "login"  # any success (2xx, or a redirect not to sign in); sent to sign in
PUBLIC = (OK, OK, OK, OK)
STAFF_PAGE = (LOGIN, LOGIN, OK, OK)
ADMIN_PAGE = (LOGIN, LOGIN, 403, OK)
STAFF_API = (401, 401, OK, OK)


@dataclass(frozen=True)
class Row:
    method: str
    route: str  # the route's template, for the coverage check
    url: str
    expected: tuple[object, object, object, object]
    form: dict[str, str] | None = None  # "{role}" in a value becomes the role
    json: Any = None
    files: dict[str, tuple[str, bytes, str]] | None = None


def matrix(client: TestClient) -> list[Row]:
    db = services_of(client).db
    tags = {t.name: t.code for t in wall_tags(db, "demo")}
    setup = tags["setup-r1c1"]
    _, state = read_state(db, "demo")
    spare = add_account(db, "spare", "instructor", TEST_PASSWORD, actor="test")
    rule = add_rule(
        db, "10.200.0.0/16", role=None, user_group="k5", info_class=None, note="", actor="test"
    )
    tag = {"app": "pattern", "action": "locate", "anchor": [100.0, 100.0]}
    volume = VolumeLayer(volume=build_test_volume(services_of(client).settings))
    commit_change(db, "demo", lambda s: s.model_copy(update={"volume": volume}), keep_events=100)
    scene = json.dumps({"view": {}, "volume": volume.model_dump()})
    tile_volume = "/api/walls/demo/tiles/r1c1/volume"
    # the census map on another wall, so the demo wall's rows keep their codes
    census = client.post(
        "/api/walls/kl-3x3/state",
        json={"app": "census"},
        headers={"Authorization": f"Bearer {services_of(client).operator_token}"},
    )
    assert census.status_code == 200, census.text
    dataset = CensusState.of(read_state(db, "kl-3x3")[1]).dataset
    group = next(t.params["group"] for t in wall_tags(db, "kl-3x3") if t.action == "toggle")
    tract = "/apps/census/kl-3x3/tracts/06061022001"
    census_state = read_state(db, "kl-3x3")[1]
    layout = get_layout(db, "kl-3x3", census_state.tag_layout)
    assert layout is not None
    captioned = next(p for p in layout.placed if p.get("label") and p.get("caption"))
    theme = {"attribute": "HH_INC", "scheme": "Blues", "method": "quantiles", "classes": 5}
    tile_theme = (
        f"/api/apps/census/walls/kl-3x3/tiles/r2c2/theme?dataset={dataset}"
        f"&layout={census_state.tag_layout}&{urlencode(theme)}"
    )
    # the brain atlas on a third wall, in quiz mode
    brain = client.post(
        "/api/walls/irregular/state",
        json={"app": "brain"},
        headers={"Authorization": f"Bearer {services_of(client).operator_token}"},
    )
    assert brain.status_code == 200, brain.text
    pin_code = next(t.code for t in wall_tags(db, "irregular") if t.action == "pin" and t.active)
    pin = f"/apps/brain/irregular/pins/{pin_code}"
    settings = services_of(client).settings
    settings.var_dir.mkdir(parents=True, exist_ok=True)
    picture = save(settings.var_dir / "picture.png", quadrants(40, 30))
    store = ImageLibrary().store(settings)
    image = store.add(picture).id
    spot = HotspotFields(x=10, y=10, title="Red", question="Which colour?", accepted=["red"])
    hotspot = hotspots.add(store, image, spot).id
    spots = f"/api/apps/image/images/{image}/hotspots"
    lesson_file = settings.var_dir / "picture.tagwall-lesson"
    lesson.export(store, image, lesson_file)
    movie = make("silent.mp4", settings.var_dir)
    video = VideoLibrary().store(settings).add(movie).id
    return [
        Row("GET", "/", "/", PUBLIC),
        Row("GET", "/wall/{wall_id}", "/wall/demo", PUBLIC),
        Row("GET", "/wall/{wall_id}/overview", "/wall/demo/overview", PUBLIC),
        Row("GET", "/wall/{wall_id}/tile/{tile_id}", "/wall/demo/tile/r1c1", (403,) * 4),
        Row("GET", "/healthz", "/healthz", PUBLIC),
        Row("GET", "/scan", "/scan", PUBLIC),
        Row("POST", "/scan", "/scan", (415,) * 4, files={"photo": ("a.txt", b"no", "text/plain")}),
        Row("GET", "/login", "/login", PUBLIC),
        Row(
            "POST",
            "/login",
            "/login",
            (401,) * 4,
            form={"username": "x-{role}", "password": "wrong"},
        ),
        Row("GET", "/login/operator", "/login/operator?token=wrong", (403,) * 4),
        # no campus provider here: tests/webapp/campus/test_oidc.py signs in through one
        Row("GET", "/login/oidc/{provider}", "/login/oidc/campus", (404,) * 4),
        Row(
            "GET",
            "/login/oidc/{provider}/callback",
            "/login/oidc/campus/callback?code=c&state=s",
            (404,) * 4,
        ),
        Row("GET", "/me", "/me", PUBLIC),
        Row("POST", "/me", "/me", PUBLIC, form={"user_group": "k5", "info_class": "1"}),
        Row("GET", "/api/walls", "/api/walls", PUBLIC),
        Row("GET", "/api/walls/{wall_id}", "/api/walls/demo", PUBLIC),
        Row(
            "GET",
            "/api/walls/{wall_id}/layouts/{layout_id}",
            f"/api/walls/demo/layouts/{state.tag_layout}",
            PUBLIC,
        ),
        Row("GET", "/codes/{name}", f"/codes/{setup}.svg", PUBLIC),
        Row("GET", "/t/{code}", f"/t/{setup}", PUBLIC),
        Row("GET", "/T/{code}", f"/T/{setup}", PUBLIC),
        Row("GET", "/p/{token}", "/p/" + "A" * 26, (404,) * 4),
        Row("GET", "/P/{token}", "/P/" + "A" * 26, (404,) * 4),
        Row("POST", "/p/{token}", "/p/" + "A" * 26, (404,) * 4, form={}),
        Row("POST", "/publish", "/publish", PUBLIC, form={"code": setup}),
        Row("GET", "/dashboard", "/dashboard", STAFF_PAGE),
        Row("GET", "/dashboard/admin", "/dashboard/admin", ADMIN_PAGE),
        Row(
            "POST",
            "/dashboard/admin/accounts",
            "/dashboard/admin/accounts",
            ADMIN_PAGE,
            form={"username": "newcomer", "role": "instructor", "password": TEST_PASSWORD},
        ),
        Row(
            "POST",
            "/dashboard/admin/accounts/{username}/remove",
            f"/dashboard/admin/accounts/{spare.username}/remove",
            ADMIN_PAGE,
            form={},
        ),
        Row(
            "POST",
            "/dashboard/admin/rules",
            "/dashboard/admin/rules",
            ADMIN_PAGE,
            form={"network": "10.201.0.0/16", "note": "matrix"},
        ),
        Row(
            "POST",
            "/dashboard/admin/rules/{rule_id}/remove",
            f"/dashboard/admin/rules/{rule.id}/remove",
            ADMIN_PAGE,
            form={},
        ),
        Row("GET", "/dashboard/lti", "/dashboard/lti", ADMIN_PAGE),
        Row(
            "POST",
            "/dashboard/lti",
            "/dashboard/lti",
            ADMIN_PAGE,
            form={
                "issuer": "https://lms.example.edu/{role}",
                "client_id": "tagwall",
                "deployment_ids": "1",
                "auth_url": "https://lms.example.edu/auth",
                "token_url": "https://lms.example.edu/token",
                "jwks_url": "https://lms.example.edu/jwks",
            },
        ),
        Row(
            "POST",
            "/dashboard/lti/{platform_id}/remove",
            "/dashboard/lti/999999/remove",
            ADMIN_PAGE,
            form={},
        ),
        # a learning platform's side: no session, no role; what it sends is checked
        Row("GET", "/lti/jwks", "/lti/jwks", PUBLIC),
        Row("GET", "/lti/login", "/lti/login", (400,) * 4),
        Row("POST", "/lti/login", "/lti/login", (400,) * 4, form={}),
        Row("POST", "/lti/launch", "/lti/launch", (400,) * 4, form={}),
        Row("POST", "/lti/deep-link", "/lti/deep-link", (400,) * 4, form={}),
        Row("POST", "/lti/continue", "/lti/continue", (410,) * 4, form={}),  # no such pass
        Row("GET", "/api/walls/{wall_id}/status", "/api/walls/demo/status", STAFF_API),
        Row("GET", "/api/walls/{wall_id}/tags", "/api/walls/demo/tags", STAFF_API),
        Row("POST", "/api/walls/{wall_id}/tags", "/api/walls/demo/tags", STAFF_API, json=tag),
        Row("GET", "/api/tags/{code}", f"/api/tags/{setup}", STAFF_API),
        Row("PATCH", "/api/tags/{code}", f"/api/tags/{setup}", STAFF_API, json={"label": "x"}),
        Row("GET", "/api/walls/{wall_id}/tag-sets", "/api/walls/demo/tag-sets", STAFF_API),
        Row(
            "PUT",
            "/api/walls/{wall_id}/tag-set",
            "/api/walls/demo/tag-set",
            STAFF_API,
            json={"name": "setup"},
        ),
        Row(
            "POST",
            "/api/walls/{wall_id}/state",
            "/api/walls/demo/state",
            STAFF_API,
            json={"layers": {"grid": False}},
        ),
        Row("GET", "/api/walls/{wall_id}/public", "/api/walls/demo/public", STAFF_API),
        Row(
            "POST",
            "/api/walls/{wall_id}/public/clear",
            "/api/walls/demo/public/clear",
            STAFF_API,
            json={},
        ),
        Row(
            "PUT",
            "/api/walls/{wall_id}/public/policy",
            "/api/walls/demo/public/policy",
            STAFF_API,
            json={"moderated": False, "locked": False},
        ),
        Row(
            "POST",
            "/api/walls/{wall_id}/public/{publication_id}/{decision}",
            "/api/walls/demo/public/999/approve",
            (401, 401, 404, 404),
            json={},
        ),
        Row("POST", "/api/pairing", "/api/pairing", STAFF_API, json={}),
        Row("GET", "/api/volumes", "/api/volumes", PUBLIC),
        Row(
            "GET",
            "/api/walls/{wall_id}/tiles/{tile_id}/volume",
            f"{tile_volume}?{urlencode({'scene': scene})}",
            (403, 403, OK, OK),
        ),
        Row(
            "GET",
            "/api/walls/{wall_id}/tiles/{tile_id}/volume",
            f"{tile_volume}?{urlencode({'scene': scene, 'detail': 'fallback'})}",
            PUBLIC,
        ),
        Row(
            "GET", "/api/walls/{wall_id}/volume/detail", "/api/walls/demo/volume/detail", STAFF_API
        ),
        Row(
            "GET",
            "/api/apps/census/walls/{wall_id}/tiles/{tile_id}",
            f"/api/apps/census/walls/kl-3x3/tiles/r2c2?dataset={dataset}",
            PUBLIC,
        ),
        Row("GET", "/api/apps/census/walls/{wall_id}/tiles/{tile_id}/theme", tile_theme, PUBLIC),
        Row(
            "GET",
            "/api/apps/census/walls/{wall_id}/globe",
            f"/api/apps/census/walls/kl-3x3/globe?dataset={dataset}&cx=0.5&cy=0.5&zoom=1",
            PUBLIC,
        ),
        # the site's imagery and terrain, relayed for tiles: none set here
        Row(
            "GET",
            "/apps/census/globe/imagery/{z}/{x}/{y}",
            "/apps/census/globe/imagery/3/1/2",
            (404, 404, 404, 404),
        ),
        Row(
            "GET",
            "/apps/census/globe/terrain/{path:path}",
            "/apps/census/globe/terrain/layer.json",
            (404, 404, 404, 404),
        ),
        Row("GET", "/apps/census/{wall_id}/tracts", "/apps/census/kl-3x3/tracts", PUBLIC),
        Row("GET", "/apps/census/{wall_id}/tracts/{geoid}", tract, PUBLIC),
        Row("GET", "/apps/census/{wall_id}/tracts/{geoid}/here", f"{tract}/here", PUBLIC),
        Row(
            "POST",
            "/apps/census/{wall_id}/tracts/{geoid}/balloon",
            f"{tract}/balloon",
            PUBLIC,
            form={},
        ),
        Row(
            "POST",
            "/apps/census/{wall_id}/groups/{group_id}/toggle",
            f"/apps/census/kl-3x3/groups/{group}/toggle",
            PUBLIC,
            form={},
        ),
        Row("GET", "/apps/census/census.kml", "/apps/census/census.kml?wall=kl-3x3", PUBLIC),
        Row("GET", "/apps/census/census.kmz", "/apps/census/census.kmz", PUBLIC),
        Row("GET", "/apps/census/network-link.kml", "/apps/census/network-link.kml", PUBLIC),
        Row(
            "POST",
            "/apps/census/{wall_id}/theme",
            "/apps/census/kl-3x3/theme",
            STAFF_PAGE,
            form={"attribute": "HH_INC"},
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/theme",
            "/api/apps/census/walls/kl-3x3/theme",
            STAFF_API,
            json={"theme": theme},
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/surface",
            "/api/apps/census/walls/kl-3x3/surface",
            STAFF_API,
            json={"surface": "flat"},
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/camera",
            "/api/apps/census/walls/kl-3x3/camera",
            STAFF_API,
            json={"heading": 0, "tilt": 0},
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/fly",
            "/api/apps/census/walls/kl-3x3/fly",
            STAFF_API,
            json={"group": group},
        ),
        Row(
            "PUT",
            "/api/apps/census/walls/{wall_id}/tour",
            "/api/apps/census/walls/kl-3x3/tour",
            STAFF_API,
            json={"steps": []},
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/tour/play",
            "/api/apps/census/walls/kl-3x3/tour/play",
            (401, 401, 409, 409),  # no steps kept
            json={},  # none needed: sends the CSRF header
        ),
        Row(
            "POST",
            "/api/apps/census/walls/{wall_id}/tour/stop",
            "/api/apps/census/walls/kl-3x3/tour/stop",
            STAFF_API,
            json={},
        ),
        Row("GET", "/api/apps/census/schemes", "/api/apps/census/schemes", STAFF_API),
        Row(
            "GET",
            "/apps/census/earth/{wall_id}/map.kmz",
            "/apps/census/earth/kl-3x3/map.kmz",
            PUBLIC,
        ),
        Row(
            "GET",
            "/apps/census/earth/{wall_id}/{display_id}.kml",
            "/apps/census/earth/kl-3x3/r2c2.kml",
            PUBLIC,
        ),
        Row(
            "GET",
            "/apps/census/earth/{wall_id}/{display_id}/wall.kml",
            "/apps/census/earth/kl-3x3/r2c2/wall.kml",
            PUBLIC,
        ),
        Row(
            "GET",
            "/apps/census/earth/{wall_id}/captions/{layout_id}/{code}.png",
            f"/apps/census/earth/kl-3x3/captions/{census_state.tag_layout}/{captioned['code']}.png",
            PUBLIC,
        ),
        Row("GET", "/api/apps/census/datasets", "/api/apps/census/datasets", STAFF_API),
        Row(
            "GET",
            "/api/apps/census/datasets/{dataset_id}",
            f"/api/apps/census/datasets/{dataset}",
            STAFF_API,
        ),
        Row(
            "POST",
            "/api/apps/census/current",
            "/api/apps/census/current",
            STAFF_API,
            json={"dataset": dataset},
        ),
        Row("GET", "/apps/brain/{wall_id}/pins/{code}", pin, PUBLIC),
        Row(
            "POST",
            "/apps/brain/{wall_id}/pins/{code}/answer",
            f"{pin}/answer",
            PUBLIC,
            form={"answer": "thalamus"},
        ),
        Row(
            "POST",
            "/apps/brain/{wall_id}/pins/{code}/reveal",
            f"{pin}/reveal",
            (403, 403, OK, OK),
            form={},
        ),
        # the literature names the region: closed while the quiz is on, for everyone
        Row(
            "GET",
            "/apps/brain/{wall_id}/pins/{code}/literature",
            f"{pin}/literature",
            (409, 409, 409, 409),
        ),
        Row(
            "GET", "/apps/brain/{wall_id}/quiz/{tag_set}", "/apps/brain/irregular/quiz/full", PUBLIC
        ),
        Row(
            "POST",
            "/apps/brain/{wall_id}/quiz/{tag_set}/finish",
            "/apps/brain/irregular/quiz/full/finish",
            PUBLIC,
            form={},
        ),
        Row("GET", "/apps/brain/{wall_id}/groups", "/apps/brain/irregular/groups", PUBLIC),
        Row(
            "POST",
            "/apps/brain/{wall_id}/groups/{group}",
            "/apps/brain/irregular/groups/medical",
            PUBLIC,
            form={},
        ),
        Row("GET", "/api/apps/brain/walls/{wall_id}", "/api/apps/brain/walls/irregular", STAFF_API),
        Row(
            "POST",
            "/api/apps/brain/walls/{wall_id}",
            "/api/apps/brain/walls/irregular",
            STAFF_API,
            json={"mode": "quiz"},
        ),
        Row(
            "POST",
            "/api/apps/brain/walls/{wall_id}/quiz/reset",
            "/api/apps/brain/walls/irregular/quiz/reset",
            STAFF_API,
            json={},
        ),
        Row(
            "POST",
            "/api/apps/brain/walls/{wall_id}/quiz/close",
            "/api/apps/brain/walls/irregular/quiz/close",
            STAFF_API,
            json={},
        ),
        Row(
            "GET",
            "/api/apps/brain/walls/{wall_id}/answers.csv",
            "/api/apps/brain/walls/irregular/answers.csv",
            STAFF_API,
        ),
        Row(
            "GET",
            "/api/apps/brain/walls/{wall_id}/unshown",
            "/api/apps/brain/walls/irregular/unshown",
            STAFF_API,
        ),
        Row("GET", "/api/walls/{wall_id}/own-codes", "/api/walls/irregular/own-codes", STAFF_API),
        Row("GET", "/api/walls/{wall_id}/places", "/api/walls/irregular/places", STAFF_API),
        Row(
            "POST",
            "/api/walls/{wall_id}/own-codes",
            "/api/walls/irregular/own-codes",
            STAFF_API,
            json={"kind": "text", "label": "Note", "text": "Hello", "anchor": [100, 100]},
        ),
        Row("GET", "/api/walls/{wall_id}/class", "/api/walls/irregular/class", STAFF_API),
        Row("POST", "/api/walls/{wall_id}/class", "/api/walls/irregular/class", STAFF_API, json={}),
        Row(
            "POST",
            "/api/walls/{wall_id}/class/end",
            "/api/walls/irregular/class/end",
            (401, 401, OK, 409),  # the admin comes after the instructor ended the class
            json={},
        ),
        # No class runs at demo: anyone is told it ended (the roll call needs none).
        Row("GET", "/classes/{class_id}/join", "/classes/1/join", (410, 410, 410, 410)),
        Row(
            "POST",
            "/classes/{class_id}/join",
            "/classes/1/join",
            (410, 410, 410, 410),
            form={"name": "{role}"},
        ),
        Row("GET", "/api/apps/image/images", "/api/apps/image/images", STAFF_API),
        Row(
            "POST",
            "/api/apps/image/images",
            "/api/apps/image/images",
            STAFF_API,
            form={"title": "{role}"},
            files={"file": ("picture.png", picture.read_bytes(), "image/png")},
        ),
        Row(
            "PATCH",
            "/api/apps/image/images/{image_id}",
            f"/api/apps/image/images/{image}",
            STAFF_API,
            json={"title": "Picture"},
        ),
        Row(
            "DELETE",
            "/api/apps/image/images/{image_id}",
            f"/api/apps/image/images/{'f' * 12}",
            (401, 401, 404, 404),
            json={},
        ),
        Row(
            "GET",
            "/api/apps/image/images/{image_id}/lesson",
            f"/api/apps/image/images/{image}/lesson",
            STAFF_API,
        ),
        Row(
            "POST",
            "/api/apps/image/lessons",
            "/api/apps/image/lessons",
            STAFF_API,
            form={},  # the CSRF token goes in the form
            files={"file": ("picture.tagwall-lesson", lesson_file.read_bytes(), "application/zip")},
        ),
        Row(
            "GET",
            "/apps/image/images/{image_id}/info.json",
            f"/apps/image/images/{image}/info.json",
            PUBLIC,
        ),
        Row(
            "GET",
            "/apps/image/images/{image_id}/{level}/{col}_{row}.jpg",
            f"/apps/image/images/{image}/6/0_0.jpg",
            PUBLIC,
        ),
        Row("GET", "/api/apps/image/images/{image_id}/hotspots", spots, STAFF_API),
        Row(
            "POST",
            "/api/apps/image/images/{image_id}/hotspots",
            spots,
            STAFF_API,
            json={"x": 1, "y": 1, "title": "{role}"},
        ),
        Row(
            "PUT",
            "/api/apps/image/images/{image_id}/hotspots/{hotspot_id}",
            f"{spots}/{hotspot}",
            STAFF_API,
            json=spot.model_dump(),
        ),
        Row(
            "DELETE",
            "/api/apps/image/images/{image_id}/hotspots/{hotspot_id}",
            f"{spots}/{'f' * 12}",
            (401, 401, 404, 404),
            json={},
        ),
        # a code no wall shows: nobody gets a page (the phones' flow: image/routes/test_phones)
        Row(
            "GET",
            "/apps/image/{wall_id}/hotspots/{code}",
            "/apps/image/demo/hotspots/X",
            (404,) * 4,
        ),
        Row(
            "POST",
            "/apps/image/{wall_id}/hotspots/{code}/answer",
            "/apps/image/demo/hotspots/X/answer",
            (404,) * 4,
            form={"answer": "red"},
        ),
        # late: it puts the image app on the demo wall
        Row(
            "POST",
            "/api/apps/image/walls/{wall_id}/show",
            "/api/apps/image/walls/demo/show",
            STAFF_API,
            json={"image": image},
        ),
        Row(
            "POST",
            "/api/apps/image/walls/{wall_id}/quiz/start",
            "/api/apps/image/walls/demo/quiz/start",
            STAFF_API,
            json={},
        ),
        Row("GET", "/api/apps/image/walls/{wall_id}", "/api/apps/image/walls/demo", STAFF_API),
        Row(
            "POST",
            "/api/apps/image/walls/{wall_id}/quiz/close",
            "/api/apps/image/walls/demo/quiz/close",
            STAFF_API,
            json={},
        ),
        Row(
            "GET",
            "/api/apps/image/walls/{wall_id}/answers.csv",
            "/api/apps/image/walls/demo/answers.csv",
            STAFF_API,
        ),
        Row("GET", "/api/apps/video/videos", "/api/apps/video/videos", STAFF_API),
        Row(
            "POST",
            "/api/apps/video/videos",
            "/api/apps/video/videos",
            STAFF_API,
            form={"title": "{role}"},
            files={"file": ("movie.mp4", movie.read_bytes(), "video/mp4")},
        ),
        Row(
            "DELETE",
            "/api/apps/video/videos/{video_id}",
            f"/api/apps/video/videos/{'f' * 12}",
            (401, 401, 404, 404),
            json={},
        ),
        Row(
            "GET",
            "/apps/video/videos/{video_id}/info.json",
            f"/apps/video/videos/{video}/info.json",
            PUBLIC,
        ),
        Row(
            "GET",
            "/apps/video/videos/{video_id}/{file_name}",
            f"/apps/video/videos/{video}/video.mp4",
            PUBLIC,
        ),
        Row("GET", "/apps/video/{wall_id}/remote", "/apps/video/demo/remote", STAFF_PAGE),
        Row(
            "GET",
            "/api/apps/video/walls/{wall_id}/remote",
            "/api/apps/video/walls/demo/remote",
            STAFF_API,
        ),
        Row("GET", "/api/apps/video/walls/{wall_id}", "/api/apps/video/walls/demo", STAFF_API),
        # after the image app's rows: it puts the video app on the demo wall
        Row(
            "POST",
            "/api/apps/video/walls/{wall_id}/show",
            "/api/apps/video/walls/demo/show",
            STAFF_API,
            json={"video": video},
        ),
        *(
            Row(
                "POST",
                f"/api/apps/video/walls/{{wall_id}}/{step}",
                f"/api/apps/video/walls/demo/{step}",
                STAFF_API,
                json=body,
            )
            for step, body in [("play", {}), ("pause", {}), ("seek", {"to_s": 0.5})]
        ),
        Row(
            "PUT",
            "/api/apps/video/walls/{wall_id}/loop",
            "/api/apps/video/walls/demo/loop",
            STAFF_API,
            json={"loop": True},
        ),
        Row(
            "PUT",
            "/api/apps/video/walls/{wall_id}/sound",
            "/api/apps/video/walls/demo/sound",
            STAFF_API,
            json={"display": "r2c2"},
        ),
        Row("POST", "/logout", "/logout", PUBLIC, form={}),  # last: it drops the role
    ]


def client_as(app: FastAPI, role: str, index: int) -> TestClient:
    # Each role from its own address, so their failed sign-ins do not throttle each other.
    client = TestClient(app, client=(f"10.0.0.{index + 1}", 50000))
    client.__enter__()
    if role == "student":
        register_student(client)
    elif role in ("instructor", "admin"):
        sign_in(client, role)
    return client


def outcome(response: Any) -> object:
    if response.status_code == 303 and response.headers["location"].startswith("/login"):
        return LOGIN
    if response.status_code < 400:
        return OK
    return response.status_code


@pytest.mark.walls("demo", "irregular", "kl-3x3")
def test_the_privilege_matrix(app: FastAPI) -> None:
    clients = [client_as(app, role, index) for index, role in enumerate(ROLES)]
    try:
        rows = matrix(clients[0])
        failures = []
        for row in rows:
            for role, client, expected in zip(ROLES, clients, row.expected, strict=True):
                csrf = csrf_of(client)
                form = (
                    {**{k: v.format(role=role) for k, v in row.form.items()}, "csrf": csrf}
                    if row.form is not None
                    else None
                )
                try:
                    response = client.request(
                        row.method,
                        row.url,
                        data=form,
                        json=row.json,
                        files=row.files,
                        headers={"X-CSRF-Token": csrf} if row.json is not None else {},
                        follow_redirects=False,
                    )
                except Exception as error:  # the server raised: say which request
                    error.add_note(f"{role} {row.method} {row.url}")
                    raise
                got = outcome(response)
                if got != expected:
                    failures.append(f"{role} {row.method} {row.url}: {got}, expected {expected}")
                assert "Traceback" not in response.text
        assert not failures, "\n".join(failures)
    finally:
        for client in clients:
            client.__exit__(None, None, None)


WEBSOCKETS = {
    (
        "WS",
        "/ws/wall/{wall_id}/tile/{tile_id}",
    ),  # tile token: tests/webapp/server/routes/test_ws.py
    ("WS", "/ws/wall/{wall_id}/view"),  # public, read only
    ("WS", "/ws/dashboard/{wall_id}"),  # test_the_dashboard_socket_is_for_instructors
}


@pytest.mark.walls("demo", "irregular", "kl-3x3")
def test_the_matrix_covers_every_route(client: TestClient) -> None:
    covered = {(row.method, row.route) for row in matrix(client)} | WEBSOCKETS
    missing = routes_of(client.app) - covered  # type: ignore[arg-type]
    assert not missing, f"routes without a row in the privilege matrix: {sorted(missing)}"


@pytest.mark.parametrize("role,allowed", list(zip(ROLES, (False, False, True, True), strict=True)))
def test_the_dashboard_socket_is_for_instructors(app: FastAPI, role: str, allowed: bool) -> None:
    client = client_as(app, role, 0)
    try:
        with client.websocket_connect(
            "/ws/dashboard/demo", headers={"origin": "http://testserver"}
        ) as socket:
            if allowed:
                message = socket.receive_json()
                assert message["type"] == "status" and message["status"]["wall"] == "demo"
            else:
                with pytest.raises(WebSocketDisconnect) as closed:
                    socket.receive_json()
                assert closed.value.code == 1008
    finally:
        client.__exit__(None, None, None)


def test_the_dashboard_socket_refuses_other_sites(app: FastAPI) -> None:
    client = client_as(app, "instructor", 0)
    try:
        with client.websocket_connect(
            "/ws/dashboard/demo", headers={"origin": "http://evil.example"}
        ) as socket:
            with pytest.raises(WebSocketDisconnect) as closed:
                socket.receive_json()
            assert closed.value.code == 1008
    finally:
        client.__exit__(None, None, None)


def test_staff_api_writes_need_the_csrf_header(app: FastAPI) -> None:
    """A page on another site can make the browser send the cookie, never the header."""
    client = client_as(app, "instructor", 0)
    try:
        forged = client.post("/api/walls/demo/state", json={"layers": {"grid": False}})
        assert forged.status_code == 403
        wrong = client.post(
            "/api/walls/demo/state",
            json={"layers": {"grid": False}},
            headers={"X-CSRF-Token": "guess"},
        )
        assert wrong.status_code == 403
        assert read_state(services_of(client).db, "demo")[1].layers == {}
    finally:
        client.__exit__(None, None, None)


def test_a_wrong_bearer_token_is_401_even_with_a_staff_session(app: FastAPI) -> None:
    client = client_as(app, "admin", 0)
    try:
        response = client.get("/api/walls/demo/status", headers={"Authorization": "Bearer nope"})
        assert response.status_code == 401
    finally:
        client.__exit__(None, None, None)
