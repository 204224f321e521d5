"""Wall configs as parsed TOML documents, for the geometry and config tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
WALLS_DIR = ROOT / "content" / "walls"


def grid_config(**grid: Any) -> dict[str, Any]:
    """A 3 x 2 grid of 55-inch Full HD panels with 3.5 mm bezels; keys override."""
    base: dict[str, Any] = {
        "columns": 3,
        "rows": 2,
        "resolution": [1920, 1080],
        "active_mm": [1209.6, 680.4],
        "bezel_mm": 3.5,
    }
    base.update(grid)
    return {"id": "test", "grid": base}


def explicit_config(*displays: dict[str, Any], **top: Any) -> dict[str, Any]:
    return {"id": "test", "display": list(displays), **top}


def panel(display_id: str, x: float, y: float, **extra: Any) -> dict[str, Any]:
    """A 16:9 panel 160 x 90 mm at (x, y)."""
    return {
        "id": display_id,
        "x_mm": x,
        "y_mm": y,
        "width_mm": 160,
        "height_mm": 90,
        "resolution": [1920, 1080],
        **extra,
    }
