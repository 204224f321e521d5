"""What a phone reads: codes as small as sizing allows, photographed by the phone-like
camera of ``tag_service.verify.phone_frame`` (70 degrees, full 1920 px frames, tilted up
to 30 degrees, rolled, blurred, noisy, low in contrast, JPEG) from 1x, 1.5x and 2x the
design distance, decoded with zbar (the server's decoder) and zxing-cpp (a ZXing-class
decoder, as phone camera apps use). Rows for the sizing rule in use and for 4 and 5
camera pixels per module beside it: the measurement behind the rule (docs/codes.md).
"""

from __future__ import annotations

import io
import time
from typing import Any

import zxingcpp
from PIL import Image

from tag_service.codes import make_symbol, render_png, url_payload
from tag_service.sizing import CAMERA_PX_PER_MODULE, Camera, min_module_mm
from tag_service.verify import decode_image, phone_frame, random_shots

BASE_URL = "http://192.168.1.20:8000"
CODES = ("K7Q2ZP9", "ABC1234", "00000ZZ", "Q9X4M2T")
DISPLAY_PX_PER_MODULE = (3, 4, 6)
DISTANCES_M = (0.8, 2.0)  # the default walk-up and seat distances
FACTORS = (1.0, 1.5, 2.0)
SHOTS = 4  # per code, display pixels per module and distance: 96 frames per row
RULES = (4.0, CAMERA_PX_PER_MODULE, 5.0)
SURROUND = 30  # the dark map or black around a code


def _screen(payload: str, px_per_module: int) -> Image.Image:
    code = Image.open(io.BytesIO(render_png(make_symbol(payload), px_per_module))).convert("L")
    screen = Image.new("L", (code.width + 400, code.height + 400), SURROUND)
    screen.paste(code, (200, 200))
    return screen


def _read_rates(rule: float, factor: float) -> dict[str, float]:
    camera = Camera(px_per_module=rule)
    zbar = zxing = total = 0
    for number, code in enumerate(CODES):
        payload = url_payload(BASE_URL, code)
        for px_per_module in DISPLAY_PX_PER_MODULE:
            screen = _screen(payload, px_per_module)
            centre = (screen.width / 2, screen.height / 2)
            for distance in DISTANCES_M:
                mm_per_px = min_module_mm(distance, camera) / px_per_module
                seed = number * 100 + px_per_module * 10 + round(distance * 10)
                for n, shot in enumerate(random_shots(distance * factor, SHOTS, seed)):
                    frame = phone_frame(screen, mm_per_px, centre, shot, seed=n)
                    total += 1
                    zbar += any(d.payload == payload for d in decode_image(frame))
                    zxing += any(
                        r.text == payload
                        for r in zxingcpp.read_barcodes(
                            frame, formats=zxingcpp.BarcodeFormat.QRCode
                        )
                    )
    return {"frames": total, "zbar": round(zbar / total, 3), "zxing": round(zxing / total, 3)}


def run() -> dict[str, Any]:
    started = time.perf_counter()
    rules = {
        f"{rule:g}": {f"{factor:g}x": _read_rates(rule, factor) for factor in FACTORS}
        for rule in RULES
    }
    return {
        "rule_in_use": CAMERA_PX_PER_MODULE,
        "read_rates": rules,
        "seconds": round(time.perf_counter() - started, 1),
    }


def summary(result: dict[str, Any]) -> str:
    lines = []
    for rule, rates in result["read_rates"].items():
        marker = " (in use)" if float(rule) == result["rule_in_use"] else ""
        cells = ", ".join(
            f"{factor}: zbar {r['zbar']:.0%} zxing {r['zxing']:.0%}" for factor, r in rates.items()
        )
        lines.append(f"   {rule} camera px per module{marker}: {cells}")
    return "\n".join(lines)
