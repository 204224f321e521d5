"""The video sync benchmark's arithmetic: how far apart the tiles' frames are at each
instant, and how far a screenshot's frame lies outside what the clock showed while it
was taken (the runs themselves are ``make bench`` and tests/browser/test_video_sync.py)."""

from __future__ import annotations

from benchmarks.video_sync import GRID_MS, spreads
from tests.browser.video_wall import Capture, due_frame, frame_errors

CLOCK = {"playing": True, "media_s": 10.0, "wall_ms": 1_000_000}


def test_the_tiles_frames_are_compared_each_by_its_latest_at_every_instant() -> None:
    one = [[0.0, 0.0], [1 / 30, 33.0], [2 / 30, 66.0]]
    late = [[0.0, 0.0], [1 / 30, 60.0], [2 / 30, 100.0]]
    assert spreads([one, late], (0.0, 100.0)) == [0, 1, 0]
    assert GRID_MS == 50


def test_the_clock_says_which_frame_is_due_and_how_far_each_shown_one_is() -> None:
    assert due_frame(CLOCK, 1_000_000) == 300
    assert due_frame(CLOCK, 1_001_050) == 331
    samples = [[10.0, 1_000_000.0], [11.1, 1_001_050.0], [12.0, 2_000_000.0]]
    assert frame_errors(samples, CLOCK, 1_000_000, 1_100_000) == [0, 2]


def test_a_screenshot_is_off_only_outside_what_its_capture_window_saw() -> None:
    start = CLOCK["wall_ms"] / 1000
    taken = Capture(frames=[300, 303, 298], sent=[start] * 3, done=[start + 0.1] * 3)
    assert taken.off(CLOCK) == [0, 0, 2]  # 300 to 303 were due during the 100 ms
    assert taken.spread == 5 and round(taken.window_ms) == 100
