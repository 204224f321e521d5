"""The video app's slot of the wall state: which video the wall plays, the one clock
statement every tile follows, looping, and which display plays the sound.

The clock statement is "playing from media time ``media_s`` at wall time ``wall_ms``"
(or paused there). Each tile computes from it where its video should be at each instant
of the wall clock (``positionAt`` in ``static/follow.js``, :func:`position_at` here: the
one rule in each language, held to the same numbers by a test). A play, pause or loop
change is stated :attr:`VideoSettings.lead_ms` ahead and continuous with the statement
before it at that instant, so no tile jumps; a seek is the one intended jump, on every
tile at the same instant.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import ClassVar

from pydantic import BaseModel, ConfigDict, Field

from wall_client.layout import Wall
from webapp.database.connection import Database
from webapp.engine.wall_state import AppState, read_state

APP = "video"


class VideoClock(BaseModel):
    """Where the wall's video is: at ``media_s`` at wall time ``wall_ms`` (server ms),
    playing on from there at normal speed, or paused there."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    playing: bool = False
    media_s: float = Field(default=0.0, ge=0)
    wall_ms: int = Field(default=0, ge=0)


class VideoState(AppState):
    app: ClassVar[str] = APP
    # tiles load the new video's start before the swap, so it appears on all at once
    heavy: ClassVar[frozenset[str]] = frozenset({"video"})
    placing: ClassVar[frozenset[str]] = frozenset()  # the video app stands no codes

    video: str | None = None  # the stored video's id (None: none chosen yet)
    clock: VideoClock = Field(default_factory=VideoClock)
    loop: bool = False  # at its end the video starts again (else it stops on its last frame)
    sound: str | None = Field(default=None, max_length=64)  # the display playing the sound


def position_at(clock: VideoClock, at_ms: int, duration_s: float, loop: bool) -> tuple[float, bool]:
    """Where ``clock`` puts the video at wall time ``at_ms``, and whether it is playing
    then: standing still before its ``wall_ms``; looping, wrapped at ``duration_s`` as it
    plays; not looping, stopped on its end (paused, it stands where it was put)."""
    running = clock.playing and at_ms > clock.wall_ms
    position = clock.media_s + ((at_ms - clock.wall_ms) / 1000 if running else 0.0)
    if duration_s <= 0:
        return max(0.0, position), running
    if loop and running:
        return position % duration_s, running
    if position >= duration_s:
        return duration_s, False
    return max(0.0, position), running


def played(slot: VideoState, now_ms: int, lead_ms: int, duration_s: float) -> VideoState:
    """The slot playing from where it stands at ``now_ms + lead_ms`` (from the start
    when it stopped at the end); as it is when it plays already."""
    at = now_ms + lead_ms
    position, playing = position_at(slot.clock, at, duration_s, slot.loop)
    if playing:
        return slot
    if position >= duration_s > 0:
        position = 0.0
    return slot.model_copy(update={"clock": VideoClock(playing=True, media_s=position, wall_ms=at)})


def paused(slot: VideoState, now_ms: int, lead_ms: int, duration_s: float) -> VideoState:
    """The slot paused where it will stand at ``now_ms + lead_ms``; as it is when paused."""
    if not slot.clock.playing:
        return slot
    at = now_ms + lead_ms
    position, _ = position_at(slot.clock, at, duration_s, slot.loop)
    return slot.model_copy(
        update={"clock": VideoClock(playing=False, media_s=position, wall_ms=at)}
    )


def sought(
    slot: VideoState, to_s: float, now_ms: int, lead_ms: int, duration_s: float
) -> VideoState:
    """The slot at media time ``to_s`` (kept within the video) from ``now_ms + lead_ms``,
    playing on if it was playing."""
    at = now_ms + lead_ms
    _, playing = position_at(slot.clock, at, duration_s, slot.loop)
    position = min(max(0.0, to_s), duration_s) if duration_s > 0 else max(0.0, to_s)
    return slot.model_copy(
        update={"clock": VideoClock(playing=playing, media_s=position, wall_ms=at)}
    )


def looped(
    slot: VideoState, loop: bool, now_ms: int, lead_ms: int, duration_s: float
) -> VideoState:
    """The slot looping or not from ``now_ms + lead_ms``, stated again from where it
    stands then: its ``media_s`` is within the video, whichever way it wraps after."""
    at = now_ms + lead_ms
    position, playing = position_at(slot.clock, at, duration_s, slot.loop)
    return slot.model_copy(
        update={"loop": loop, "clock": VideoClock(playing=playing, media_s=position, wall_ms=at)}
    )


def walls_showing(db: Database, walls: Iterable[Wall], video_id: str) -> list[Wall]:
    """The walls whose scene shows ``video_id`` now: the video app up, that video chosen
    (a wall on another app keeps the choice in its slot, but shows nothing of it)."""
    showing = []
    for wall in walls:
        _, state = read_state(db, wall.id)
        if state.app == APP and VideoState.of(state).video == video_id:
            showing.append(wall)
    return showing
