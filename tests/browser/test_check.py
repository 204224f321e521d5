"""``tagwall check`` against a running server and real tiles.

Kept apart from the other browser tests: the check drives its own Playwright, which
cannot share a thread with the module-scoped ``browser`` fixture.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from wall_client.config import load_wall
from webapp.cli.check import CheckReport, check_wall, fetch_layout
from webapp.cli.testing import ServerProcess
from webapp.core.settings import CONTENT_DIR
from webapp.people.security import operator_token, tile_token
from webapp.tags.schemas import LayoutInfo, PlacedCode
from webapp.web.urls import tile_path


def run_check(server: ServerProcess, *args: str) -> subprocess.CompletedProcess[str]:
    tagwall = Path(sys.executable).with_name("tagwall")
    return subprocess.run(
        [str(tagwall), "check", "--wall", "demo", "--server", server.url, *args],
        env=server.env(),
        capture_output=True,
        text=True,
        timeout=180,
    )


def check_expecting(
    server: ServerProcess, version: int, layout: LayoutInfo, expected: PlacedCode
) -> CheckReport:
    """The check of the demo tiles against ``layout`` with its first code replaced by
    ``expected``: what the check says when a tile shows something else than it should."""
    wall = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    tampered = layout.model_copy(update={"placed": [expected, *layout.placed[1:]]})
    token = tile_token(server.secret, "demo")
    urls = {d.id: server.url + tile_path(token, "demo", d.id) for d in wall.displays}
    chromium = shutil.which("chromium")
    assert chromium is not None
    return check_wall(wall, urls, version, tampered, chromium)


def test_check_decodes_every_code_the_demo_tiles_show(server: ServerProcess) -> None:
    result = run_check(server)
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    count = len(layout.placed)
    assert count >= 6
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.splitlines()[0] == f"decoded {count}/{count} codes"
    assert result.stdout.splitlines()[1] == (
        f"intact {count}/{count} codes: 0 damaged modules, 0 dirty quiet zones"
    )
    assert "smallest pixels per module: " in result.stdout


def test_check_compares_every_module_with_the_symbol(server: ServerProcess) -> None:
    """A code that differs from its symbol in three modules still decodes: the check
    reports exactly those three, and fails."""
    version, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    code = layout.placed[0]
    rows = [list(row) for row in code.matrix]
    for i in (9, 10, 11):  # in the middle: data modules, not a finder pattern
        rows[i][i] = "0" if rows[i][i] == "1" else "1"
    expected = code.model_copy(update={"matrix": ["".join(row) for row in rows]})

    report = check_expecting(server, version, layout, expected)

    count = len(layout.placed)
    assert report.decoded == count, "it still decodes"
    assert not report.ok
    lines = report.lines()
    assert lines[1] == f"intact {count - 1}/{count} codes: 3 damaged modules, 0 dirty quiet zones"
    modules = len(code.matrix) ** 2
    failure = (
        f"  FAIL tile {code.display}: {code.code} ({code.label}) 3 of {modules} modules damaged"
    )
    assert failure in lines


def test_check_reports_a_tile_that_shows_the_wrong_code(server: ServerProcess) -> None:
    version, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    wrong = layout.placed[0]
    expected = wrong.model_copy(update={"payload": wrong.payload + "X"})

    report = check_expecting(server, version, layout, expected)

    assert not report.ok
    assert report.decoded == len(layout.placed) - 1
    lines = report.lines()
    assert lines[0] == f"decoded {report.decoded}/{len(layout.placed)} codes"
    assert f"  FAIL tile {wrong.display}: a code decodes to {wrong.payload!r}" in "\n".join(lines)
    assert f"  FAIL tile {wrong.display}: {wrong.code} ({wrong.label}) did not decode" in lines


def test_check_exits_2_when_the_server_is_unreachable(server: ServerProcess) -> None:
    server.stop()
    result = run_check(server)
    assert result.returncode == 2
    assert result.stderr.startswith("error: ")


def test_codes_placed_again_after_a_pan_and_zoom_of_the_census_map_still_decode(
    server: ServerProcess,
) -> None:
    server.change("demo", {"app": "census"})
    _, whole = fetch_layout(server.url, "demo", operator_token(server.secret))
    server.change("demo", {"view": {"center": [0.55, 0.45], "zoom": 3}})
    _, zoomed = fetch_layout(server.url, "demo", operator_token(server.secret))
    tracts = [c for c in zoomed.placed if c.display not in ("r1c3", "r2c1")]
    assert len(tracts) > len([c for c in whole.placed if c.display not in ("r1c3", "r2c1")])
    result = run_check(server)
    count = len(zoomed.placed)
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.splitlines()[0] == f"decoded {count}/{count} codes"
