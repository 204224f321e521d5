"""The phone-steps benchmark at a tiny size: its three servers answer every step, and
its result has the shape ``make bench`` writes (no times are checked)."""

from __future__ import annotations

from benchmarks.phone_steps import PHONE_STEPS, figures_of, run, summary


def test_a_tiny_run_measures_every_step_against_both_floors() -> None:
    result = run(requests=2, rounds=1, idle_s=0.0)
    assert set(result["floors"]) == {"starlette", "fastapi_jinja"}
    assert set(result["steps"]) == {*PHONE_STEPS, "healthz"}
    for step in result["steps"].values():
        assert set(step) == {"server_cpu_ms", "ratio", "rounds_ms"}
        assert len(step["rounds_ms"]) == 1
    assert isinstance(result["meets_target"], bool)
    assert "FastAPI + Jinja" in summary(result)


def test_each_figure_is_the_median_of_its_rounds_in_fastapi_floors() -> None:
    figures = {name: [2.0, 9.0, 4.0] for name in (*PHONE_STEPS, "healthz")}
    figures |= {"starlette": [0.5, 0.5, 0.5], "fastapi_jinja": [1.0, 2.0, 3.0]}
    result = figures_of(figures, requests=10, rounds=3, idle=0.0)
    assert result["floors"]["fastapi_jinja"]["server_cpu_ms"] == 2.0
    assert result["steps"]["answer"] == {
        "server_cpu_ms": 4.0,
        "ratio": 2.0,
        "rounds_ms": [2.0, 9.0, 4.0],
    }
    assert result["worst_ratio"] == 2.0
    assert result["meets_target"]
