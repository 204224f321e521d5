"""Run benchmarks by name (default: all) and write each result to ``results/NAME.json``."""

from __future__ import annotations

import argparse
import datetime
import importlib
import json
import os
import platform
import sys
from pathlib import Path

BENCHMARKS = (
    "fanout",
    "codes",
    "camera",
    "placement",
    "scans",
    "volume",
    "census",
    "census_colour",
    "census_fit",
    "brain",
    "signin",
    "phone_steps",
    "sync",
    "lecture_hall",
    "memory",
    "image",
    "globe",
    "video_sync",
)
RESULTS = Path(__file__).parent / "results"


def machine() -> dict[str, object]:
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__)
    parser.add_argument("names", nargs="*", help=f"benchmarks to run: {', '.join(BENCHMARKS)}")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(BENCHMARKS))
    if unknown:
        parser.error(f"unknown benchmark(s): {', '.join(unknown)}")
    RESULTS.mkdir(exist_ok=True)
    for name in args.names or BENCHMARKS:
        module = importlib.import_module(f"benchmarks.{name}")
        print(f"== {name}", flush=True)
        result = {
            "benchmark": name,
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "machine": machine(),
            **module.run(),
        }
        path = RESULTS / f"{name}.json"
        path.write_text(json.dumps(result, indent=2) + "\n")
        print(module.summary(result))
        print(f"   written to {path}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
