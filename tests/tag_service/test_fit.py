"""Whether a wall has room for its codes, asked of the placement itself (issue 31)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from tag_service.fit import (
    CORE,
    FitProblem,
    SlotCode,
    check_fit,
    fits_display,
    largest_distance,
    left_out,
    walk_up_fits,
)
from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm, symbol_modules
from wall_client.config import parse_wall
from wall_client.layout import Wall

V2 = symbol_modules(25)  # a LAN URL's code: 33 modules across with the quiet zone
REGISTRATION = [
    SlotCode("Student", "registration", 0, (V2,)),
    SlotCode("Instructor", "registration", 1, (V2,)),
]


def wall(seat_distance_m: float = 4.0, resolution: tuple[int, int] = (3840, 2160)) -> Wall:
    """Issue 31's wall: 2 x 2 27-inch panels, 12 mm bezels, students 3-4 m away."""
    return parse_wall(
        {
            "id": "class",
            "seat_distance_m": seat_distance_m,
            "grid": {
                "columns": 2,
                "rows": 2,
                "resolution": list(resolution),
                "active_mm": [597.7, 336.2],
                "bezel_mm": 12,
            },
        }
    )


def test_the_registration_codes_that_do_not_fit_at_4_m_fit_at_the_distance_reported() -> None:
    cramped = wall()
    [problem] = check_fit(cramped, REGISTRATION, {})
    assert problem == FitProblem(
        owner=CORE,
        screen="registration",
        labels=("Student", "Instructor"),
        purpose="seat",
        distance_m=4.0,
        fits_up_to_m=2.5,
        required=True,
    )
    # as the server places them, at that distance, and not a step beyond
    assert left_out(cramped, REGISTRATION, 2.5) == []
    assert left_out(cramped, REGISTRATION, 2.6) == REGISTRATION
    assert check_fit(wall(seat_distance_m=2.5), REGISTRATION, {}) == []
    assert problem.message() == (
        "Student and Instructor codes do not fit the registration screen at 4 m:"
        " seats up to 2.5 m fit, or give the registration screen more displays"
    )


def test_a_code_that_fits_its_display_but_not_with_its_caption_does_not_fit() -> None:
    """At 3 m the code is 2112 px on 2160 px displays: `codes size` said 328 mm and
    nothing more, yet its caption (a fifth of a side) leaves no room for it."""
    cramped = wall()
    module_mm = min_module_mm(3.0)
    bare = PlacementRequest(key="a", sizes=(V2,), module_mm=module_mm, screen="registration")
    assert place(cramped, [bare]).placed, "the symbol alone would fit"
    assert place(cramped, [replace(bare, caption=True)]).unplaced
    assert not fits_display(cramped, "r2c1", (V2,), 3.0, "seat")
    assert fits_display(cramped, "r2c1", (V2,), 2.5, "seat")


def test_a_screen_too_small_from_any_seat_says_it_needs_more_room() -> None:
    tiny = wall(seat_distance_m=2.0, resolution=(160, 90))  # 3 px modules still too big
    [problem] = check_fit(tiny, REGISTRATION, {})
    assert problem.fits_up_to_m is None and problem.required
    assert problem.message() == (
        "Student and Instructor codes do not fit the registration screen at 2 m, from no"
        " seat: give the registration screen more displays (or larger ones)"
    )


def test_an_app_whose_codes_do_not_fit_beside_the_core_codes_is_a_warning() -> None:
    """A third code on the registration screen makes the grid's cells narrower: on
    this wall the census map's tract index finds no place from 1.9 m on."""
    index = {"census": [SlotCode("Tract index", "registration", 2, (V2,))]}
    menu = {"brain": [SlotCode(f"group {n}", "menu", n, (V2,)) for n in range(1, 11)]}
    assert check_fit(wall(seat_distance_m=1.8), REGISTRATION, index | menu) == []
    [problem] = check_fit(wall(seat_distance_m=2.0), REGISTRATION, index)
    assert (problem.owner, problem.labels, problem.fits_up_to_m) == (
        "census",
        ("Tract index",),
        1.8,
    )
    assert not problem.required
    assert problem.message() == (
        "the Tract index code does not fit the registration screen at 2 m with the census"
        " app on the wall: seats up to 1.8 m fit, or give the registration screen more displays"
    )


def test_an_app_that_crowds_a_core_code_out_is_an_error() -> None:
    welcome = {"welcome": [SlotCode("Welcome", "registration", 0, (V2,))]}
    [problem] = check_fit(wall(seat_distance_m=2.0), REGISTRATION, welcome)
    assert problem.owner == "welcome" and problem.labels == ("Instructor",)
    assert problem.required


def test_screens_the_wall_does_not_have_are_not_checked() -> None:
    """No menu screen: the wall shows no menu by its own choice."""
    menu = [SlotCode("K-5", "menu", 1, (V2,))]
    assert check_fit(wall(seat_distance_m=2.0), REGISTRATION, {"brain": menu}) == []


def test_walk_up_codes_are_checked_on_the_displays_anchored_codes_use() -> None:
    cramped = wall()
    far = replace(cramped, walk_up_distance_m=4.0)
    assert walk_up_fits(cramped, (V2,), 0.8)
    assert not walk_up_fits(far, (V2,), 4.0)
    [problem] = check_fit(far, [], {}, walk_up_sizes=(V2,))
    assert problem.screen == "stage" and not problem.required
    assert problem.fits_up_to_m is not None
    assert walk_up_fits(far, (V2,), problem.fits_up_to_m)
    assert not walk_up_fits(far, (V2,), problem.fits_up_to_m + 0.1)


@pytest.mark.parametrize(("threshold", "expected"), [(2.93, 2.9), (0.05, None), (7.0, 3.9)])
def test_the_largest_distance_is_searched_in_tenths_of_a_metre(
    threshold: float, expected: float | None
) -> None:
    assert largest_distance(lambda d: d <= threshold, 4.0) == expected
