"""`tagwall image add`, `list` and `remove`, as a person at a shell would use them."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest
from click.testing import CliRunner

from tests.conftest import migrate, wall_files
from tests.webapp.apps.image.samples import png_declaring, quadrants, save
from webapp.apps.image import store
from webapp.apps.image.state import ImageState
from webapp.cli.commands import main
from webapp.database.connection import Database
from webapp.engine.wall_state import commit_change


def test_add_then_list_and_bad_files_exit_2_with_one_line(tmp_path: Path) -> None:
    env = {"TAGWALL_VAR_DIR": str(tmp_path / "var")}
    runner = CliRunner()
    source = save(tmp_path / "slide.tif", quadrants(300, 200))
    added = runner.invoke(main, ["image", "add", str(source), "--title", "Slide 1"], env=env)
    assert added.exit_code == 0, added.output
    assert "'Slide 1', 300 x 200 px, 10 levels" in added.stdout
    listed = runner.invoke(main, ["image", "list"], env=env)
    assert listed.stdout.split()[1:] == ["300", "x", "200", "px", "Slide", "1"]

    (tmp_path / "notes.jpg").write_text("not a picture")
    bomb = png_declaring(tmp_path / "bomb.png", 100_000, 100_000)
    for bad, said in [(tmp_path / "notes.jpg", "not a PNG, JPEG or TIFF"), (bomb, "declares")]:
        refused = runner.invoke(main, ["image", "add", str(bad)], env=env)
        assert refused.exit_code == 2 and said in refused.stderr, refused.output
        assert len(refused.stderr.strip().splitlines()) == 1
    assert len(runner.invoke(main, ["image", "list"], env=env).stdout.splitlines()) == 1
    assert sorted(p.name for p in (tmp_path / "var" / "images").iterdir()) == [
        listed.stdout.split()[0]
    ]


def test_without_libvips_adding_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def missing(name: str) -> ModuleType:
        raise OSError("cannot load library 'libvips.so.42'")

    monkeypatch.setattr(store.importlib, "import_module", missing)
    source = save(tmp_path / "slide.png", quadrants(30, 20))
    refused = CliRunner().invoke(
        main, ["image", "add", str(source)], env={"TAGWALL_VAR_DIR": str(tmp_path / "var")}
    )
    assert refused.exit_code == 2
    assert refused.stderr.strip() == (
        "error: libvips is not installed (cannot load library 'libvips.so.42'): "
        "apt-get install libvips42"
    )


def test_remove_takes_an_image_off_the_disk_unless_a_wall_shows_it(tmp_path: Path) -> None:
    var = tmp_path / "var"
    env = {
        "TAGWALL_VAR_DIR": str(var),
        "TAGWALL_WALL_CONFIGS": str(wall_files("demo")[0]),
    }
    runner = CliRunner()
    source = save(tmp_path / "slide.png", quadrants(30, 20))
    added = [
        runner.invoke(main, ["image", "add", str(source), "--title", title], env=env)
        for title in ("Shown", "Kept")
    ]
    shown, kept = (result.stdout.split()[1].rstrip(":") for result in added)  # "added ID: ..."
    url = f"sqlite:///{var / 'tagwall.db'}"
    migrate(url)
    db = Database(url)
    commit_change(
        db,
        "demo",
        lambda state: ImageState(image=shown).put(state.model_copy(update={"app": "image"})),
        keep_events=10,
    )
    db.dispose()

    refused = runner.invoke(main, ["image", "remove", shown], env=env)
    assert refused.exit_code == 2
    assert refused.stderr == (
        "error: 'Shown' is shown on Demo wall (3 x 2, 55-inch): show another image there first.\n"
    )
    removed = runner.invoke(main, ["image", "remove", kept], env=env)
    assert removed.exit_code == 0, removed.output
    assert removed.stdout == f"removed {kept}: 'Kept'\n"
    assert sorted(p.name for p in (var / "images").iterdir()) == [shown]
    again = runner.invoke(main, ["image", "remove", kept], env=env)
    assert again.exit_code == 2 and again.stderr == f"error: There is no image {kept}.\n"
