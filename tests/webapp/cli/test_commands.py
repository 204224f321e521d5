"""The command line, driven through click's runner like a person at a shell."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm, symbol_modules
from tests.conftest import TEST_SECRET, blob_volume
from wall_client.config import load_wall
from webapp.apps.discovery import installed_apps
from webapp.cli.commands import log_fit, main
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.engine.wall_state import read_state
from webapp.people.accounts import authenticate
from webapp.tags.schemas import LayoutInfo, PlacedCode
from webapp.volume.store import VolumeStore


@pytest.fixture
def env(tmp_path: Path, database_url: str) -> dict[str, str]:
    return {
        "TAGWALL_VAR_DIR": str(tmp_path / "var"),
        "TAGWALL_DATABASE_URL": database_url,
        "TAGWALL_SECRET_KEY": TEST_SECRET,
        "TAGWALL_HOST": "127.0.0.1",
        "TAGWALL_PORT": "8111",
        "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
    }


def run(env: dict[str, str], *args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args), env=env)
    return result.exit_code, result.stdout, result.stderr


def test_tiles_prints_one_url_per_display(env: dict[str, str]) -> None:
    code, out, _ = run(env, "tiles", "--wall", "demo")
    lines = out.splitlines()
    assert code == 0 and len(lines) == 6
    assert lines[0].startswith("http://127.0.0.1:8111/wall/demo/tile/r1c1?token=")
    assert len({line.split("token=")[1] for line in lines}) == 1


def test_tiles_unknown_wall_exits_2(env: dict[str, str]) -> None:
    code, _, err = run(env, "tiles", "--wall", "atlantis")
    assert code == 2 and "atlantis" in err and "demo" in err


def test_urls_prints_dashboard_overview_and_tiles(env: dict[str, str]) -> None:
    code, out, _ = run(env, "urls")
    assert code == 0
    assert "dashboard: http://127.0.0.1:8111/login/operator?token=" in out
    assert "overview:  http://127.0.0.1:8111/wall/demo/overview" in out
    assert out.count("/tile/") == 6


@pytest.mark.parametrize("command", ["urls", "tiles"])
def test_links_from_a_folder_without_an_installation_are_refused(
    env: dict[str, str], tmp_path: Path, command: str
) -> None:
    """Issue 31: `tagwall urls` with another TAGWALL_VAR_DIR printed links of a secret it
    had just made up there (no server answers them) and created the folder."""
    elsewhere = tmp_path / "elsewhere"
    bare = {
        **env,
        "TAGWALL_VAR_DIR": str(elsewhere),
        "TAGWALL_SECRET_KEY": "",
        "TAGWALL_DATABASE_URL": "",
    }
    code, out, err = run(bare, command)
    assert code == 2 and out == ""
    assert err.splitlines() == [
        f"error: there is no tagwall installation in {elsewhere} (no secret_key and no"
        " tagwall.db there): point TAGWALL_VAR_DIR at the installation's folder, or start"
        " one there with `tagwall serve`"
    ]
    assert not elsewhere.exists(), "nothing was created"


def test_config_check_accepts_shipped_walls(env: dict[str, str]) -> None:
    files = sorted(str(p) for p in (CONTENT_DIR / "walls").glob("*.toml"))
    code, out, _ = run(env, "config", "check", *files)
    assert code == 0 and out.count(": ok:") == len(files)


def test_config_check_rejects_bad_file_with_exit_2(env: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[grid]\ncolumns = 0\nrows = 2\nresolution = [1920, 1080]\nactive_mm = [1, 1]\n")
    code, _, err = run(env, "config", "check", str(bad))
    assert code == 2 and "bad.toml" in err and "grid.columns" in err


def test_config_check_missing_file_exits_2(env: dict[str, str], tmp_path: Path) -> None:
    code, _, err = run(env, "config", "check", str(tmp_path / "absent.toml"))
    assert code == 2 and "absent.toml" in err


def test_broken_wall_configs_stop_commands_with_a_message(
    env: dict[str, str], tmp_path: Path
) -> None:
    bad = tmp_path / "broken.toml"
    bad.write_text("this is = = not toml")
    code, _, err = run({**env, "TAGWALL_WALL_CONFIGS": str(bad)}, "tiles")
    assert code == 2 and "broken.toml" in err


def test_invalid_setting_exits_2(env: dict[str, str]) -> None:
    code, _, err = run({**env, "TAGWALL_PORT": "seventy"}, "tiles")
    assert code == 2 and "TAGWALL_PORT" in err


def test_db_upgrade_creates_tables(env: dict[str, str], database_url: str) -> None:
    code, out, _ = run(env, "db", "upgrade")
    assert code == 0 and "head" in out
    assert read_state(Database(database_url), "demo")[0] == 0


def test_db_downgrade_names_what_it_cannot_take_down(env: dict[str, str]) -> None:
    assert run(env, "db", "upgrade")[0] == 0
    code, _, err = run(env, "db", "downgrade", "base", "--app", "brain")
    assert code == 2
    assert err == "error: no installed app 'brain' has tables of its own (apps that have: none)\n"
    code, _, err = run(env, "db", "downgrade", "9999")
    assert code == 2 and err.startswith("error: ") and "9999" in err and "Traceback" not in err
    code, out, _ = run(env, "db", "downgrade", "0012")
    assert code == 0 and out == "database at 0012\n"


def test_kiosk_dry_run_prints_one_browser_per_display(env: dict[str, str]) -> None:
    code, out, _ = run(
        env,
        "kiosk",
        "--wall",
        "kl-3x3",
        "--node",
        "node1",
        "--dry-run",
        "--browser",
        "/usr/bin/chromium",
    )
    lines = out.splitlines()
    assert code == 0 and len(lines) == 2  # two displays per node on the 3x3 wall
    assert lines[0].startswith("r1c1: /usr/bin/chromium --kiosk")
    assert lines[1].startswith("r1c2: /usr/bin/chromium --kiosk")
    assert "--window-position=2560,0" in lines[1]
    assert "/wall/kl-3x3/tile/r1c1?token=" in lines[0]


def test_kiosk_unknown_node_exits_2(env: dict[str, str]) -> None:
    code, _, err = run(
        env, "kiosk", "--wall", "demo", "--node", "node99", "--dry-run", "--browser", "chromium"
    )
    assert code == 2 and "node99" in err


def test_codes_size_prints_the_code_on_every_display(env: dict[str, str]) -> None:
    code, out, _ = run(env, "codes", "size", "--wall", "demo", "--distance", "1.0")
    lines = out.splitlines()
    assert code == 0
    assert lines[0].startswith(
        "wall demo, seat codes, scanning distance 1 m: modules of at least 3.28 mm"
    )
    assert lines[1] == "QR version 2: 33 modules across, 4-module quiet zones included"
    rows = [line.split() for line in lines[3:]]
    assert [row[0] for row in rows] == ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
    # 0.63 mm pixels: 3.28 mm needs 6 px per module, 33 x 6 = 198 px, 125 mm.
    assert all(row[1:] == ["0.630", "6", "3.78", "198", "124.7"] for row in rows)


def test_codes_size_flags_codes_that_do_not_fit(env: dict[str, str]) -> None:
    code, out, _ = run(env, "codes", "size", "--wall", "hiperwall", "--distance", "30")
    assert code == 0 and out.count("(does not fit with its caption; fits up to 3 m)") == 50


def test_codes_size_defaults_to_the_walls_design_distance(env: dict[str, str]) -> None:
    code, out, _ = run(env, "codes", "size", "--wall", "hiperwall", "--qr-version", "3")
    assert code == 0 and out.startswith("wall hiperwall, seat codes, scanning distance 2.5 m")
    assert "QR version 3: 37 modules across" in out
    code, out, _ = run(env, "codes", "size", "--wall", "hiperwall", "--purpose", "walk-up")
    assert code == 0 and out.startswith("wall hiperwall, walk-up codes, scanning distance 0.8 m")


@pytest.mark.parametrize(
    "args", [("--distance", "0"), ("--distance", "far"), ("--qr-version", "41")]
)
def test_codes_size_rejects_bad_options(env: dict[str, str], args: tuple[str, str]) -> None:
    code, _, err = run(env, "codes", "size", "--wall", "demo", *args)
    assert code == 2 and "Invalid value" in err


def test_user_add_asks_for_the_password_twice_and_the_account_signs_in(
    env: dict[str, str], database_url: str
) -> None:
    result = CliRunner().invoke(
        main,
        ["user", "add", "Alice", "--role", "instructor"],
        env=env,
        input="pw-123456\npw-123456\n",
    )
    assert result.exit_code == 0, result.output
    assert "added alice (instructor)" in result.stdout
    assert "pw-123456" not in result.stdout
    database = Database(database_url)
    try:
        assert authenticate(database, "ALICE", "pw-123456") is not None
        assert authenticate(database, "alice", "wrong-password") is None
    finally:
        database.dispose()


def test_user_list_remove_and_passwd(env: dict[str, str], database_url: str) -> None:
    run(env, "user", "add", "bob", "--role", "admin", "--password", "first-pass")
    code, out, _ = run(env, "user", "list")
    assert code == 0 and out.startswith("bob\tadmin\t") and out.endswith("\tpassword\n")
    code, out, _ = run(env, "user", "passwd", "bob", "--password", "second-pass")
    assert code == 0 and "password of bob changed" in out
    database = Database(database_url)
    try:
        assert authenticate(database, "bob", "first-pass") is None
        assert authenticate(database, "bob", "second-pass") is not None
    finally:
        database.dispose()
    assert run(env, "user", "remove", "bob")[:2] == (0, "removed bob\n")
    assert run(env, "user", "list")[1] == "no accounts\n"


@pytest.mark.parametrize(
    "args,message",
    [
        (["user", "add", "x", "--password", "long-enough"], "not a valid username"),
        (["user", "add", "carol", "--password", "short"], "at least 8 characters"),
        (["user", "remove", "nobody"], "no account called 'nobody'"),
        (["user", "passwd", "nobody", "--password", "long-enough"], "no account called"),
    ],
)
def test_user_commands_refuse_bad_requests_with_exit_1(
    env: dict[str, str], args: list[str], message: str
) -> None:
    code, _, err = run(env, *args)
    assert code == 1 and message in err


def test_user_add_refuses_a_taken_name(env: dict[str, str]) -> None:
    assert run(env, "user", "add", "dave", "--password", "long-enough")[0] == 0
    code, _, err = run(env, "user", "add", "DAVE", "--password", "long-enough")
    assert code == 1 and "already an account called 'dave'" in err


def test_volume_build_writes_a_store_that_volume_list_shows(
    env: dict[str, str], tmp_path: Path
) -> None:
    source = tmp_path / "blobs.npy"
    np.save(source, blob_volume())
    code, out, err = run(env, "volume", "build", str(source), "--brick", "8", "--spacing", "1,1,2")
    assert code == 0, err
    store = tmp_path / "var" / "volumes" / "blobs"
    assert (store / "volume.json").is_file()
    assert "40 x 36 x 28 voxels, bricks of 8" in out
    code, out, _ = run(env, "volume", "list")
    assert code == 0
    assert out.startswith("blobs: 40 x 36 x 28 voxels of 1 mm, from blobs.npy")
    assert VolumeStore(store).meta.spacing == (1.0, 1.0, 2.0)


def test_volume_build_into_a_named_directory(env: dict[str, str], tmp_path: Path) -> None:
    source = tmp_path / "blobs.npy"
    np.save(source, blob_volume())
    code, _, err = run(env, "volume", "build", str(source), str(tmp_path / "brain"))
    assert code == 0, err
    assert VolumeStore(tmp_path / "brain").meta.name == "brain"


def test_volume_list_says_when_there_are_none(env: dict[str, str]) -> None:
    code, out, _ = run(env, "volume", "list")
    assert code == 0 and out.startswith("no volumes in ")


@pytest.mark.parametrize(
    "arguments,message",
    [
        (["missing.npy"], "no such file"),
        (["flat.npy"], "a 3-D volume is needed"),
        (["blobs.npy", "--brick", "12"], "the brick side must be a power of two"),
        (["blobs.npy", "--spacing", "1,1"], "three positive numbers"),
    ],
)
def test_volume_build_refuses_bad_input_with_a_message(
    env: dict[str, str], tmp_path: Path, arguments: list[str], message: str
) -> None:
    np.save(tmp_path / "blobs.npy", blob_volume())
    np.save(tmp_path / "flat.npy", np.zeros((4, 4), dtype=np.uint8))
    arguments = [str(tmp_path / arguments[0]), *arguments[1:]]
    code, out, err = run(env, "volume", "build", *arguments)
    assert code == 2
    assert message in out + err
    assert "Traceback" not in out + err
    assert not (tmp_path / "var" / "volumes").exists() or not any(
        (tmp_path / "var" / "volumes").iterdir()
    )


# --- configuration and database problems: one clear line, exit 2, never a traceback ---


def refused(env: dict[str, str], *args: str) -> str:
    """Run a command that must refuse; its one line of error."""
    code, out, err = run(env, *args)
    assert code == 2, (out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ")
    return lines[0]


def test_a_setting_that_is_not_json_is_one_line(env: dict[str, str]) -> None:
    line = refused({**env, "TAGWALL_INFO_CLASS_MAX": "{student: 3"}, "serve")
    assert "TAGWALL_INFO_CLASS_MAX" in line and "JSON" in line


def test_an_unreachable_database_is_one_line(env: dict[str, str]) -> None:
    url = "postgresql+psycopg://tagwall:hunter2@127.0.0.1:1/tagwall"
    line = refused({**env, "TAGWALL_DATABASE_URL": url}, "serve")
    assert "cannot use the database at postgresql+psycopg://tagwall:***@127.0.0.1:1" in line
    assert "hunter2" not in line


def test_an_unreachable_redis_is_one_line(env: dict[str, str]) -> None:
    redis = {"TAGWALL_BUS": "redis", "TAGWALL_REDIS_URL": "redis://:hunter2@127.0.0.1:1/0"}
    line = refused({**env, **redis}, "serve")
    assert "cannot use Redis at redis://:***@127.0.0.1:1/0 (TAGWALL_REDIS_URL)" in line
    assert "hunter2" not in line


def test_a_redis_url_that_is_not_one_is_one_line(env: dict[str, str]) -> None:
    redis = {"TAGWALL_BUS": "redis", "TAGWALL_REDIS_URL": "redis://127.0.0.1:port/0"}
    line = refused({**env, **redis}, "serve")
    assert "TAGWALL_REDIS_URL redis://127.0.0.1:port/0 is not a Redis URL" in line


@pytest.mark.parametrize("url", ["not a url", "mysqlx://somewhere/db", "sqlite+nodriver:///x"])
def test_a_nonsense_database_url_is_one_line(env: dict[str, str], url: str) -> None:
    line = refused({**env, "TAGWALL_DATABASE_URL": url}, "serve")
    assert "is not a database URL tagwall can use" in line


def test_a_damaged_sqlite_file_is_one_line(env: dict[str, str], tmp_path: Path) -> None:
    damaged = tmp_path / "damaged.db"
    damaged.write_bytes(b"these bytes were never a database " * 200)
    line = refused({**env, "TAGWALL_DATABASE_URL": f"sqlite:///{damaged}"}, "serve")
    assert "damaged.db is damaged or not a database" in line
    assert damaged.read_bytes().startswith(b"these bytes"), "nothing written over it"


def test_no_walls_configured_is_one_line(env: dict[str, str], tmp_path: Path) -> None:
    empty = tmp_path / "walls"
    empty.mkdir()
    line = refused({**env, "TAGWALL_WALL_CONFIGS": str(empty)}, "serve")
    assert "no wall configs found" in line and str(empty) in line


def test_an_unknown_default_wall_is_one_line(env: dict[str, str]) -> None:
    for command in (("serve",), ("urls",), ("tiles",)):
        line = refused({**env, "TAGWALL_DEFAULT_WALL": "atlantis"}, *command)
        assert "TAGWALL_DEFAULT_WALL" in line and "'atlantis'" in line and "demo" in line


def test_production_without_a_secret_refuses_to_start(env: dict[str, str]) -> None:
    production = {**env, "TAGWALL_ENV": "production", "TAGWALL_SECRET_KEY": ""}
    line = refused(production, "serve")
    assert "TAGWALL_SECRET_KEY is required in production" in line
    assert not (Path(env["TAGWALL_VAR_DIR"]) / "secret_key").exists(), "none was made up"


def test_tokens_rotate_prints_the_new_urls(env: dict[str, str]) -> None:
    _, before, _ = run(env, "tiles", "--wall", "demo")
    code, out, _ = run(env, "tokens", "rotate", "tiles", "--wall", "demo")
    _, after, _ = run(env, "tiles", "--wall", "demo")
    assert code == 0 and "wall demo: new tile URLs" in out
    assert before != after and after.splitlines()[0] in out
    _, other_before, _ = run(env, "tiles", "--wall", "kl-3x3")
    code, out, _ = run(env, "tokens", "rotate", "operator")
    assert code == 0 and "new operator sign-in link: http://127.0.0.1:8111/login/operator" in out
    assert run(env, "tiles", "--wall", "kl-3x3")[1] == other_before, "other walls keep theirs"


def test_several_workers_without_what_they_share_refuse_to_start(env: dict[str, str]) -> None:
    """A memory bus reaches one process's tiles and SQLite serves one process: more
    workers than that is one clear line, before anything listens."""
    line = refused(env, "serve", "--workers", "2")
    assert line == (
        "error: TAGWALL_WORKERS=2 needs TAGWALL_BUS=redis: the memory bus reaches the tiles "
        "of one process only"
    )
    sqlite = f"sqlite:///{env['TAGWALL_VAR_DIR']}/tagwall.db"  # whichever database the suite uses
    on_sqlite = {
        **env,
        "TAGWALL_BUS": "redis",
        "TAGWALL_WORKERS": "3",
        "TAGWALL_DATABASE_URL": sqlite,
    }
    line = refused(on_sqlite, "serve")
    assert line.startswith("error: TAGWALL_WORKERS=3 needs PostgreSQL")
    assert refused({**env, "TAGWALL_WORKERS": "0"}, "serve").startswith("error: TAGWALL_WORKERS: ")


def _install_broken_app(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An installed distribution whose app entry point names a module that is not there."""
    info = folder / "broken_app-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-app\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[tagwall.apps]\nbroken = no_such_module.app:App\n")
    monkeypatch.syspath_prepend(str(folder))


def test_an_app_that_cannot_be_loaded_stops_serve_with_one_line_and_help_warns(
    env: dict[str, str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _install_broken_app(tmp_path / "site", monkeypatch)
    broken = "app 'broken' (broken-app 1.0, no_such_module.app:App) could not be loaded"
    code, out, err = run(env, "serve")
    assert code == 2, out
    assert err.strip().startswith(f"error: {broken}") and "Traceback" not in err
    code, out, err = run(env, "--help")
    assert code == 0 and "serve" in out  # the core's commands still there
    assert err.splitlines()[0].startswith(f"warning: {broken}") and "Traceback" not in err
    assert "TAGWALL_APPS" in err  # how to switch it off
    code, out, err = run({**env, "TAGWALL_APPS": "brain, census"}, "content", "--help")
    assert code == 0 and not err, err  # switched off, the rest of tagwall works


def test_serve_refuses_a_first_app_that_is_not_installed(env: dict[str, str]) -> None:
    code, _, err = run({**env, "TAGWALL_FIRST_APP": "painting"}, "serve")
    assert code == 2
    assert "TAGWALL_FIRST_APP='painting' is not an installed app" in err


CRAMPED_WALL = """
id = "cramped"
seat_distance_m = 4.0
[grid]
columns = 2
rows = 2
resolution = [3840, 2160]
active_mm = [597.7, 336.2]
bezel_mm = 12
"""
"""Issue 31: 2 x 2 27-inch 4K panels, 12 mm bezels, students 3-4 m away."""
CRAMPED_ERROR = (
    "error: Student and Instructor codes do not fit the registration screen at 4 m:"
    " seats up to 2.5 m fit, or give the registration screen more displays"
)


@pytest.fixture
def cramped(tmp_path: Path) -> Path:
    path = tmp_path / "cramped.toml"
    path.write_text(CRAMPED_WALL)
    return path


def test_config_check_fails_a_wall_without_room_for_the_registration_codes(
    env: dict[str, str], cramped: Path
) -> None:
    """Issue 31: such a wall passed, and its registration codes were silently missing."""
    code, out, err = run(env, "config", "check", str(cramped))
    assert code == 1
    assert out.startswith(f"{cramped}: codes do not fit: wall 'cramped', 4 displays")
    lines = err.splitlines()
    assert lines[0] == f"{cramped}: {CRAMPED_ERROR}"
    assert lines[1].startswith(f"{cramped}: warning: the Tract index code does not fit")
    assert len(lines) == 2


def test_config_check_still_names_malformed_files_beside_walls_that_do_not_fit(
    env: dict[str, str], cramped: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('id = "bad"\nseat_distance_m = -1\n')
    code, _, err = run(env, "config", "check", str(bad), str(cramped))
    assert code == 2
    assert f"{bad}: seat_distance_m:" in err and f"{cramped}: {CRAMPED_ERROR}" in err


def test_codes_size_says_what_the_placement_can_place_captions_included(
    env: dict[str, str], cramped: Path
) -> None:
    """Issue 31: at 3 m it printed a 328 mm code with no warning, which the server
    could not place with its caption; now each row says what the placement says."""
    wall = load_wall(cramped)
    configured = {**env, "TAGWALL_WALL_CONFIGS": str(cramped), "TAGWALL_DEFAULT_WALL": "cramped"}
    for distance, fits in (("3", False), ("2.5", True)):
        code, out, _ = run(configured, "codes", "size", "--distance", distance)
        request = PlacementRequest(
            key="Student",
            sizes=(symbol_modules(25),),
            module_mm=min_module_mm(float(distance)),
            screen="registration",
            caption=True,
        )
        assert bool(place(wall, [request]).placed) is fits
        rows = out.splitlines()[3:7]
        assert code == 0 and [row.split()[0] for row in rows] == ["r1c1", "r1c2", "r2c1", "r2c2"]
        flag = "(does not fit with its caption; fits up to 2.5 m)"
        assert all(row.endswith(flag) is not fits for row in rows)
    code, out, _ = run(configured, "codes", "size", "--distance", "3")
    assert out.splitlines()[7] == CRAMPED_ERROR.replace("at 4 m", "at 3 m")


def test_serve_logs_what_does_not_fit_each_wall(
    cramped: Path, caplog: pytest.LogCaptureFixture
) -> None:
    walls = {"cramped": load_wall(cramped), "demo": load_wall(CONTENT_DIR / "walls" / "demo.toml")}
    with caplog.at_level(logging.WARNING, logger="webapp.cli.commands"):
        log_fit(walls, installed_apps(), "http://127.0.0.1:8111")
    first = caplog.records[0].getMessage()
    assert first == f"wall cramped: {CRAMPED_ERROR}"
    assert not [r for r in caplog.records if r.getMessage().startswith("wall demo")]


Point = tuple[float, float]


def placed_code(code: str, rect: tuple[float, float, float, float], head: Point) -> PlacedCode:
    """A code standing on ``rect`` (scene mm of the demo wall) with a pin to ``head``."""
    x, y, w, h = rect
    edge = (min(max(head[0], x), x + w), min(max(head[1], y), y + h))
    return PlacedCode(
        code=code, label=f"Tract {code}", kind="tract", payload=f"http://wall/t/{code}",
        display="r2c2", rect=rect, pixels=(0, 0, 99), px_per_module=3, modules=33,
        error="M", version=2, matrix=[], anchor=head, leader=(edge, head),
    )  # fmt: skip


@pytest.mark.parametrize("crossing", [True, False])
def test_check_reports_pins_that_cross_and_exits_1(
    env: dict[str, str], monkeypatch: pytest.MonkeyPatch, crossing: bool
) -> None:
    """The pin rule is checked on the layout the server gives (its geometry: every
    code still decodes), before and whatever the tiles' photographs say."""
    a = placed_code("AAAAAAA", (1000, 800, 100, 100), (1300, 1000))
    b = placed_code("BBBBBBB", (1200, 800, 100, 100), (1000 if crossing else 1400, 1000))
    layout = LayoutInfo(id=1, wall="demo", tag_set=None, placed=[a, b], unplaced=[])
    check_module = pytest.importorskip("webapp.cli.check")  # Playwright: the check extra

    def every_code_decodes(*args: object) -> None:
        report = args[-1]
        assert isinstance(report, check_module.CheckReport)
        report.decoded = report.intact = report.expected

    monkeypatch.setattr(check_module, "fetch_layout", lambda *args: (1, layout))
    monkeypatch.setattr(check_module, "_photograph", every_code_decodes)
    code, out, _ = run(env, "check", "--wall", "demo", "--browser", "/bin/true")
    if crossing:
        assert code == 1, out
        assert "pins: 1 crossing, under a code or with the head under one" in out
        assert "  FAIL the pins of AAAAAAA (Tract AAAAAAA) and BBBBBBB (Tract BBBBBBB) cross" in out
    else:
        assert code == 0, out
        assert "pins: 0 crossing" in out
