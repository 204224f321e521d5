"""The volume module: building stores, rendering tiles, and the detail a wall gains.

* Build time, store size and the build's peak memory (resident set of a child
  process) for the MNI template and for a synthetic 1024^3 uint8 volume generated
  on disk (a textured ball, so a third of its bricks are empty).
* Per-tile render time, fallback and refined, image encoding included (what a tile
  waits for): a single 1920 x 1080 display showing the whole MNI brain (targets:
  fallback <= 100 ms, refined <= 1 s), the demo wall's busiest tile, and HIPerWall's.
  Cold is the first render after opening the store; warm the median of three more.
* Detail gained: voxels rendered across HIPerWall's 50 tiles against one 2560 x 1600
  display, each under the same per-display budget.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from wall_client.config import load_wall, parse_wall
from wall_client.layout import Wall
from webapp.core.settings import CONTENT_DIR
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.store import VolumeStore
from webapp.volume.tiles import encode, tile_image, tile_plan

MNI = CONTENT_DIR / "brain_atlas" / "mni_icbm152_t1_tal_nlin_sym_09a.nii.gz"
SYNTHETIC_SIDE = 1024
BUDGET = 1 << 24
WARM_ROUNDS = 3
ONE_FULL_HD = {
    "id": "one",
    "name": "one 1920 x 1080 display",
    "grid": {
        "columns": 1,
        "rows": 1,
        "resolution": [1920, 1080],
        "active_mm": [1209.6, 680.4],
        "bezel_mm": 0,
    },
}
ONE_WQXGA = {
    "id": "single",
    "name": "one 2560 x 1600 display",
    "grid": {
        "columns": 1,
        "rows": 1,
        "resolution": [2560, 1600],
        "active_mm": [641.3, 400.8],
        "bezel_mm": 0,
    },
}
# The child reports its own high-water mark (VmHWM): ru_maxrss of children would also
# count the parent's pages the child held between fork and exec.
BUILD = (
    "import sys, time; from pathlib import Path;"
    "from webapp.volume.build import build_store, open_source;"
    "t = time.perf_counter();"
    "build_store(open_source(Path(sys.argv[1])), Path(sys.argv[2]), name=sys.argv[3]);"
    "hwm = [l.split()[1] for l in open('/proc/self/status') if l.startswith('VmHWM')][0];"
    "print(time.perf_counter() - t, hwm)"
)


def synthesise(path: Path, side: int) -> None:
    """A textured ball in a cube of ``side`` voxels, written a slab at a time."""
    volume = np.lib.format.open_memmap(path, mode="w+", dtype=np.uint8, shape=(side,) * 3)
    x, y = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    centre, radius = side / 2, side * 0.45
    for z0 in range(0, side, 64):
        z = np.arange(z0, min(z0 + 64, side))[None, None, :]
        distance = np.sqrt(
            (x[..., None] - centre) ** 2 + (y[..., None] - centre) ** 2 + (z - centre) ** 2
        )
        texture = (
            128
            + 60 * np.sin(x[..., None] / 9.0) * np.cos(y[..., None] / 13.0)
            + 50 * np.sin(z / 7.0)
        )
        volume[:, :, z0 : z0 + z.shape[2]] = np.where(distance < radius, texture, 0).astype(
            np.uint8
        )
    volume.flush()
    del volume


def build(source: Path, out: Path, name: str) -> dict[str, Any]:
    """Build in a child process, so its peak resident memory is the build's own."""
    finished = subprocess.run(
        [sys.executable, "-c", BUILD, str(source), str(out), name],
        check=True,
        capture_output=True,
        text=True,
    )
    seconds, peak_kib = finished.stdout.split()
    meta = VolumeStore(out).meta
    return {
        "source_bytes": source.stat().st_size,
        "voxels": int(np.prod(meta.shape)),
        "volume_bytes_uint8": int(np.prod(meta.shape)),
        "build_s": round(float(seconds), 2),
        "store_bytes": sum(p.stat().st_size for p in out.iterdir()),
        "peak_rss_mb": round(int(peak_kib) / 1024, 1),
        "stored_bricks": meta.stored_bricks,
        "empty_bricks": meta.empty_bricks,
        "brick": meta.brick,
    }


def tile_times(store_path: Path, wall: Wall, display_id: str, view: View) -> dict[str, Any]:
    """Cold and warm milliseconds of one tile's fallback and refined image."""
    store = VolumeStore(store_path)
    layer = VolumeLayer(volume=store.name)
    result: dict[str, Any] = {"wall": wall.id, "tile": display_id}
    for detail in ("fallback", "refined"):
        times = []
        for _ in range(1 + WARM_ROUNDS):
            start = time.perf_counter()
            image = tile_image(store, wall, display_id, view, layer, detail=detail, budget=BUDGET)
            encode(image.image, "png")
            times.append((time.perf_counter() - start) * 1000)
        result[detail] = {
            "cold_ms": round(times[0], 1),
            "warm_ms": round(statistics.median(times[1:]), 1),
            "level": image.plan.level,
            "image": list(image.plan.size),
        }
    return result


def busiest(store_path: Path, wall: Wall, view: View) -> str:
    """The display whose refined render holds the most voxels."""
    store = VolumeStore(store_path)
    layer = VolumeLayer(volume=store.name)

    def voxels(display_id: str) -> int:
        _, _, plan = tile_plan(
            store, wall, display_id, view, layer, detail="refined", budget=BUDGET
        )
        return plan.voxels(store.meta)

    return max((d.id for d in wall.displays), key=voxels)


def detail_gained(store_path: Path, wall: Wall, single: Wall, view: View) -> dict[str, Any]:
    store = VolumeStore(store_path)
    layer = VolumeLayer(volume=store.name)

    def shown(on: Wall) -> tuple[int, dict[int, int]]:
        total, levels = 0, {}
        for display in on.displays:
            _, _, plan = tile_plan(
                store, on, display.id, view, layer, detail="refined", budget=BUDGET
            )
            if plan.selection is not None and plan.selection.count:
                total += plan.voxels(store.meta)
                levels[plan.level] = levels.get(plan.level, 0) + 1
        return total, levels

    wall_voxels, wall_levels = shown(wall)
    single_voxels, single_levels = shown(single)
    return {
        "wall_voxels": wall_voxels,
        "wall_tiles_per_level": {str(k): v for k, v in sorted(wall_levels.items())},
        "single_display_voxels": single_voxels,
        "single_display_level": min(single_levels, default=None),
        "ratio": round(wall_voxels / max(1, single_voxels), 2),
    }


def run() -> dict[str, Any]:
    demo = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    hiperwall = load_wall(CONTENT_DIR / "walls" / "hiperwall.toml")
    one, single = parse_wall(ONE_FULL_HD), parse_wall(ONE_WQXGA)
    view = View(yaw=30, pitch=15)
    work = Path(tempfile.mkdtemp(prefix="tagwall-volume-bench-"))
    try:
        mni_store = work / "mni152"
        synthetic = work / "synthetic.npy"
        synthetic_store = work / "synthetic"
        result: dict[str, Any] = {"budget_voxels": BUDGET, "build": {}}
        result["build"]["mni152"] = build(MNI, mni_store, "mni152")
        synthesise(synthetic, SYNTHETIC_SIDE)
        result["build"]["synthetic_1024"] = build(synthetic, synthetic_store, "synthetic")
        synthetic.unlink()
        result["render"] = [
            tile_times(mni_store, one, "r1c1", view),
            tile_times(mni_store, demo, busiest(mni_store, demo, view), view),
            tile_times(mni_store, hiperwall, busiest(mni_store, hiperwall, view), view),
            tile_times(synthetic_store, hiperwall, busiest(synthetic_store, hiperwall, view), view),
        ]
        result["render"][-1]["volume"] = "synthetic_1024"
        result["detail_gained"] = {
            "mni152": detail_gained(mni_store, hiperwall, single, view),
            "synthetic_1024": detail_gained(synthetic_store, hiperwall, single, view),
        }
        return result
    finally:
        shutil.rmtree(work, ignore_errors=True)


def summary(result: dict[str, Any]) -> str:
    lines = []
    for name, b in result["build"].items():
        lines.append(
            f"   build {name}: {b['build_s']} s, store {b['store_bytes'] / 1e6:.0f} MB "
            f"(volume {b['volume_bytes_uint8'] / 1e6:.0f} MB), peak memory {b['peak_rss_mb']} MB"
        )
    for r in result["render"]:
        lines.append(
            f"   render {r.get('volume', 'mni152')} on {r['wall']}/{r['tile']}: fallback "
            f"{r['fallback']['warm_ms']} ms (cold {r['fallback']['cold_ms']}), refined level "
            f"{r['refined']['level']} {r['refined']['warm_ms']} ms "
            f"(cold {r['refined']['cold_ms']})"
        )
    for name, d in result["detail_gained"].items():
        lines.append(
            f"   detail {name}: wall {d['wall_voxels']:,} voxels vs one display "
            f"{d['single_display_voxels']:,} (x{d['ratio']})"
        )
    return "\n".join(lines)
