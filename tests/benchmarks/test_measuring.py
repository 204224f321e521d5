"""What the benchmarks measure alike."""

from __future__ import annotations

import os

import pytest

from benchmarks.measuring import cpu_seconds, memory_kb, percentile, process_tree


def test_percentiles_are_nearest_rank() -> None:
    values = [float(v) for v in range(100, 0, -1)]  # 1..100, unordered
    assert percentile(values, 0.5) == 50
    assert percentile(values, 0.99) == 99
    assert percentile(values, 1.0) == 100
    assert percentile([7.0], 0.99) == 7
    with pytest.raises(ValueError):
        percentile([], 0.5)


def test_cpu_is_counted_for_this_process_and_nothing_for_one_gone() -> None:
    before = cpu_seconds([os.getpid()])
    sum(i * i for i in range(2_000_000))
    assert cpu_seconds([os.getpid()]) > before
    assert cpu_seconds([2**22 + 1]) == 0  # above Linux's highest pid


def test_a_process_tree_starts_at_its_root() -> None:
    assert process_tree(os.getpid())[0] == os.getpid()


def test_memory_is_read_for_this_process_and_nothing_for_one_gone() -> None:
    memory = memory_kb([os.getpid()])
    assert 0 < memory["anon"] < memory["rss"] <= memory["peak"]
    assert memory["anon"] + memory["file"] <= memory["rss"]
    assert memory_kb([2**22 + 1]) == {"rss": 0, "anon": 0, "file": 0, "peak": 0}
