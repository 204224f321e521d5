"""A lesson to share: an image with its hotspots exported as one file and imported on
another installation with the CLI, and every bad lesson file refused with its line
and nothing stored."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from tests.webapp.apps.image.lessons import BAD, GOOD, HANDMADE, changed, lesson_zip, spot
from tests.webapp.apps.image.samples import NUCLEUS, WALL_TEXT, png_bytes
from webapp.apps.image import hotspots
from webapp.apps.image.hotspots import HotspotFields
from webapp.apps.image.lesson import LessonRefused, import_lesson
from webapp.apps.image.store import ImageStore
from webapp.cli.commands import main


@pytest.mark.parametrize(("case", "members", "line"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_lesson_is_refused_with_its_line_and_nothing_stored(
    tmp_path: Path, case: str, members: dict[str, bytes], line: str
) -> None:
    store = ImageStore(tmp_path / "images", max_upload_bytes=100_000)
    source = lesson_zip(tmp_path / "cell.tagwall-lesson", members)
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert refused.value.problems == [line]
    assert list(store.root.iterdir()) == []
    assert not (tmp_path / "evil.txt").exists()


@pytest.mark.parametrize(("case", "made", "line"), HANDMADE, ids=[h[0] for h in HANDMADE])
def test_a_damaged_or_foreign_zip_is_refused_in_one_line(
    tmp_path: Path, case: str, made: Any, line: str
) -> None:
    """ZIPs no lesson export makes (each built byte by byte): refused before anything
    is stored, never more extracted than a member declares."""
    store = ImageStore(tmp_path / "images", max_upload_bytes=100_000)
    source = tmp_path / "cell.tagwall-lesson"
    source.write_bytes(made())
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert refused.value.problems == [line]
    assert list(store.root.iterdir()) == []


def test_not_a_zip_and_every_problem_of_a_file_on_a_line_of_its_own(tmp_path: Path) -> None:
    store = ImageStore(tmp_path / "images")
    notes = tmp_path / "notes.zip"
    notes.write_text("not a zip")
    with pytest.raises(LessonRefused, match=r"^notes.zip: not a ZIP file \(a lesson"):
        import_lesson(store, notes)
    both = [spot(x=-1), spot(question=None, accepted=["x"])]
    source = lesson_zip(tmp_path / "two.zip", {**GOOD, "lesson.json": changed(hotspots=both)})
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert len(refused.value.problems) == 2
    assert "Accepted answers need a question." in refused.value.problems[1]


def test_export_then_import_on_a_fresh_installation_with_the_cli(tmp_path: Path) -> None:
    runner = CliRunner()
    here = {"TAGWALL_VAR_DIR": str(tmp_path / "here")}
    there = {"TAGWALL_VAR_DIR": str(tmp_path / "there")}
    source = tmp_path / "cell.png"
    source.write_bytes(png_bytes())
    assert (
        runner.invoke(main, ["image", "add", str(source), "--title", "Cell"], env=here).exit_code
        == 0
    )
    store = ImageStore(tmp_path / "here" / "images")
    image_id = store.images()[0].id
    for fields in (NUCLEUS, WALL_TEXT):
        hotspots.add(store, image_id, HotspotFields.model_validate(fields))

    lesson = tmp_path / "cell.tagwall-lesson"
    exported = runner.invoke(main, ["image", "export", image_id, str(lesson)], env=here)
    assert exported.exit_code == 0, exported.output
    checked = runner.invoke(main, ["image", "check", str(lesson)], env=there)
    assert checked.stdout == "ok: 'Cell', 600 x 400 px, 2 hotspots, 1 questions\n"
    imported = runner.invoke(main, ["image", "import", str(lesson)], env=there)
    assert imported.exit_code == 0, imported.output
    assert "'Cell', 600 x 400 px, 2 hotspots" in imported.stdout

    fresh = ImageStore(tmp_path / "there" / "images")
    [manifest] = fresh.images()
    assert (manifest.width, manifest.height, manifest.title) == (600, 400, "Cell")
    strip = [s.model_dump(exclude={"id"}) for s in hotspots.hotspots(store, image_id)]
    assert [s.model_dump(exclude={"id"}) for s in hotspots.hotspots(fresh, manifest.id)] == strip

    bad = lesson_zip(tmp_path / "bad.zip", {"lesson.json": changed()})
    for command in ("check", "import"):
        refused = runner.invoke(main, ["image", command, str(bad)], env=there)
        assert refused.exit_code == 2
        assert refused.stderr.splitlines() == [
            "bad.zip: the image 'cell.png' is missing.",
            "1 problem(s) found",
        ]
    assert len(fresh.images()) == 1
    missing = runner.invoke(main, ["image", "export", "0123456789ab", str(lesson)], env=here)
    assert missing.exit_code == 2 and "There is no image 0123456789ab." in missing.stderr
