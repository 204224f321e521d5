"""`tagwall video add`, `list`, `remove` and `testcard`, as a person at a shell uses them."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from PIL import Image

from tests.conftest import migrate, wall_files
from tests.webapp.apps.video.conftest import Samples
from webapp.apps.video.state import VideoState
from webapp.apps.video.testcard import read_cell
from webapp.cli.commands import main
from webapp.database.connection import Database
from webapp.engine.wall_state import commit_change


def test_add_then_list_and_bad_files_exit_2_with_one_line(
    tmp_path: Path, video_sample: Samples
) -> None:
    env = {"TAGWALL_VAR_DIR": str(tmp_path / "var")}
    runner = CliRunner()
    added = runner.invoke(
        main, ["video", "add", str(video_sample("lecture.webm")), "--title", "Valves"], env=env
    )
    assert added.exit_code == 0, added.output
    assert "'Valves', 64 x 36 px, 0:01.0 at 30 fps, vp9, opus, in" in added.stdout
    listed = runner.invoke(main, ["video", "list"], env=env)
    assert listed.stdout.split()[1:] == ["64", "x", "36", "px", "0:01.0", "Valves"]

    for bad, said in [
        (video_sample("hevc.mp4"), "hevc.mp4 is MP4 with H.265 video"),
        (video_sample("four-hours.mp4"), "four-hours.mp4 lasts 4 h 0 min"),
        (video_sample("talk.m4a"), "talk.m4a has no video stream"),
    ]:
        refused = runner.invoke(main, ["video", "add", str(bad)], env=env)
        assert refused.exit_code == 2 and said in refused.stderr, refused.output
        assert len(refused.stderr.strip().splitlines()) == 1
    small = runner.invoke(
        main,
        ["video", "add", str(video_sample("lecture.mp4"))],
        env={**env, "TAGWALL_VIDEO_MAX_BYTES": "1000"},
    )
    assert small.exit_code == 2 and "TAGWALL_VIDEO_MAX_BYTES" in small.stderr
    assert len(runner.invoke(main, ["video", "list"], env=env).stdout.splitlines()) == 1


def test_remove_takes_a_video_off_the_disk_unless_a_wall_shows_it(
    tmp_path: Path, video_sample: Samples
) -> None:
    var = tmp_path / "var"
    env = {"TAGWALL_VAR_DIR": str(var), "TAGWALL_WALL_CONFIGS": str(wall_files("demo")[0])}
    runner = CliRunner()
    lecture = str(video_sample("lecture.mp4"))
    added = [
        runner.invoke(main, ["video", "add", lecture, "--title", title], env=env)
        for title in ("Shown", "Kept")
    ]
    shown, kept = (result.stdout.split()[1].rstrip(":") for result in added)  # "added ID: ..."
    url = f"sqlite:///{var / 'tagwall.db'}"
    migrate(url)
    db = Database(url)
    commit_change(
        db,
        "demo",
        lambda state: VideoState(video=shown).put(state.model_copy(update={"app": "video"})),
        keep_events=10,
    )
    db.dispose()

    refused = runner.invoke(main, ["video", "remove", shown], env=env)
    assert refused.exit_code == 2
    assert refused.stderr == (
        "error: 'Shown' is shown on Demo wall (3 x 2, 55-inch): show another video there first.\n"
    )
    removed = runner.invoke(main, ["video", "remove", kept], env=env)
    assert removed.exit_code == 0, removed.output
    assert removed.stdout == f"removed {kept}: 'Kept'\n"
    assert sorted(p.name for p in (var / "videos").iterdir()) == [shown]
    again = runner.invoke(main, ["video", "remove", kept], env=env)
    assert again.exit_code == 2 and again.stderr == f"error: There is no video {kept}.\n"


def test_a_testcard_shows_each_frames_number_in_every_cell(tmp_path: Path) -> None:
    card = tmp_path / "card.mp4"
    runner = CliRunner()
    made = runner.invoke(
        main, ["video", "testcard", str(card), "--seconds", "2", "--columns", "2", "--rows", "1",
               "--width", "320", "--height", "90"],
    )  # fmt: skip
    assert made.exit_code == 0, made.output
    assert made.stdout == f"wrote {card}: 2 x 1 cells, 320 x 90 px, 2 s\n"
    for frame in (0, 37, 59):
        still = tmp_path / f"{frame}.png"
        subprocess.run(
            ["ffmpeg", "-v", "error", "-i", str(card), "-vf", f"select=eq(n\\,{frame})",
             "-frames:v", "1", str(still)],
            check=True,
        )  # fmt: skip
        pixels = np.asarray(Image.open(still).convert("RGB"))
        assert [read_cell(pixels[:, :160]), read_cell(pixels[:, 160:])] == [frame, frame]
    assert read_cell(np.full((90, 160, 3), 128, np.uint8)) is None  # grey: no card
    too_long = runner.invoke(main, ["video", "testcard", str(card), "--seconds", "2000"])
    assert too_long.exit_code == 2
    assert too_long.stderr == "error: a card counts 32768 frames at most (1092 s)\n"
