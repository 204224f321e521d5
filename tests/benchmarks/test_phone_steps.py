"""The phone-steps benchmark at a tiny size: its three servers answer every step, and
its result has the shape ``make bench`` writes (no times are checked)."""

from __future__ import annotations

from benchmarks.phone_steps import PHONE_STEPS, figures_of, run, summary


def test_a_tiny_run_measures_every_step_against_both_floors() -> None:
    result = run(requests=2, rounds=1, idle_s=0.0)
    assert set(result["floors"]) == {"starlette", "fastapi_jinja"}
    assert set(result["steps"]) == {*PHONE_STEPS, "healthz"}
    for step in result["steps"].values():
        assert set(step) == {"server_cpu_ms", "ratio", "rounds_ms", "floors_ms"}
        assert len(step["rounds_ms"]) == 1
    assert isinstance(result["meets_target"], bool)
    assert "FastAPI + Jinja" in summary(result)


def test_each_ratio_is_the_median_of_a_step_over_the_floor_measured_beside_it() -> None:
    pairs = {name: [(2.0, 1.0), (9.0, 3.0), (4.0, 1.0)] for name in (*PHONE_STEPS, "healthz")}
    result = figures_of(pairs, [0.5, 0.4, 0.6], requests=10, idle=0.0)
    assert result["floors"]["fastapi_jinja"]["server_cpu_ms"] == 1.0
    assert result["floors"]["starlette"]["server_cpu_ms"] == 0.5
    assert result["steps"]["answer"] == {
        "server_cpu_ms": 4.0,
        "ratio": 3.0,
        "rounds_ms": [2.0, 9.0, 4.0],
        "floors_ms": [1.0, 3.0, 1.0],
    }
    assert result["rounds"] == 3
    assert result["worst_ratio"] == 3.0
    assert not result["meets_target"]
