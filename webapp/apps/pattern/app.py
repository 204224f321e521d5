"""The setup test pattern: a calibration code on every display, for installers.

Scanning one tells the phone which display it is, where the code stands and how big
its modules are, so a wrongly cabled or mis-configured display shows up at once. A
code on the bezel between the first two side-by-side displays shows placement at work: it
cannot stand on the bezel, so it moves onto a display and a pin points back (on
walls whose displays hold only one code at the design distance, it is reported as
unplaceable instead, which the dashboard shows).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi import Response

from wall_client.layout import ROLES, Display, Wall
from webapp.apps.hooks import VOLUME_LAYER, Scan, WallApp, static_url
from webapp.database.models import TagLayoutRecord
from webapp.engine.wall_state import WallState, read_state
from webapp.publishing.publication import Block, Publication
from webapp.tags.registry import TagSpec
from webapp.web.context import AppContext
from webapp.web.templating import render

FOLDER = Path(__file__).parent
SETUP_SET = "setup"


class PatternApp(WallApp):
    name: str = "pattern"
    default_tag_set: str | None = SETUP_SET
    # a volume the dashboard puts up shows instead of the pattern
    layers: tuple[str, ...] = (VOLUME_LAYER, f"{static_url('pattern')}/scene.js")
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        designated = {d.id for role in ROLES for d in wall.screen(role)}
        free = [d for d in wall.displays if d.id not in designated]
        tags = [self._tag(f"setup-{d.id}", f"Display {d.id}", d.rect.center) for d in free]
        for left, right in _side_by_side(free)[:1]:
            x = (left.rect.right + right.rect.x) / 2
            y = (max(left.rect.y, right.rect.y) + min(left.rect.bottom, right.rect.bottom)) / 2
            tags.append(
                self._tag(f"setup-{left.id}-{right.id}", f"Bezel {left.id}|{right.id}", (x, y))
            )
        return tags

    def _tag(self, name: str, label: str, anchor: tuple[float, float]) -> TagSpec:
        return TagSpec(
            name=name, label=label, app=self.name, action="locate", tag_set=SETUP_SET, anchor=anchor
        )

    async def on_scan(self, scan: Scan) -> Response:
        placed, display = await _placement_of(scan)
        return render(
            scan.request,
            "pattern/locate.html",
            wall=scan.wall,
            tag=scan.tag,
            placed=placed,
            display=display,
        )

    async def publication(self, scan: Scan) -> Publication | None:
        """Where this code stands, for everyone at the wall to check."""
        placed, display = await _placement_of(scan)
        if placed is None or display is None:
            return None
        x, y, size, _ = placed["rect"]
        return Publication(
            title=scan.tag.label,
            blocks=[
                Block(
                    kind="facts",
                    rows=[
                        ("Display", f"{display.id} (node {display.node}, output {display.index})"),
                        ("Code at", f"{x:.0f}, {y:.0f} mm from the top-left corner"),
                        ("Code size", f"{size:.0f} mm, {placed['px_per_module']} px per module"),
                    ],
                )
            ],
        )

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "pattern/panel.html"


async def _placement_of(scan: Scan) -> tuple[dict[str, Any] | None, Display | None]:
    """Where the scanned code stands in the wall's current layout (None: not placed)."""
    layout = await scan.context.db.read(_current_layout, scan.context, scan.wall.id)
    placed = next(
        (p for p in (layout.placed if layout else []) if p["code"] == scan.tag.code), None
    )
    return placed, scan.wall.display(placed["display"]) if placed else None


def _current_layout(context: AppContext, wall_id: str) -> TagLayoutRecord | None:
    _, state = read_state(context.db, wall_id)
    return context.layout(wall_id, state.tag_layout)


def _side_by_side(displays: list[Display]) -> list[tuple[Display, Display]]:
    """Pairs of displays next to each other in a row (sharing most of their height)."""
    pairs = []
    for left in displays:
        right = min(
            (
                d
                for d in displays
                if d.rect.x >= left.rect.right
                and min(d.rect.bottom, left.rect.bottom) - max(d.rect.y, left.rect.y)
                > left.rect.height / 2
            ),
            key=lambda d: d.rect.x,
            default=None,
        )
        if right is not None:
            pairs.append((left, right))
    return pairs
