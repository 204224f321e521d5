"""Wall configs: the pydantic models refuse bad TOML with one clear line per problem.

Each line is ``FILE: field.path: message``; these tests pin the words an operator reads.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.wall_client.walls import explicit_config, grid_config, panel
from wall_client.config import (
    ScreensConfig,
    WallConfigError,
    config_keys,
    load_wall,
    load_walls,
    parse_wall,
)
from wall_client.layout import ROLES


def write(tmp_path: Path, text: str, name: str = "wall.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def errors_of(data: dict[str, Any]) -> list[str]:
    with pytest.raises(WallConfigError) as caught:
        parse_wall(data, "walls/x.toml")
    return caught.value.errors


def test_the_old_distance_key_says_what_it_became() -> None:
    errors = errors_of({**grid_config(), "scan_distance_m": 2})
    assert errors == [
        "walls/x.toml: scan_distance_m: renamed: use seat_distance_m"
        " (walk-up codes have walk_up_distance_m)"
    ]
    assert errors_of({**grid_config(), "walk_up_distance_m": 0})[0].endswith("must be positive")


def test_a_wall_keeps_its_time_zone_and_refuses_one_that_does_not_exist() -> None:
    assert parse_wall(grid_config(), "walls/x.toml").time_zone == "UTC"
    berlin = parse_wall({**grid_config(), "time_zone": "Europe/Berlin"}, "walls/x.toml")
    assert berlin.time_zone == "Europe/Berlin"
    for wrong in ("Mars/Olympus", "../../etc/passwd", "", 7):
        [error] = errors_of({**grid_config(), "time_zone": wrong})
        assert error.startswith("walls/x.toml: time_zone: "), error


def test_overlapping_displays() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0), panel("b", 100, 50)))
    assert any(
        e.startswith("walls/x.toml: display[1]: display 'b' overlaps display 'a'") for e in errors
    )
    parse_wall(explicit_config(panel("a", 0, 0), panel("b", 160, 0)))  # touching is fine


def test_non_positive_sizes() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0), panel("b", 200, 0, width_mm=0)))
    assert "walls/x.toml: display[1].width_mm: must be at least 1 mm" in errors
    errors = errors_of(grid_config(columns=0, active_mm=[-1, 90]))
    assert "walls/x.toml: grid.columns: must be positive" in errors
    assert "walls/x.toml: grid.active_mm[0]: must be at least 1 mm" in errors
    errors = errors_of(grid_config(bezel_mm=-1))
    assert "walls/x.toml: grid.bezel_mm: must not be negative" in errors


def test_unknown_role() -> None:
    errors = errors_of({**grid_config(), "screens": {"lobby": "r1c1"}})
    assert any(e.startswith("walls/x.toml: screens.lobby: unknown role") for e in errors)


def test_duplicate_display_ids() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0), panel("a", 200, 0)))
    assert "walls/x.toml: display[1].id: duplicate display id 'a' (also display[0])" in errors


def test_screen_naming_an_unknown_display() -> None:
    """Display ids are checked once every value is valid: two configs, not one."""
    errors = errors_of({**grid_config(), "screens": {"public": "r9c9", "menu": ["r1c1"]}})
    assert errors == ["walls/x.toml: screens.public: unknown display 'r9c9'"]
    errors = errors_of({**grid_config(), "screens": {"public": "r1c1", "menu": ["r1c1", 3]}})
    assert errors == ["walls/x.toml: screens.menu: must be a display id or a list of display ids"]


def test_the_stage_names_known_displays() -> None:
    assert errors_of({**grid_config(), "screens": {"stage": ["r9c9"]}}) == [
        "walls/x.toml: screens.stage: unknown display 'r9c9'"
    ]
    assert errors_of({**grid_config(), "screens": {"stage": []}})[0].endswith(
        "give at least one display (leave it out for the default)"
    )
    assert errors_of({**grid_config(), "screens": {"stage": ["r1c1", "r1c1"]}}) == [
        "walls/x.toml: screens.stage: lists a display more than once"
    ]


def test_display_outside_the_wall() -> None:
    errors = errors_of(
        explicit_config(panel("a", 0, 0), panel("b", 200, 0), wall={"width_mm": 300})
    )
    assert any(e.startswith("walls/x.toml: display[1]: display outside the wall") for e in errors)
    errors = errors_of(explicit_config(panel("a", -5, 0)))
    assert any(e.startswith("walls/x.toml: display[0]: display outside the wall") for e in errors)
    errors = errors_of({**grid_config(), "wall": {"width_mm": 3000}})
    assert any(
        e.startswith("walls/x.toml: wall.width_mm: display outside the wall: r1c3") for e in errors
    )


def test_bad_rotation() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0, rotation=45)))
    assert "walls/x.toml: display[0].rotation: must be one of 0, 90, 180, 270 (got 45)" in errors
    errors = errors_of(grid_config(rotation="90"))
    assert any(e.startswith("walls/x.toml: grid.rotation: must be one of") for e in errors)


def test_both_or_neither_form() -> None:
    both = {**grid_config(), "display": [panel("a", 0, 0)]}
    assert any(e.startswith("walls/x.toml: grid: ") and "not both" in e for e in errors_of(both))
    assert any(e.startswith("walls/x.toml: grid: missing") for e in errors_of({"id": "x"}))


def test_unknown_keys_anywhere() -> None:
    config = grid_config(
        colums=3, bezel_mm={"left": 1, "right": 1, "top": 1, "bottom": 1, "middle": 2}
    )
    config.update(colour="red", wall={"depth_mm": 3})
    errors = errors_of(config)
    for field in ("colour", "grid.colums", "grid.bezel_mm.middle", "wall.depth_mm"):
        assert any(e.startswith(f"walls/x.toml: {field}: unknown key") for e in errors), field
    errors = errors_of(explicit_config(panel("a", 0, 0, rotate=90)))
    assert any(e.startswith("walls/x.toml: display[0].rotate: unknown key") for e in errors)


def test_aspect_mismatch() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0, height_mm=120)))
    assert any(
        e.startswith("walls/x.toml: display[0].resolution: ") and "pixels would not be square" in e
        for e in errors
    )
    # Turned 90 degrees but sizes not swapped.
    errors = errors_of(explicit_config(panel("a", 0, 0, rotation=90)))
    assert any("display[0].resolution" in e and "not be square" in e for e in errors)
    errors = errors_of(grid_config(active_mm=[1000, 1000]))
    assert any(e.startswith("walls/x.toml: grid.active_mm: ") for e in errors)
    parse_wall(explicit_config(panel("a", 0, 0, height_mm=92)))  # within 3%


def test_bad_wall_id_and_missing_fields_are_all_reported() -> None:
    config = explicit_config({"id": "a b", "x_mm": 0, "resolution": [1920.5, 1080]})
    config["id"] = "Bad Id"
    errors = errors_of(config)
    assert any(e.startswith("walls/x.toml: id: 'Bad Id' must use only") for e in errors)
    for field in (
        "display[0].id",
        "display[0].y_mm",
        "display[0].width_mm",
        "display[0].height_mm",
        "display[0].resolution",
    ):
        assert any(e.startswith(f"walls/x.toml: {field}: ") for e in errors), field


def test_duplicate_node_index() -> None:
    errors = errors_of(explicit_config(panel("a", 0, 0, index=0), panel("b", 200, 0, index=0)))
    assert any(e.startswith("walls/x.toml: display[1].index: index 0 on node") for e in errors)


def test_parse_without_source_says_string() -> None:
    with pytest.raises(WallConfigError) as caught:
        parse_wall({"id": "x", "grid": {}})
    assert all(e.startswith("<string>: ") for e in caught.value.errors)
    assert str(caught.value) == "\n".join(caught.value.errors)
    assert isinstance(caught.value, ValueError)


def test_toml_syntax_error(tmp_path: Path) -> None:
    path = write(tmp_path, "this is = = not toml")
    with pytest.raises(WallConfigError) as caught:
        load_wall(path)
    assert caught.value.errors[0].startswith(f"{path}: TOML syntax error")


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(WallConfigError, match=re.escape(f"{tmp_path / 'absent.toml'}: ")):
        load_wall(tmp_path / "absent.toml")
    with pytest.raises(WallConfigError, match=r"absent\.toml"):
        load_walls([tmp_path / "absent.toml"])


def test_load_wall_reports_file_and_field(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        'id = "x"\n[[display]]\nid = "a"\nx_mm = 0\ny_mm = 0\nwidth_mm = -1\n'
        "height_mm = 90\nresolution = [1920, 1080]\n",
    )
    with pytest.raises(WallConfigError) as caught:
        load_wall(path)
    assert f"{path}: display[0].width_mm: must be at least 1 mm" in caught.value.errors


DEMO_TEXT = """
id = "{wall_id}"
[grid]
columns = 2
rows = 1
resolution = [1920, 1080]
active_mm = [160, 90]
bezel_mm = 0
"""


def test_duplicate_wall_ids_across_files(tmp_path: Path) -> None:
    first = write(tmp_path, DEMO_TEXT.format(wall_id="same"), "a.toml")
    second = write(tmp_path, DEMO_TEXT.format(wall_id="same"), "b.toml")
    with pytest.raises(WallConfigError) as caught:
        load_walls([tmp_path])
    (message,) = caught.value.errors
    assert message.startswith(f"{second}: id: duplicate wall id 'same'")
    assert str(first) in message


def test_load_walls_mixes_files_and_folders_and_reports_every_file(tmp_path: Path) -> None:
    folder = tmp_path / "walls"
    folder.mkdir()
    write(folder, DEMO_TEXT.format(wall_id="one"), "1.toml")
    write(folder, "not a wall", "notes.txt")
    single = write(tmp_path, DEMO_TEXT.format(wall_id="two"), "two.toml")
    assert list(load_walls([folder, single])) == ["one", "two"]
    bad = write(folder, "id = 3", "2.toml")
    broken = write(tmp_path, "= =", "broken.toml")
    with pytest.raises(WallConfigError) as caught:
        load_walls([folder, broken])
    assert any(e.startswith(f"{bad}: id: ") for e in caught.value.errors)
    assert any(e.startswith(f"{broken}: TOML syntax error") for e in caught.value.errors)


# --- the models ----------------------------------------------------------------------


def tables() -> dict[str, dict[str, Any]]:
    """A valid config holding each kind of table, by the path prefix of its keys."""
    sides = {"left": 1, "right": 1, "top": 1, "bottom": 1}
    return {
        "": grid_config(),
        "wall.": {**grid_config(), "wall": {}},
        "screens.": {**grid_config(), "screens": {}},
        "grid.": grid_config(),
        "grid.bezel_mm.": grid_config(bezel_mm=sides),
        "display[0].": explicit_config(panel("a", 0, 0)),
    }


@pytest.mark.parametrize("prefix", list(tables()))
def test_every_table_refuses_unknown_keys_naming_the_path_and_the_keys_it_takes(
    prefix: str,
) -> None:
    config = tables()[prefix]
    table: Any = config
    for part in re.findall(r"\w+|\[\d+\]", prefix):
        table = table[int(part[1:-1])] if part.startswith("[") else table[part]
    table["colour"] = "red"
    (error,) = errors_of(config)
    assert error.startswith(f"walls/x.toml: {prefix}colour: unknown ")
    expected = re.search(r"\(expected one of: (.*)\)$", error)
    assert expected, error
    base = re.sub(r"\[\d+\]", "", prefix)
    below = {key.removeprefix(base) for key in config_keys() if key.startswith(base)}
    assert set(expected.group(1).split(", ")) == {key for key in below if "." not in key}


def test_unknown_display_keys_list_what_a_display_takes() -> None:
    assert errors_of(explicit_config(panel("a", 0, 0), panel("b", 200, 0, rotate=90))) == [
        "walls/x.toml: display[1].rotate: unknown key (expected one of: id, x_mm, y_mm,"
        " width_mm, height_mm, resolution, rotation, node, index, desktop_origin)"
    ]


def test_wrong_types_say_what_is_expected() -> None:
    config = grid_config(
        columns="3",
        rows=2.5,
        resolution=[1920, "1080"],
        active_mm=[True, 90],
        bezel_mm="3",
        gap_mm=[1],
        rotation=True,
    )
    config.update(name="", bezel_mode="flat", wall=[4000])
    assert errors_of(config) == [
        "walls/x.toml: name: must be a non-empty string",
        "walls/x.toml: bezel_mode: must be one of 'overlay', 'offset' (got 'flat')",
        "walls/x.toml: wall: must be a table",
        "walls/x.toml: grid.columns: must be an integer",
        "walls/x.toml: grid.rows: must be an integer",
        "walls/x.toml: grid.resolution: must be a pair of integers, like [1920, 1080]",
        "walls/x.toml: grid.active_mm[0]: must be a number",
        "walls/x.toml: grid.bezel_mm: must be a number",
        "walls/x.toml: grid.gap_mm: must be a pair of numbers, like [1209.6, 680.4]",
        "walls/x.toml: grid.rotation: must be one of 0, 90, 180, 270 (got True)",
    ]
    assert errors_of({"id": "x", "display": {"id": "a"}}) == [
        "walls/x.toml: display: must be an array of tables, written as [[display]] sections"
    ]
    assert errors_of({"id": "x", "display": [3]}) == ["walls/x.toml: display[0]: must be a table"]


def test_out_of_range_values_name_the_range() -> None:
    config = explicit_config(
        panel("a", 0, 0, index=-1, desktop_origin=[-1920, 0]),  # origins may be negative
        panel("b", float("inf"), 0, resolution=[1920, 0]),
        panel("c", 2e6, 0, width_mm=5e-324),  # far off and too small to divide by
        seat_distance_m=-2,
    )
    assert errors_of(config) == [
        "walls/x.toml: seat_distance_m: must be positive",
        "walls/x.toml: display[0].index: must not be negative",
        "walls/x.toml: display[1].x_mm: must be a finite number",
        "walls/x.toml: display[1].resolution[1]: must be positive",
        "walls/x.toml: display[2].x_mm: must be at most 1000000 mm",
        "walls/x.toml: display[2].width_mm: must be at least 1 mm",
    ]
    assert errors_of(grid_config(columns=10**9, displays_per_node=0, gap_mm=[-1, 2])) == [
        "walls/x.toml: grid.columns: must be at most 100",  # not a billion displays built
        "walls/x.toml: grid.gap_mm[0]: must not be negative",
        "walls/x.toml: grid.displays_per_node: must be positive",
    ]
    assert errors_of({"id": "x", "display": []}) == [
        "walls/x.toml: display: at least one [[display]] is required"
    ]


def test_missing_required_fields_are_each_named() -> None:
    grid = grid_config()["grid"]
    del grid["bezel_mm"], grid["rows"]
    assert errors_of({"grid": grid}) == [
        "walls/x.toml: id: required",
        "walls/x.toml: grid.rows: required",
        "walls/x.toml: grid.bezel_mm: required (0 for bezel-less panels)",
    ]
    sides = grid_config(bezel_mm={"left": 1, "right": 1, "top": 1})
    assert errors_of(sides) == ["walls/x.toml: grid.bezel_mm.bottom: required"]


def test_rules_between_keys_are_reported_together() -> None:
    config = explicit_config(
        panel("a", 0, 0),
        panel("a", 100, 50, index=0),
        panel("c", 500, 0),
        wall={"width_mm": 600},
        screens={"public": "zz"},
    )
    assert errors_of(config) == [
        "walls/x.toml: display[1].id: duplicate display id 'a' (also display[0])",
        "walls/x.toml: display[1].index: index 0 on node 'node1' is already used by display[0]",
        "walls/x.toml: display[2]: display outside the wall: 500..660 x 0..90 mm"
        " is not within wall.width_mm x wall.height_mm 600 x 140 mm",
        "walls/x.toml: display[1]: display 'a' overlaps display 'a' (display[0]) by 60 x 40 mm",
        "walls/x.toml: screens.public: unknown display 'zz'",
    ]


def test_odd_keys_are_quoted_as_in_toml() -> None:
    assert errors_of({**grid_config(), "screens": {"big screen": "r1c1"}}) == [
        'walls/x.toml: screens."big screen": unknown role'
        " (expected one of: public, menu, registration, stage)"
    ]


def test_toml_syntax_errors_say_where(tmp_path: Path) -> None:
    path = write(tmp_path, 'id = "x"\n[grid]\ncolumns = 3\nrows = \n')
    with pytest.raises(WallConfigError) as caught:
        load_wall(path)
    (error,) = caught.value.errors
    assert error.startswith(f"{path}: TOML syntax error: ") and "line 4" in error
    with pytest.raises(WallConfigError, match="is a directory"):
        load_wall(tmp_path)


def test_screen_roles_are_the_walls_roles_and_the_stage() -> None:
    assert tuple(ScreensConfig.model_fields) == (*ROLES, "stage")


def test_accepted_keys_really_are_accepted() -> None:
    """Every documented key in one grid wall and one explicit wall."""
    config = grid_config(
        bezel_mm=dict.fromkeys(("left", "right", "top", "bottom"), 1),
        gap_mm=0,
        displays_per_node=2,
        node_prefix="n",
        rotation=0,
    )
    config.update(
        name="n",
        bezel_mode="offset",
        seat_distance_m=1,
        walk_up_distance_m=0.5,
        time_zone="Europe/Berlin",
        wall={"width_mm": 4000, "height_mm": 2000},
        screens={**dict.fromkeys(ROLES, "r1c1"), "stage": ["r2c1"]},
    )
    explicit = explicit_config(
        panel("a", 0, 0, rotation=0, node="n", index=0, desktop_origin=[0, 0])
    )
    used = {
        *config,
        *(f"grid.{k}" for k in config["grid"]),
        *(f"grid.bezel_mm.{k}" for k in config["grid"]["bezel_mm"]),
        *(f"wall.{k}" for k in config["wall"]),
        *(f"screens.{k}" for k in config["screens"]),
        "display",
        *(f"display.{k}" for k in explicit["display"][0]),
    }
    assert used == set(config_keys())
    parse_wall(config)
    parse_wall(explicit)


# A field path in messages: dotted keys (quoted when not bare), array indices.
KEY = r'(?:[A-Za-z0-9_-]+|"(?:[^"\\]|\\.)*")(?:\[\d+\])*'
PATH = rf"{KEY}(?:\.{KEY})*"

# Values a TOML document can hold, to throw at every key.
toml_values = st.recursive(
    st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.floats() | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner),
    max_leaves=6,
)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(config_keys()), toml_values)
def test_any_value_anywhere_gives_our_words_not_pydantics(key: str, value: Any) -> None:
    explicit = key.startswith("display.")
    config = explicit_config(panel("a", 0, 0)) if explicit else grid_config()
    *parents, last = key.replace("display.", "display.0.").split(".")
    table: Any = config
    for part in parents:
        table = table[int(part)] if part.isdigit() else table.setdefault(part, {})
    if not isinstance(table, dict):
        return  # grid.bezel_mm given as one number: no sides below it
    table[last] = value
    try:
        parse_wall(config, "walls/x.toml")
    except WallConfigError as error:
        for line in error.errors:
            assert re.fullmatch(rf"walls/x\.toml: {PATH}: .+", line), line
            assert "Input should" not in line and "pydantic" not in line, line
