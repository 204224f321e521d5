"""The clock statement: where it puts the video at each instant, the same in Python and
in the tiles' follow.js; play, pause and loop continuous with the statement before, a seek
the one jump, each taking effect the lead ahead."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.webapp.apps.image.samples import node_answer
from webapp.apps.video.state import (
    VideoClock,
    VideoState,
    looped,
    paused,
    played,
    position_at,
    sought,
)

FOLLOW = Path(__file__).parents[4] / "webapp" / "apps" / "video" / "static" / "follow.js"
LEAD = 500
DURATION = 90.0
CASES = [
    (VideoClock(playing=True, media_s=10.0, wall_ms=1_000), 6_000, 90.0, False),
    (VideoClock(playing=True, media_s=10.0, wall_ms=1_000), 500, 90.0, False),  # not yet
    (VideoClock(playing=True, media_s=88.0, wall_ms=1_000), 6_000, 90.0, False),  # ended
    (VideoClock(playing=True, media_s=88.0, wall_ms=1_000), 6_000, 90.0, True),  # wrapped
    (VideoClock(playing=True, media_s=5.0, wall_ms=0), 400_000, 90.0, True),  # many times
    (VideoClock(playing=False, media_s=42.5, wall_ms=1_000), 9_000, 90.0, True),
    (VideoClock(playing=True, media_s=3.0, wall_ms=1_000), 2_000, 0.0, False),  # unknown length
]


def test_where_a_statement_puts_the_video() -> None:
    assert [position_at(*case) for case in CASES] == [
        (15.0, True),
        (10.0, False),
        (90.0, False),
        (3.0, True),
        (5.0 + 400 - 4 * 90, True),
        (42.5, False),
        (4.0, True),
    ]


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node")
def test_the_tiles_follow_the_same_rule() -> None:
    script = f"""
        import {{positionAt}} from {json.dumps(FOLLOW.as_uri())};
        const cases = {json.dumps([[c.model_dump(), at, d, loop] for c, at, d, loop in CASES])};
        console.log(JSON.stringify(cases.map(([clock, at, duration, loop]) => {{
          const {{position, playing}} = positionAt(clock, at, duration, loop);
          return [position, playing];
        }})));
    """
    tiles = node_answer(script)
    ours = [position_at(*case) for case in CASES]
    assert [playing for _, playing in tiles] == [playing for _, playing in ours]
    assert [position for position, _ in tiles] == pytest.approx([p for p, _ in ours], abs=1e-9)


def playing_from(media_s: float, wall_ms: int, loop: bool = False) -> VideoState:
    return VideoState(video="v", clock=VideoClock(playing=True, media_s=media_s, wall_ms=wall_ms),
                      loop=loop)  # fmt: skip


def test_play_and_pause_take_effect_the_lead_ahead_from_where_it_stands() -> None:
    still = VideoState(video="v", clock=VideoClock(playing=False, media_s=12.0, wall_ms=100))
    going = played(still, 10_000, LEAD, DURATION)
    assert going.clock == VideoClock(playing=True, media_s=12.0, wall_ms=10_500)
    assert played(going, 10_100, LEAD, DURATION) is going  # pressed twice: one start
    stopped = paused(going, 13_000, LEAD, DURATION)
    assert stopped.clock == VideoClock(playing=False, media_s=15.0, wall_ms=13_500)
    assert paused(stopped, 14_000, LEAD, DURATION) is stopped
    at_end = paused(playing_from(80.0, 0), 20_000, LEAD, DURATION)
    assert at_end.clock.media_s == DURATION  # it stopped on its last frame
    assert played(at_end, 30_000, LEAD, DURATION).clock.media_s == 0.0  # and starts over


def test_a_seek_keeps_playing_or_paused_and_stays_within_the_video() -> None:
    going = sought(playing_from(10.0, 0), 30.0, 5_000, LEAD, DURATION)
    assert going.clock == VideoClock(playing=True, media_s=30.0, wall_ms=5_500)
    still = VideoState(video="v", clock=VideoClock(playing=False, media_s=1.0, wall_ms=0))
    assert sought(still, 500.0, 5_000, LEAD, DURATION).clock == VideoClock(
        playing=False, media_s=DURATION, wall_ms=5_500
    )
    assert sought(still, -3.0, 5_000, LEAD, DURATION).clock.media_s == 0.0


def test_looping_is_stated_again_from_where_the_video_stands() -> None:
    going = looped(playing_from(80.0, 0, loop=True), False, 20_000, LEAD, DURATION)
    # 80 s + 20.5 s wrapped at 90 s: it goes on from 10.5 s, now stopping at the end
    assert (going.loop, going.clock) == (False, VideoClock(playing=True, media_s=10.5,
                                                             wall_ms=20_500))  # fmt: skip


steps = st.lists(
    st.tuples(
        st.sampled_from(["play", "pause", "loop", "unloop"]),
        st.integers(min_value=1, max_value=200_000),  # ms since the step before
    ),
    max_size=12,
)


@given(steps)
def test_play_pause_and_loop_never_move_the_video(history: list[tuple[str, int]]) -> None:
    """At the instant each statement takes over, it puts the video where the one before
    it had it: no tile jumps, whatever is pressed when (a seek is the one jump)."""
    slot = VideoState(video="v")
    now = 0
    for step, later in history:
        now += later
        before = slot
        if step == "play":
            slot = played(slot, now, LEAD, DURATION)
        elif step == "pause":
            slot = paused(slot, now, LEAD, DURATION)
        else:
            slot = looped(slot, step == "loop", now, LEAD, DURATION)
        if slot is before:
            continue
        at = slot.clock.wall_ms
        assert at == now + LEAD
        was, _ = position_at(before.clock, at, DURATION, before.loop)
        is_now, _ = position_at(slot.clock, at, DURATION, slot.loop)
        restarted = step == "play" and was == DURATION  # from its end: from the start
        assert is_now == pytest.approx(0.0 if restarted else was, abs=1e-9)
