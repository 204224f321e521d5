"""The video app's own settings: a bad one stops the server at start naming it; every
one is documented."""

from __future__ import annotations

from importlib.metadata import entry_points

import pytest
from click.testing import CliRunner

from webapp.apps.discovery import GROUP, AppLoadError, load_app
from webapp.apps.video.settings import VideoSettings, video_settings
from webapp.cli.commands import main
from webapp.core.settings import PROJECT_ROOT


@pytest.mark.parametrize(
    "variable,value,says",
    [
        ("MAX_BYTES", "0", "greater than or equal to 1"),
        ("MAX_DURATION_S", "an hour", "valid number"),
        ("LEAD_MS", "20", "greater than or equal to 50"),
    ],
)
def test_a_bad_setting_is_refused_naming_it(
    monkeypatch: pytest.MonkeyPatch, variable: str, value: str, says: str
) -> None:
    monkeypatch.setenv(f"TAGWALL_VIDEO_{variable}", value)
    with pytest.raises(ValueError, match=f"^TAGWALL_VIDEO_{variable}: ") as refused:
        video_settings()
    assert says in str(refused.value)


def test_a_bad_setting_stops_the_server_at_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TAGWALL_VIDEO_LEAD_MS", "0")
    video = next(e for e in entry_points(group=GROUP) if e.name == "video")
    with pytest.raises(AppLoadError, match=r"TAGWALL_VIDEO_LEAD_MS: "):
        load_app(video)
    result = CliRunner().invoke(main, ["serve"])
    assert result.exit_code == 2
    assert "TAGWALL_VIDEO_LEAD_MS" in result.output and "Traceback" not in result.output


def test_every_video_setting_is_documented() -> None:
    text = (PROJECT_ROOT / "docs" / "configuration.md").read_text()
    for name in VideoSettings.model_fields:
        assert f"`TAGWALL_VIDEO_{name.upper()}`" in text, name
