"""The video app's own settings (``TAGWALL_VIDEO_*``), read as the app loads: a bad value
stops the server and every command at start with one line naming it."""

from __future__ import annotations

from pydantic import Field, ValidationError
from pydantic_settings import BaseSettings, SettingsConfigDict

from webapp.core.settings import setting_problems


class VideoSettings(BaseSettings):
    """What a video may be, and how far ahead the wall schedules a play, pause or seek."""

    model_config = SettingsConfigDict(env_prefix="TAGWALL_VIDEO_", extra="ignore")

    # A lecture in 1080p H.264 at 4 Mbit/s is 1.8 GB an hour.
    max_bytes: int = Field(default=4_000_000_000, ge=1)
    # Three hours take the longest lecture; a whole day's recording is no lecture.
    max_duration_s: float = Field(default=3 * 3600, gt=0)
    # Every tile has a play, pause or seek, and a start's first frame decoded, by then.
    lead_ms: int = Field(default=500, ge=50, le=10_000)


def video_settings() -> VideoSettings:
    """The video app's settings from the environment; ValueError naming each bad one
    (``TAGWALL_VIDEO_MAX_BYTES: ...``), so the server stops at start."""
    try:
        return VideoSettings()
    except ValidationError as error:
        raise ValueError("; ".join(setting_problems(error, VideoSettings))) from None
