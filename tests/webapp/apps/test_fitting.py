"""What ``config check``, ``serve`` and the dashboard say fits is what the server places:
the apps' screen tags, registered as the server registers them and placed by the
registry's own layout (issue 31)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from tag_service.codes import new_code
from wall_client.config import parse_wall
from wall_client.layout import Wall
from webapp.apps.discovery import installed_apps
from webapp.apps.fitting import wall_fit
from webapp.apps.hooks import WallApp
from webapp.database.models import TagRecord
from webapp.tags.registry import _fill, compute_layout, payload_of

BASE_URL = "http://192.168.1.20:8000"
CRAMPED = parse_wall(
    {
        "id": "cramped",
        "grid": {
            "columns": 2,
            "rows": 2,
            "resolution": [3840, 2160],
            "active_mm": [597.7, 336.2],
            "bezel_mm": 12,
        },
    }
)
"""Issue 31's wall: 2 x 2 27-inch 4K panels, 12 mm bezels."""


@pytest.fixture(scope="module")
def apps() -> dict[str, WallApp]:
    return installed_apps()


def server_leaves_out(wall: Wall, apps: list[WallApp]) -> list[str]:
    """The labels of the apps' screen tags the server's layout leaves out, on the
    screens the wall has (a wall without a menu screen shows no menu by its choice)."""
    tags = []
    for app in apps:
        for spec in app.screen_tags(wall):
            if spec.screen is None or not wall.screen(spec.screen):
                continue
            record = TagRecord(code=new_code(), wall_id=wall.id)
            _fill(record, spec)
            tags.append(record)
    _, unplaced = compute_layout(wall, tags, [payload_of(tag, BASE_URL) for tag in tags])
    return sorted(code["label"] for code in unplaced)


@pytest.mark.parametrize(
    ("distance_m", "shown", "left_out"),
    [
        (2.5, "pattern", []),
        (2.6, "pattern", ["Instructor", "Student"]),
        (1.8, "census", []),
        (1.9, "census", ["Tract index"]),
    ],
)
def test_what_the_check_says_fits_is_what_the_server_places(
    apps: dict[str, WallApp], distance_m: float, shown: str, left_out: list[str]
) -> None:
    wall = replace(CRAMPED, seat_distance_m=distance_m)
    installed = {"core": apps["core"], shown: apps[shown]}
    said = sorted(
        label for problem in wall_fit(wall, installed, BASE_URL) for label in problem.labels
    )
    assert said == left_out == server_leaves_out(wall, list(installed.values()))


def test_the_distance_the_check_offers_for_a_menu_is_where_the_server_places_it(
    apps: dict[str, WallApp],
) -> None:
    with_menu = replace(
        CRAMPED, seat_distance_m=4.0, screens={**CRAMPED.screens, "menu": ("r1c2",)}
    )
    installed = {"core": apps["core"], "brain": apps["brain"]}
    menu = [p for p in wall_fit(with_menu, installed, BASE_URL) if p.screen == "menu"]
    [problem] = menu
    assert problem.owner == "brain" and problem.fits_up_to_m is not None
    assert problem.labels == ("K-5", "Undergraduate", "Medical", "Research")
    fits = replace(with_menu, seat_distance_m=problem.fits_up_to_m)
    beyond = replace(with_menu, seat_distance_m=problem.fits_up_to_m + 0.1)
    brain = [apps["brain"]]
    assert server_leaves_out(fits, brain) == []
    assert server_leaves_out(beyond, brain) != []
