"""The lecture-hall benchmark's arithmetic: percentiles, arrivals, step figures, tile
latencies and the profile's attribution (the runs themselves are ``make bench``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from benchmarks.lecture_hall import (
    Published,
    Sample,
    arrivals,
    cpu_list,
    step_figures,
    summarise_profile,
    tile_figures,
    work_of,
)


def test_phones_arrive_uniformly_over_the_period() -> None:
    assert arrivals(4, 60.0, 1000.0) == [1000.0, 1015.0, 1030.0, 1045.0]


def test_a_taskset_cpu_list_names_its_cpus() -> None:
    """The hall pins its server with taskset and itself with the same list."""
    assert cpu_list("0") == {0}
    assert cpu_list("0,2-4") == {0, 2, 3, 4}


def test_steps_count_failures_and_time_only_answers() -> None:
    samples = [
        Sample("scan", 10.0, 200),
        Sample("scan", 30.0, 429),
        Sample("scan", 5000.0, 0),  # no answer: a failure without a latency
        Sample("answer", 8.0, 303),
    ]
    figures = step_figures(samples)
    assert figures["scan"]["count"] == 3
    assert figures["scan"]["failures"] == 2
    assert figures["scan"]["statuses"] == {"0": 1, "200": 1, "429": 1}
    assert figures["scan"]["max_ms"] == 30.0
    assert figures["answer"] == {
        "count": 1,
        "failures": 0,
        "statuses": {"303": 1},
        "p50_ms": 8.0,
        "p99_ms": 8.0,
        "max_ms": 8.0,
    }
    assert "register" not in figures


def test_tile_latency_is_the_last_tiles_and_missed_events_stand_apart() -> None:
    whole = Published(1, sent_at=10.0, acknowledged_at=10.005, stamped_at=10.004)
    whole.received = [10.006, 10.020]
    missed = Published(2, sent_at=11.0, acknowledged_at=11.01, stamped_at=11.009)
    missed.received = [11.02]
    figures = tile_figures([whole, missed], tiles=2)
    assert figures["events"] == 2
    assert figures["incomplete_events"] == 1
    assert figures["last_tile_ms_from_request"]["p50"] == pytest.approx(20.0)
    assert figures["last_tile_ms_from_server_stamp"]["p50"] == pytest.approx(16.0)


def test_a_sample_goes_to_the_code_of_ours_that_called_the_library() -> None:
    loop = "Runner.run (asyncio/runners.py)"
    wrapper = "SessionCookieMiddleware.__call__ (webapp/web/middleware.py)"
    route = "resolve (webapp/server/routes/resolve.py)"
    assert work_of(
        [
            loop,
            wrapper,
            "render (webapp/web/templating.py)",
            "Template.render (jinja2/environment.py)",
        ]
    ) == ("templates (Jinja rendering)")
    assert work_of([loop, wrapper, route, "find (webapp/tags/registry.py)"]) == (
        "code and tag lookups (tags.registry)"
    )
    # a middleware's __call__ claims only its own time, not what it wraps
    assert work_of([loop, wrapper]) == "session cookie (visitors middleware, itsdangerous)"
    assert work_of([loop, wrapper, route]) == "other code of ours: webapp/server/routes/resolve.py"
    assert work_of([loop]).startswith("event loop")
    assert work_of(["Buffer.append_bits (segno/encoder.py)"]) == "unattributed (partial stacks)"


def test_a_profile_sums_to_the_whole(tmp_path: Path) -> None:
    raw = tmp_path / "profile.txt"
    raw.write_text(
        "Runner.run (asyncio/runners.py) 3\n"
        "Thread.run (threading.py);record_answer (webapp/quiz/engine.py);"
        "Session.commit (sqlalchemy/orm/session.py) 1\n"
    )
    summary = summarise_profile(raw, cpu_ms_per_request=8.0)
    assert summary["samples"] == 4
    by_work = {entry["where"]: entry for entry in summary["by_work"]}
    assert by_work["brain: answer stored (Quiz.record_answer)"]["share"] == 0.25
    assert by_work["brain: answer stored (Quiz.record_answer)"]["ms_per_request"] == 2.0
    assert {e["where"]: e["share"] for e in summary["self_by_package"]} == {
        "asyncio": 0.75,
        "sqlalchemy": 0.25,
    }
