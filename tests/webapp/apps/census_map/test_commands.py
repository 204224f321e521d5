"""`tagwall census`: importing data sets and listing them, as a person at a shell would."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

import httpx
import pytest
from click.testing import CliRunner

from tests.conftest import TEST_SECRET, migrate
from tests.webapp.apps.census_map.kml_schema import assert_valid_kml
from tests.webapp.apps.census_map.test_acs import INCOME, TABLES, VALUE, downloaded
from tests.webapp.apps.census_map.test_importer import three_tracts, write_shapefile
from webapp.apps.census_map import store
from webapp.apps.census_map.earth import base_signature
from webapp.cli.commands import main
from webapp.database.connection import Database
from webapp.people.security import operator_token


def closed_port() -> int:
    """A local port nothing listens on (bound once by the OS, then released)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


@pytest.fixture
def env(tmp_path: Path, database_url: str) -> dict[str, str]:
    """Settings whose server_url points at a port where no server runs."""
    return {
        "TAGWALL_VAR_DIR": str(tmp_path / "var"),
        "TAGWALL_DATABASE_URL": database_url,
        "TAGWALL_SECRET_KEY": TEST_SECRET,
        "TAGWALL_HOST": "127.0.0.1",
        "TAGWALL_PORT": str(closed_port()),
    }


def run(env: dict[str, str], *args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(main, list(args), env=env)
    return result.exit_code, result.stdout, result.stderr


def test_import_prints_the_report_when_no_server_runs(
    env: dict[str, str], tmp_path: Path, database_url: str
) -> None:
    shapes = three_tracts(tmp_path / "tracts.geojson")
    code, out, err = run(env, "census", "import", "--shapes", str(shapes), "--key", "GEOID")
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == "imported data set 1 'tracts': 3 tracts, 1 attributes"
    assert "attributes: POP" in lines
    assert "not reachable" in out and "when it next starts" in out
    database = Database(database_url)
    try:
        assert store.current_id(database) == 1
    finally:
        database.dispose()


def test_list_shows_the_data_sets_and_marks_the_current_one(
    env: dict[str, str], tmp_path: Path
) -> None:
    code, out, _ = run(env, "census", "list")
    assert code == 0 and "no census data sets" in out
    shapes = str(three_tracts(tmp_path / "tracts.geojson"))
    for name in ("first", "second"):
        args = ("census", "import", "--shapes", shapes, "--key", "GEOID", "--name", name)
        assert run(env, *args)[0] == 0
    code, out, _ = run(env, "census", "list")
    second, first = out.splitlines()
    assert code == 0
    assert second.startswith("*    2  second  'tracts'  3 tracts  ")
    assert first.startswith("     1  first  'tracts'  3 tracts  ") and first.endswith(" UTC")


@pytest.mark.parametrize(
    "extra,message",
    [
        (("--key", "FIPS"), "has no column 'FIPS'"),
        (("--key", "GEOID", "--table", "absent.csv"), "cannot read"),
        (("--key", "GEOID", "--strict", "--table", "short.csv"), "strict import refused"),
    ],
)
def test_bad_input_exits_1_with_the_message(
    env: dict[str, str], tmp_path: Path, extra: tuple[str, ...], message: str
) -> None:
    shapes = three_tracts(tmp_path / "tracts.geojson")
    (tmp_path / "short.csv").write_text("GEOID,POP\n06067000100,1\n")
    args = [str(tmp_path / a) if a.endswith(".csv") else a for a in extra]
    code, out, err = run(env, "census", "import", "--shapes", str(shapes), *args)
    assert code == 1 and err.startswith("error: ") and message in err
    assert "Traceback" not in out + err and "imported" not in out


def test_a_truncated_shapefile_prints_only_tagwalls_one_line(
    env: dict[str, str], tmp_path: Path
) -> None:
    """As a shell shows it, in a process of its own (where a library's warning would
    print, with its path in site-packages): the log's INFO lines, then the one error."""
    migrate(env["TAGWALL_DATABASE_URL"])  # no migration's lines in the log
    shapes = write_shapefile(tmp_path / "tracts")
    shapes.write_bytes(shapes.read_bytes()[:254])
    tagwall = Path(sys.executable).with_name("tagwall")
    done = subprocess.run(
        [str(tagwall), "census", "import", "--shapes", str(shapes), "--key", "GEOID"],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=120,
    )
    said = [line for line in done.stderr.splitlines() if not line.startswith("INFO ")]
    assert (done.returncode, said, done.stdout) == (
        1,
        [
            "error: tracts.shp: its .shp is cut short: its header declares 508 bytes, the "
            "file holds 254 (copy or download it again)"
        ],
        "",
    )


def test_an_acs_table_imports_with_its_labels_and_margins(
    env: dict[str, str], tmp_path: Path, database_url: str
) -> None:
    shapes = three_tracts(tmp_path / "tracts.geojson")
    tables = [str(path) for path in downloaded(tmp_path, INCOME, VALUE)]
    code, out, err = run(
        env, "census", "import", "--shapes", str(shapes), "--key", "GEOID",
        "--table", tables[0], "--table", tables[1],
    )  # fmt: skip
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0] == "imported data set 1 'tracts': 3 tracts, 2 attributes"
    assert "margins of error: B19013_001M, B25077_001M" in lines
    database = Database(database_url)
    try:
        dataset = store.load(database, 1)
    finally:
        database.dispose()
    assert dataset is not None and dataset.settings.attributes[1].label == "Median value (dollars)"


@pytest.mark.parametrize("problem", ["no metadata", "metadata of another table", "a word"])
def test_a_broken_acs_download_exits_1_in_one_line(
    env: dict[str, str], tmp_path: Path, problem: str
) -> None:
    shapes = three_tracts(tmp_path / "tracts.geojson")
    [data] = downloaded(tmp_path, INCOME)
    metadata = tmp_path / f"{INCOME}-Column-Metadata.csv"
    if problem == "no metadata":
        metadata.unlink()
    elif problem == "metadata of another table":
        metadata.write_bytes((TABLES / f"{VALUE}-Column-Metadata.csv").read_bytes())
    else:
        data.write_text(data.read_text(encoding="utf-8").replace('"52941"', '"about 53k"'))
    args = ("--shapes", str(shapes), "--key", "GEOID", "--table", str(data))
    code, out, err = run(env, "census", "import", *args)
    assert code == 1 and err.startswith("error: ") and err.count("\n") == 1, err
    assert "Traceback" not in out + err and "imported" not in out


def test_an_unknown_kind_of_file_exits_1(env: dict[str, str], tmp_path: Path) -> None:
    shapes = tmp_path / "tracts.kml"
    shapes.write_text("<kml/>")
    code, _, err = run(env, "census", "import", "--shapes", str(shapes), "--key", "GEOID")
    assert code == 1 and "not a kind of file" in err


@pytest.mark.parametrize(
    "answer,said",
    [
        (httpx.Response(200, json={"dataset": 1}), "the map now shows data set 1"),
        (
            httpx.Response(403, json={"detail": "operator token required"}),
            "did not switch the map: 403 operator token required",
        ),
        (httpx.Response(502, text="bad gateway"), "did not switch the map: 502 bad gateway"),
    ],
)
def test_import_asks_a_running_server_to_switch_the_map(
    env: dict[str, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    answer: httpx.Response,
    said: str,
) -> None:
    sent: list[tuple[str, dict[str, Any]]] = []

    def post(url: str, **kwargs: Any) -> httpx.Response:
        sent.append((url, kwargs))
        return answer

    monkeypatch.setattr(httpx, "post", post)
    shapes = three_tracts(tmp_path / "tracts.geojson")
    code, out, _ = run(env, "census", "import", "--shapes", str(shapes), "--key", "GEOID")
    assert code == 0 and out.splitlines()[-1].endswith(said)
    ((url, kwargs),) = sent
    assert url == f"http://127.0.0.1:{env['TAGWALL_PORT']}/api/apps/census/current"
    assert kwargs["json"] == {"dataset": 1}
    assert kwargs["timeout"] == httpx.Timeout(60.0, connect=5.0)
    assert kwargs["headers"] == {"Authorization": f"Bearer {operator_token(TEST_SECRET)}"}


@pytest.mark.parametrize(
    "error,said",
    [
        (
            httpx.ReadTimeout("timed out"),
            "is busy: it took the request but did not answer within 60 s, so it may still be "
            "switching the map; data set 1 is imported and current either way",
        ),
        (httpx.ConnectError("refused"), "is not reachable; the map switches to data set 1"),
        (httpx.ConnectTimeout("timed out"), "is not reachable; the map switches to data set 1"),
    ],
)
def test_a_busy_server_is_told_from_one_that_is_not_there(
    env: dict[str, str],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    error: httpx.HTTPError,
    said: str,
) -> None:
    """Issue 31: a request that timed out on a busy machine read "the server is not
    reachable", though the server had switched the map."""

    def post(url: str, **kwargs: Any) -> httpx.Response:
        raise error

    monkeypatch.setattr(httpx, "post", post)
    shapes = three_tracts(tmp_path / "tracts.geojson")
    code, out, err = run(env, "census", "import", "--shapes", str(shapes), "--key", "GEOID")
    assert code == 0 and said in out.splitlines()[-1], out
    assert "Traceback" not in out + err


def test_earth_prints_what_each_display_opens(env: dict[str, str]) -> None:
    code, out, err = run(
        env, "earth", "--wall", "demo", "--base-url", "http://wall.example:8000/", "--fov", "45"
    )
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].split() == ["display", "Google", "Earth", "Pro", "opens"]
    rows = dict(line.split(maxsplit=1) for line in lines[1:])
    # not the public base URL: the links carry the base with the server's signature
    signed = urlencode(
        {
            "base": "http://wall.example:8000",
            "sig": base_signature(TEST_SECRET, "http://wall.example:8000"),
        }
    )
    # only the options that differ from the defaults
    assert (
        rows["r2c2"] == f"http://wall.example:8000/apps/census/earth/demo/r2c2.kml?fov=45&{signed}"
    )
    assert rows["r1c2"] == "(the public screen: a browser tile, see `tagwall tiles`)"
    assert len(rows) == 6


def test_earth_writes_one_kml_file_per_display(env: dict[str, str], tmp_path: Path) -> None:
    code, out, err = run(env, "earth", "--wall", "demo", "--out", str(tmp_path / "earth"))
    assert code == 0, err
    written = sorted(path.name for path in (tmp_path / "earth").iterdir())
    assert written == ["r1c1.kml", "r2c2.kml", "r2c3.kml"]
    text = (tmp_path / "earth" / "r2c3.kml").read_text()
    assert_valid_kml(text)
    assert f"{env['TAGWALL_PORT']}/apps/census/earth/demo/r2c3/wall.kml</href>" in text
    assert str(tmp_path / "earth" / "r2c3.kml") in out


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--wall", "nope"], "no wall 'nope'"),
        (["--fov", "0"], "--fov"),
        (["--refresh", "0"], "--refresh"),
        (["--base-url", "wall.example"], "--base-url must be an http"),
    ],
)
def test_earth_refuses_bad_options(env: dict[str, str], args: list[str], says: str) -> None:
    code, _, err = run(env, "earth", *args)
    assert code == 2 and says in err
