"""``tagwall check``: photograph every tile of a running wall and decode its codes.

What counts is what the tiles actually show: each tile page is opened in headless
Chromium at its display's native resolution, screenshotted, and every QR code in
the picture is decoded and matched against the codes the server placed there.
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field

import httpx
from PIL import Image
from playwright.sync_api import Page, sync_playwright

from tag_service.verify import decode_image
from wall_client.layout import Wall
from webapp.schemas import LayoutInfo, PlacedCode, WallStatus

TILE_TIMEOUT_MS = 20_000
CHROMIUM_ARGS = ("--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage")


@dataclass
class CheckReport:
    expected: int = 0
    decoded: int = 0
    failures: list[str] = field(default_factory=list)
    smallest: PlacedCode | None = None  # the code with the fewest pixels per module

    @property
    def ok(self) -> bool:
        return not self.failures and self.decoded == self.expected

    def lines(self) -> list[str]:
        lines = [f"decoded {self.decoded}/{self.expected} codes"]
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
    """Screenshot every tile at ``version`` and match decoded codes to ``layout``."""
    report = CheckReport(expected=len(layout.placed))
    if layout.placed:
        report.smallest = min(layout.placed, key=lambda code: code.px_per_module)
    for failure in layout.unplaced:
        report.failures.append(f"{failure.code} ({failure.label}) not placed: {failure.reason}")
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
                _check_tile(page, tile_urls[display.id], version, expected, display.id, report)
                context.close()
        finally:
            browser.close()
    return report


def _check_tile(
    page: Page,
    url: str,
    version: int,
    expected: list[PlacedCode],
    display_id: str,
    report: CheckReport,
) -> None:
    page.goto(url)
    try:
        page.wait_for_function(
            "v => Number(document.body.dataset.version) >= v", arg=version, timeout=TILE_TIMEOUT_MS
        )
    except Exception:  # Playwright's TimeoutError: the tile never showed the state
        report.failures.append(f"tile {display_id} did not show wall version {version}")
        return
    image = Image.open(io.BytesIO(page.screenshot(type="png")))
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
