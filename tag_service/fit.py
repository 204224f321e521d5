"""Whether a wall has room for the codes it must carry, and what would make room.

A wall file can be valid and still leave no room for its codes: seat codes grow with
the seat distance, so a 2 x 2 wall of 27-inch panels scanned from 4 m needs 436 mm
codes on displays 336 mm tall. The server then places what it can and lists the rest
as unplaced, which nobody reads before class. So this module asks the server's own
placement (:func:`tag_service.placement.place`, captions included), never a rule of
its own that could disagree with it, and when codes do not fit it searches, with the
same placement, the largest distance at which they do.

Only codes whose place does not depend on what the wall shows are checked: the slot
codes of the designated screens (registration, menu, public), and one walk-up code on
the displays anchored codes may use. A screen the wall does not have is not checked:
a wall without a menu screen shows no menu by its own choice.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm
from wall_client.layout import ROLES, CodePurpose, Wall

STEP_M = 0.1
"""Distances are searched and reported in steps of this (a row of seats is coarser)."""
NEAREST_M = 0.1
"""The nearest distance considered: nearer than this, no code gets smaller anyway
(modules never drop below three pixels)."""
CORE = "core"
"""The owner of the codes every wall carries (the registration codes)."""


@dataclass(frozen=True)
class SlotCode:
    """A code standing in a slot of a designated screen, as the placement sees it."""

    label: str  # its caption, and its name in messages
    screen: str
    slot: int
    sizes: tuple[int, ...]  # symbol widths in modules, quiet zone included, tried in order


@dataclass(frozen=True)
class FitProblem:
    """Codes that find no place at a wall's design distance, and what would fix it."""

    owner: str  # CORE, or the app whose codes (on the wall with the core's) do not fit
    screen: str  # a screen role, or "stage" for walk-up codes
    labels: tuple[str, ...]  # the codes left out
    purpose: CodePurpose
    distance_m: float  # the design distance checked
    fits_up_to_m: float | None  # the largest distance that fits; None: none does
    required: bool  # core codes are left out: the wall cannot be used as it is

    def message(self) -> str:
        """One plain line: what does not fit where, and what would."""
        if self.screen == "stage":
            return self._walk_up_message()
        names = _names(self.labels)
        verb = "does" if len(self.labels) == 1 else "do"
        where = f"the {self.screen} screen"
        shown = "" if self.owner == CORE else f" with the {self.owner} app on the wall"
        head = f"{names} {verb} not fit {where} at {self.distance_m:g} m{shown}"
        if self.fits_up_to_m is None:
            return f"{head}, from no seat: give {where} more displays (or larger ones)"
        return f"{head}: seats up to {self.fits_up_to_m:g} m fit, or give {where} more displays"

    def _walk_up_message(self) -> str:
        head = (
            f"walk-up codes (marking the scene) do not fit any display of the stage"
            f" at {self.distance_m:g} m"
        )
        if self.fits_up_to_m is None:
            return f"{head}, from no distance: use displays with more pixels"
        return f"{head}: walk-up distances up to {self.fits_up_to_m:g} m fit"


def _names(labels: Sequence[str]) -> str:
    """``Student and Instructor codes``, ``the Tract index code``; a long menu is
    counted, so the line stays one line."""
    if len(labels) == 1:
        return f"the {labels[0]} code"
    if len(labels) > 4:
        return f"{len(labels)} codes ({labels[0]}, {labels[1]} ... {labels[-1]})"
    return f"{', '.join(labels[:-1])} and {labels[-1]} codes"


def left_out(wall: Wall, codes: Sequence[SlotCode], distance_m: float) -> list[SlotCode]:
    """The slot ``codes`` the placement leaves out when seat codes are sized for
    ``distance_m`` (the same requests the server makes, captions included)."""
    module_mm = min_module_mm(distance_m)
    requests = [
        PlacementRequest(
            key=str(index),
            sizes=code.sizes,
            module_mm=module_mm,
            screen=code.screen,
            slot=code.slot,
            caption=bool(code.label),
        )
        for index, code in enumerate(codes)
    ]
    return [codes[int(unplaced.key)] for unplaced in place(wall, requests).unplaced]


def walk_up_fits(wall: Wall, sizes: tuple[int, ...], distance_m: float) -> bool:
    """Whether one captioned walk-up code finds a place, anchored at the middle of some
    display anchored codes may use: if not, no scene code ever stands on this wall."""
    module_mm = min_module_mm(distance_m)
    designated = wall.designated()
    for display in wall.displays:
        if display.id in designated:
            continue
        request = PlacementRequest(
            key="walk-up",
            sizes=sizes,
            module_mm=module_mm,
            anchor=wall.viewport(display.id).scene_rect.center,
            caption=True,
        )
        if place(wall, [request]).placed:
            return True
    return False


def fits_display(
    wall: Wall, display_id: str, sizes: tuple[int, ...], distance_m: float, purpose: CodePurpose
) -> bool:
    """Whether one captioned code of ``purpose`` sized for ``distance_m`` stands on the
    display ``display_id`` as the server would place it there: a seat code alone on a
    screen of that display, a walk-up code anchored at its middle (what ``tagwall codes
    size`` reports per display, so it never shows a code the server cannot place)."""
    module_mm = min_module_mm(distance_m)
    if purpose == "seat":
        alone = replace(wall, screens={"menu": (display_id,)})
        request = PlacementRequest(
            key="seat", sizes=sizes, module_mm=module_mm, screen="menu", caption=True
        )
    else:
        alone = replace(wall, screens={})
        middle = wall.viewport(display_id).scene_rect.center
        request = PlacementRequest(
            key="walk-up", sizes=sizes, module_mm=module_mm, anchor=middle, caption=True
        )
    placed = place(alone, [request]).placed
    return bool(placed) and placed[0].display_id == display_id


def largest_distance(fits: Callable[[float], bool], below_m: float) -> float | None:
    """The largest distance, a whole number of :data:`STEP_M` under ``below_m`` (where
    it does not fit), at which ``fits``; None when not even :data:`NEAREST_M` does.

    A bisection: nearer means modules no larger on every display, so codes that fit
    at a distance fit at every nearer one."""
    if not fits(NEAREST_M):
        return None
    low = round(NEAREST_M / STEP_M)  # fits
    high = max(low + 1, math.ceil(below_m / STEP_M - 1e-9))  # taken not to fit
    while high - low > 1:
        middle = (low + high) // 2
        if fits(middle * STEP_M):
            low = middle
        else:
            high = middle
    return round(low * STEP_M, 1)


def check_fit(
    wall: Wall,
    core: Sequence[SlotCode],
    apps: Mapping[str, Sequence[SlotCode]],
    walk_up_sizes: tuple[int, ...] | None = None,
) -> list[FitProblem]:
    """What does not fit ``wall`` at its design distances: the ``core`` codes on their
    own, then each app's codes on the screens with the core's (a wall shows one app at
    a time, and an app's slot codes share a screen's grid with the core's, so an app can
    crowd the core's codes out), then a walk-up code of ``walk_up_sizes``.

    Core codes left out make a problem ``required``, whichever codes crowd them out."""
    seat = wall.seat_distance_m
    has = {role for role in ROLES if wall.screen(role)}
    problems: list[FitProblem] = []
    core_out: set[str] = set()
    for screen in sorted({code.screen for code in core} & has):
        mine = [code for code in core if code.screen == screen]
        out = left_out(wall, mine, seat)
        if out:
            core_out.update(code.label for code in out)
            problems.append(_problem(wall, CORE, screen, mine, out, required=True))
    for name, codes in sorted(apps.items()):
        for screen in sorted({code.screen for code in codes} & has):
            together = [code for code in (*core, *codes) if code.screen == screen]
            out = [code for code in left_out(wall, together, seat) if code.label not in core_out]
            if out:
                crowded = any(code in core for code in out)
                problems.append(_problem(wall, name, screen, together, out, required=crowded))
    if walk_up_sizes and not walk_up_fits(wall, walk_up_sizes, wall.walk_up_distance_m):
        up_to = largest_distance(
            lambda d: walk_up_fits(wall, walk_up_sizes, d), wall.walk_up_distance_m
        )
        problems.append(
            FitProblem(CORE, "stage", (), "walk-up", wall.walk_up_distance_m, up_to, False)
        )
    return problems


def _problem(
    wall: Wall,
    owner: str,
    screen: str,
    codes: Sequence[SlotCode],
    out: Sequence[SlotCode],
    *,
    required: bool,
) -> FitProblem:
    """The problem of ``out`` among ``codes`` on ``screen``, with the largest seat
    distance at which all of ``codes`` fit there."""
    up_to = largest_distance(lambda d: not left_out(wall, codes, d), wall.seat_distance_m)
    labels = tuple(code.label for code in out)
    return FitProblem(owner, screen, labels, "seat", wall.seat_distance_m, up_to, required)
