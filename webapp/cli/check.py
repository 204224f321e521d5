"""``tagwall check``: hold a running wall's layout to the pin rule, then photograph
every tile and decode its codes.

The layout's geometry comes first: a pin that crosses another, runs under a code or
has its head under one leaves every code readable, so no photograph catches it; the
placement's own predicate (:func:`tag_service.placement.pin_conflicts`) does.

What counts is what the tiles actually show: each tile page is opened in headless
Chromium at its display's native resolution, screenshotted, and every QR code in
the picture is decoded and matched against the codes the server placed there. A
code that decodes may still have something drawn over it (it fails first from a
few steps back), so every placed code's pixels are also compared with its symbol,
module by module, quiet zone included.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import httpx
import numpy as np
from PIL import Image
from playwright.sync_api import Page, sync_playwright

from tag_service.placement import Mark, pin_conflicts
from tag_service.verify import decode_image, module_boxes, symbol_damage
from wall_client.layout import Rect, Wall
from webapp.server.schemas import WallStatus
from webapp.tags.schemas import LayoutInfo, PlacedCode

TILE_TIMEOUT_MS = 20_000
CHROMIUM_ARGS = ("--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage")


@dataclass
class CheckReport:
    expected: int = 0
    decoded: int = 0
    failures: list[str] = field(default_factory=list)
    smallest: PlacedCode | None = None  # the code with the fewest pixels per module
    intact: int = 0  # codes whose pixels match their symbol, quiet zone included
    damaged_modules: int = 0  # over all codes
    dirty_quiet_zones: int = 0  # codes with something in their quiet zone
    pin_conflicts: int = 0  # pins crossing, under a code, or with their head under one

    @property
    def ok(self) -> bool:
        return not self.failures and self.decoded == self.expected

    def lines(self) -> list[str]:
        lines = [
            f"decoded {self.decoded}/{self.expected} codes",
            f"intact {self.intact}/{self.expected} codes: {self.damaged_modules} damaged"
            f" modules, {self.dirty_quiet_zones} dirty quiet zones",
            f"pins: {self.pin_conflicts} crossing, under a code or with the head under one",
        ]
        lines += [f"  FAIL {failure}" for failure in self.failures]
        if self.smallest is not None:
            lines.append(
                f"smallest pixels per module: {self.smallest.px_per_module} "
                f"({self.smallest.code} on {self.smallest.display})"
            )
        return lines


def fetch_layout(server_url: str, wall_id: str, operator_token: str) -> tuple[int, LayoutInfo]:
    """The wall's version and the layout its tiles should show, from the running server."""
    headers = {"Authorization": f"Bearer {operator_token}"}
    with httpx.Client(base_url=server_url, headers=headers, timeout=10) as client:
        status_response = client.get(f"/api/walls/{wall_id}/status")
        status_response.raise_for_status()
        status = WallStatus.model_validate(status_response.json())
        layout_id = int(status.state.get("tag_layout", 0))
        if not layout_id:
            return status.version, LayoutInfo(
                id=0, wall=wall_id, tag_set=None, placed=[], unplaced=[]
            )
        layout_response = client.get(f"/api/walls/{wall_id}/layouts/{layout_id}")
        layout_response.raise_for_status()
        return status.version, LayoutInfo.model_validate(layout_response.json())


def check_wall(
    wall: Wall,
    tile_urls: dict[str, str],
    version: int,
    layout: LayoutInfo,
    browser_path: str,
) -> CheckReport:
    """Hold ``layout`` to the pin rule, then screenshot every tile at ``version`` and
    match decoded codes to it."""
    report = check_layout(layout)
    _photograph(wall, tile_urls, version, layout, browser_path, report)
    return report


def check_layout(layout: LayoutInfo) -> CheckReport:
    """What the layout says before any tile is photographed: its unplaced codes, and
    every way its pins break the placement's rule."""
    report = CheckReport(expected=len(layout.placed))
    if layout.placed:
        report.smallest = min(layout.placed, key=lambda code: code.px_per_module)
    for failure in layout.unplaced:
        report.failures.append(f"{failure.code} ({failure.label}) not placed: {failure.reason}")
    marks = [
        Mark(f"{code.code} ({code.label})", Rect(*code.footprint), code.leader)
        for code in layout.placed
    ]
    conflicts = pin_conflicts(marks)
    report.pin_conflicts = len(conflicts)
    report.failures += [str(conflict) for conflict in conflicts]
    return report


def _photograph(
    wall: Wall,
    tile_urls: dict[str, str],
    version: int,
    layout: LayoutInfo,
    browser_path: str,
    report: CheckReport,
) -> None:
    """Screenshot every tile and check what it shows against ``layout``."""
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=browser_path, args=CHROMIUM_ARGS)
        try:
            for display in wall.displays:
                width, height = display.resolution
                context = browser.new_context(
                    viewport={"width": width, "height": height}, device_scale_factor=1
                )
                page = context.new_page()
                expected = [code for code in layout.placed if code.display == display.id]
                image = _tile_picture(page, tile_urls[display.id], version, display.id, report)
                if image is not None:
                    _check_decodes(image, expected, display.id, report)
                    _check_pixels(image, wall, expected, display.id, report)
                context.close()
        finally:
            browser.close()


def _tile_picture(
    page: Page, url: str, version: int, display_id: str, report: CheckReport
) -> Image.Image | None:
    """The tile's screenshot once it shows ``version`` (None, and a failure, if never)."""
    page.goto(url)
    try:
        page.wait_for_function(
            "v => Number(document.body.dataset.version) >= v", arg=version, timeout=TILE_TIMEOUT_MS
        )
    except Exception:  # Playwright's TimeoutError: the tile never showed the state
        report.failures.append(f"tile {display_id} did not show wall version {version}")
        return None
    return Image.open(io.BytesIO(page.screenshot(type="png"))).convert("RGB")


def _check_decodes(
    image: Image.Image, expected: list[PlacedCode], display_id: str, report: CheckReport
) -> None:
    by_payload = {code.payload: code for code in expected}
    found = set()
    for decoded in decode_image(image):
        code = by_payload.get(decoded.payload)
        if code is None:
            report.failures.append(
                f"tile {display_id}: a code decodes to {decoded.payload!r}, not a code placed there"
            )
        elif code.code not in found:
            found.add(code.code)
            report.decoded += 1
    for code in expected:
        if code.code not in found:
            report.failures.append(f"tile {display_id}: {code.code} ({code.label}) did not decode")


def _check_pixels(
    image: Image.Image, wall: Wall, expected: list[PlacedCode], display_id: str, report: CheckReport
) -> None:
    """Each code's pixels against its symbol, where the tile draws its modules."""
    pixels = np.asarray(image)
    to_pixels = wall.viewport(display_id).to_pixels
    for code in expected:
        boxes = module_boxes(to_pixels, code.rect, code.modules)
        damage = symbol_damage(pixels, boxes, code.matrix)
        report.damaged_modules += damage.damaged
        report.dirty_quiet_zones += damage.dirty_quiet > 0
        if damage.intact:
            report.intact += 1
            continue
        problems = []
        if damage.damaged:
            problems.append(f"{damage.damaged} of {damage.modules} modules damaged")
        if damage.dirty_quiet:
            problems.append(f"quiet zone dirty ({damage.dirty_quiet} modules)")
        report.failures.append(
            f"tile {display_id}: {code.code} ({code.label}) {', '.join(problems)}"
        )
