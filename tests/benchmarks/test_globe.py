"""The globe benchmark: its figures, and a tiny run on one tile giving the result's
shape (no times are checked; the runs themselves are ``make bench``)."""

from __future__ import annotations

import shutil

import pytest

from benchmarks.globe import KINDS, SURFACES, figures_of, run, summary


def test_each_ratio_is_the_globes_median_over_the_flat_maps() -> None:
    samples = {
        "flat": {"first_frame": [1000.0, 3000.0], "toggle": [20.0, 30.0, 40.0], "colour": [80.0]},
        "globe": {
            "first_frame": [9000.0, 11000.0],
            "toggle": [600.0, 900.0, 5000.0],
            "colour": [800.0],
        },
    }
    figures = figures_of(samples)
    assert figures["globe"]["toggle"] == {"median_ms": 900.0, "max_ms": 5000.0, "samples": 3}
    assert figures["flat"]["first_frame"]["median_ms"] == 2000.0
    assert figures["ratio"] == {"first_frame": 5.0, "toggle": 30.0, "colour": 10.0}


@pytest.mark.skipif(shutil.which("chromium") is None, reason="needs Debian chromium")
def test_a_tiny_run_times_every_kind_on_both_surfaces() -> None:
    result = run(rounds=1, changes=2, tiles=["r2c2"])
    for surface in SURFACES:
        assert set(result[surface]) == set(KINDS)
        assert result[surface]["first_frame"]["samples"] == 1
        assert result[surface]["toggle"]["samples"] == result[surface]["colour"]["samples"] == 2
    assert set(result["ratio"]) == set(KINDS)
    assert "globe" in summary(result)
