"""The brain atlas's content files and `tagwall content check`: what an editor is told."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner, Result

from webapp.apps.brain_atlas.content import ATLAS_DIR, check, load_content
from webapp.apps.brain_atlas.matching import answer_key
from webapp.cli.commands import main
from webapp.core.settings import CONTENT_DIR

TEXT = "A text long enough to be a real paragraph about this part of the brain."


def write(directory: Path, name: str, data: object) -> None:
    path = directory / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


@pytest.fixture
def small(tmp_path: Path) -> Path:
    """A small, correct content folder: one quiz region and one K-5 region."""
    shutil.copy(ATLAS_DIR / "atlas-desikankilliany.csv", tmp_path)
    shutil.copy(ATLAS_DIR / "atlas-names.yaml", tmp_path)
    shutil.copy(ATLAS_DIR / "views.yaml", tmp_path)
    for volume in ATLAS_DIR.glob("*.nii.gz"):
        (tmp_path / volume.name).symlink_to(volume)
    write(
        tmp_path,
        "regions.yaml",
        {
            "regions": [
                {
                    "id": "precentral-gyrus",
                    "name": "Precentral gyrus",
                    "synonyms": ["primary motor cortex"],
                    "abbreviations": ["M1"],
                    "hemisphere": "left",
                    "labels": [23],
                    "sets": ["full"],
                },
                {
                    "id": "brainstem",
                    "name": "Brainstem",
                    "hemisphere": "both",
                    "labels": [83],
                    "sets": ["k5"],
                },
            ]
        },
    )
    write(tmp_path, "references.yaml", {"purves": {"citation": "Purves et al., Neuroscience"}})
    group = {"text": TEXT, "references": ["purves"]}
    research = {"text": TEXT, "references": ["purves"], "search": "precentral gyrus"}
    write(
        tmp_path,
        "tutor/precentral-gyrus.yaml",
        {
            "k5": {"text": TEXT},
            "undergraduate": dict(group),
            "medical": dict(group),
            "research": research,
        },
    )
    write(tmp_path, "tutor/brainstem.yaml", {"k5": {"text": TEXT}})
    return tmp_path


def test_every_full_set_region_needs_a_childrens_text_too(small: Path) -> None:
    """Children scan full-set pins as well: "For the K-5 group" must head a text for
    children, never the undergraduate one."""
    path = small / "tutor/precentral-gyrus.yaml"
    data = yaml.safe_load(path.read_text())
    del data["k5"]
    path.write_text(yaml.safe_dump(data))

    assert check(small) == ["tutor/precentral-gyrus.yaml: no text for k5"]


def test_a_correct_folder_loads(small: Path) -> None:
    content = load_content(small)
    assert [r.id for r in content.in_set("full")] == ["precentral-gyrus"]
    assert content.region("brainstem") is not None and check(small) == []


def test_the_shipped_content_is_complete() -> None:
    content = load_content()
    assert len(content.in_set("full")) == 23 and len(content.in_set("k5")) == 11
    assert check() == []
    assert set(content.atlas_names) == {label.label for label in content.labels.values()}


def test_competitors_are_the_atlas_regions_a_set_leaves_out() -> None:
    content = load_content()
    full = content.competitors("full")
    assert "Pars orbitalis" in full and "Cuneus" in full and "Lingual gyrus" in full
    # in the quiz (under a name of their own, or as part of a region): no competitors
    for covered in ("Precentral gyrus", "Pars opercularis", "Rostral anterior cingulate cortex"):
        assert covered not in full
    assert content.competitors("k5") == [
        "Caudal anterior cingulate cortex",
        "Isthmus cingulate cortex",
        "Posterior cingulate cortex",
        "Rostral anterior cingulate cortex",
        "Caudate nucleus",
        "Putamen",
        "Globus pallidus",
        "Nucleus accumbens",
    ]
    parts = content.parts("k5")
    assert parts["movement-strip"] == ["Precentral gyrus"]
    assert "Paracentral lobule" in parts["frontal-lobe"]
    assert content.parts("full")["brocas-area"] == ["Pars opercularis", "Pars triangularis"]


def test_one_answer_key_per_set() -> None:
    """Names are unique within a set only: "hippocampus" is the quiz's hippocampus and
    the K-5 memory seahorse, each in its own set's key."""
    content = load_content()
    full, k5 = answer_key(content, "full"), answer_key(content, "k5")
    assert full.best("hippocampus") == "hippocampus"
    assert k5.best("hippocampus") == "memory-seahorse"
    assert full.best("memory seahorse") is None
    assert full.competitor("pars orbitalis") == "Pars orbitalis"
    assert k5.competitor("pars orbitalis") is None  # part of the K-5 frontal lobe
    assert k5.judge("frontal-lobe", "frontal") and full.best("frontal") is None


def edit_regions(directory: Path, change: dict[str, object], index: int = 0) -> None:
    data = yaml.safe_load((directory / "regions.yaml").read_text())
    data["regions"][index].update(change)
    write(directory, "regions.yaml", data)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"labels": [99]}, "regions.yaml: precentral-gyrus: 99 is not an atlas label"),
        ({"labels": [64]}, "label 64 (precentral) is in hemisphere R, not left"),
        ({"hemisphere": "middle"}, "regions.yaml: regions[precentral-gyrus]: hemisphere"),
        ({"name": ""}, "regions.yaml: regions[precentral-gyrus]: name"),
        ({"sets": ["quiz"]}, "regions.yaml: regions[precentral-gyrus]: sets.0"),
        ({"colour": "red"}, "regions.yaml: regions[precentral-gyrus]: colour"),
        (
            {"synonyms": ["Pars orbitalis"]},
            "regions.yaml: precentral-gyrus: 'Pars orbitalis' is the atlas name of "
            "'parsorbitalis', which no full region includes",
        ),
    ],
)
def test_region_problems_are_named(small: Path, change: dict[str, object], message: str) -> None:
    edit_regions(small, change)
    problems = check(small)
    assert any(message in problem for problem in problems), problems


def add_region(directory: Path, region: dict[str, object], tutor: dict[str, object]) -> None:
    data = yaml.safe_load((directory / "regions.yaml").read_text())
    data["regions"].append(region)
    write(directory, "regions.yaml", data)
    write(directory, f"tutor/{region['id']}.yaml", tutor)


def test_names_need_only_be_unique_within_a_set(small: Path) -> None:
    # the quiz's precentral gyrus and the K-5 brainstem: different sets, no clash
    edit_regions(small, {"synonyms": ["stalk", "Primary Motor Cortex"], "abbreviations": ["m1"]}, 1)
    assert check(small) == []
    # a second K-5 region answering to "brainstem" clashes
    add_region(
        small,
        {
            "id": "trunk",
            "name": "Trunk",
            "synonyms": ["BRAINSTEM"],
            "hemisphere": "both",
            "labels": [40],
            "sets": ["k5"],
        },
        {"k5": {"text": TEXT}},
    )
    assert check(small) == ["regions.yaml: trunk: 'BRAINSTEM' also names brainstem (k5)"]


def test_a_region_in_both_sets_clashes_in_each(small: Path) -> None:
    group = {"text": TEXT, "references": ["purves"]}
    research = {"text": TEXT, "references": ["purves"], "search": "motor"}
    add_region(
        small,
        {
            "id": "motor",
            "name": "Motor strip",
            "abbreviations": ["m1"],
            "hemisphere": "right",
            "labels": [64],
            "sets": ["full", "k5"],
        },
        {"k5": group, "undergraduate": group, "medical": group, "research": research},
    )
    assert check(small) == ["regions.yaml: motor: 'm1' also names precentral-gyrus (full)"]
    edit_regions(small, {"name": "Motor strip"}, index=1)  # the K-5 brainstem
    assert set(check(small)) == {
        "regions.yaml: motor: 'm1' also names precentral-gyrus (full)",
        "regions.yaml: motor: 'Motor strip' also names brainstem (k5)",
    }


def test_a_name_of_an_atlas_region_the_set_leaves_out(small: Path) -> None:
    # "Precentral gyrus" is the atlas name of label 23: fine in the full set, which
    # has it, but not in the K-5 set, which only has the brainstem
    edit_regions(small, {"synonyms": ["stalk", "precentral GYRUS"]}, index=1)
    assert check(small) == [
        "regions.yaml: brainstem: 'precentral GYRUS' is the atlas name of 'precentral', "
        "which no k5 region includes (add the label, or drop the name)"
    ]
    edit_regions(small, {"synonyms": ["Precentral gyrus"]})
    assert check(small) == [
        "regions.yaml: brainstem: 'precentral GYRUS' is the atlas name of 'precentral', "
        "which no k5 region includes (add the label, or drop the name)"
    ]


def test_the_small_folders_answer_keys(small: Path) -> None:
    content = load_content(small)
    assert len(content.competitors("full")) == 41  # every atlas region but one
    key = answer_key(content, "full")
    assert key.judge("precentral-gyrus", "precentral")
    assert key.competitor("postcentral gyrus") == "Postcentral gyrus"
    assert not key.judge("precentral-gyrus", "paracentral")
    k5 = answer_key(content, "k5")
    assert k5.best("primary motor cortex") is None  # the full set's precentral gyrus
    assert k5.competitor("precentral") == "Precentral gyrus"


def edit_atlas_names(directory: Path, change: dict[str, object]) -> None:
    data = yaml.safe_load((directory / "atlas-names.yaml").read_text())
    data.update(change)
    write(directory, "atlas-names.yaml", {k: v for k, v in data.items() if v != "-"})


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"cuneus": "-"}, "atlas-names.yaml: no readable name for the atlas label 'cuneus'"),
        ({"cerebellum": "Cerebellum"}, "atlas-names.yaml: cerebellum: not a label of the atlas"),
        ({"cuneus": ""}, "atlas-names.yaml: cuneus: expected a name of 1 to 100 characters"),
        ({"cuneus": ["Cuneus"]}, "atlas-names.yaml: cuneus: expected a name of 1 to 100"),
        ({"cuneus": "x" * 101}, "atlas-names.yaml: cuneus: expected a name of 1 to 100"),
        ({"lingual": "CUNEUS"}, "atlas-names.yaml: lingual: 'CUNEUS' also names cuneus"),
    ],
)
def test_atlas_name_problems_are_named(
    small: Path, change: dict[str, object], message: str
) -> None:
    edit_atlas_names(small, change)
    problems = check(small)
    assert any(message in problem for problem in problems), problems


def test_atlas_names_file_missing_or_not_a_mapping(small: Path) -> None:
    (small / "atlas-names.yaml").unlink()
    assert check(small) == ["atlas-names.yaml: missing"]
    (small / "atlas-names.yaml").write_text("- cuneus\n- lingual\n")
    assert check(small) == ["atlas-names.yaml: expected a mapping of atlas label -> readable name"]
    (small / "atlas-names.yaml").write_text("# nothing yet\n")
    assert check(small) == ["atlas-names.yaml: empty"]


def test_a_missing_text_and_an_unknown_region(small: Path) -> None:
    (small / "tutor" / "precentral-gyrus.yaml").unlink()
    write(small, "tutor/cerebellum.yaml", {"k5": {"text": TEXT}})
    assert set(check(small)) >= {
        "tutor/precentral-gyrus.yaml: missing",
        "tutor/cerebellum.yaml: no region 'cerebellum' in regions.yaml",
    }


def test_a_group_without_its_text(small: Path) -> None:
    write(small, "tutor/brainstem.yaml", {"medical": {"text": TEXT}})
    assert "tutor/brainstem.yaml: no text for k5" in check(small)


def test_a_broken_reference(small: Path) -> None:
    data = yaml.safe_load((small / "tutor" / "precentral-gyrus.yaml").read_text())
    data["medical"]["references"] = ["kandel"]
    write(small, "tutor/precentral-gyrus.yaml", data)
    assert check(small) == [
        "tutor/precentral-gyrus.yaml: medical cites 'kandel', which references.yaml does not list"
    ]


def test_yaml_that_does_not_parse(small: Path) -> None:
    (small / "regions.yaml").write_text("regions: [unclosed")
    [problem] = [p for p in check(small) if p.startswith("regions.yaml")]
    assert problem.startswith("regions.yaml: not valid YAML")


def test_missing_files(tmp_path: Path) -> None:
    problems = check(tmp_path)
    assert "regions.yaml: missing" in problems and "references.yaml: missing" in problems


def content_root(small: Path) -> Path:
    """A content folder holding ``small`` as its atlas (and the shipped walls)."""
    root = small.with_name(f"{small.name}-content")
    root.mkdir(exist_ok=True)
    if not (root / "brain_atlas").exists():
        (root / "brain_atlas").symlink_to(small)
    return root


def check_content(small: Path, **env: str) -> Result:
    return CliRunner().invoke(
        main, ["content", "check", "--dir", str(content_root(small))], env=env
    )


def test_the_command_prints_a_summary_or_the_problems(small: Path) -> None:
    good = check_content(small)
    assert good.exit_code == 0, good.output
    assert (
        f"{content_root(small) / 'brain_atlas'}: 1 quiz regions, 1 K-5 regions, 2 tutor files,"
        " 1 references, 5 views showing every pin"
    ) in good.output
    edit_regions(small, {"labels": [99]})
    bad = check_content(small)
    assert bad.exit_code == 2
    assert "99 is not an atlas label" in bad.output and "1 problem(s) found" in bad.output


def test_the_command_names_regions_no_view_shows(small: Path) -> None:
    (small / "views.yaml").write_text(
        "views:\n"
        "  - id: top\n"
        "    name: From above\n"
        "    view: {yaw: 0, pitch: 90}\n"
        "    layer: {mode: slice, slice: 0.6}\n"
    )
    result = check_content(small)
    assert result.exit_code == 2
    assert "views.yaml: no view shows the pin of brainstem" in result.output


def test_the_command_explains_a_broken_views_file(small: Path) -> None:
    (small / "views.yaml").write_text("views:\n  - id: x\n    name: X\n    colour: red\n")
    result = check_content(small)
    assert result.exit_code == 2 and "views.yaml" in result.output


def test_the_command_checks_the_content_folder_in_use(
    small: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Issue 30: without ``--dir`` it checks the folder the server reads
    (``TAGWALL_CONTENT_DIR``), and a broken file is one line, not three."""
    root = tmp_path_factory.mktemp("our-content")
    shutil.copytree(small, root / "brain_atlas", symlinks=True)
    (root / "brain_atlas" / "tutor" / "brainstem.yaml").write_text("k5: [unclosed\n")

    result = CliRunner().invoke(main, ["content", "check"], env={"TAGWALL_CONTENT_DIR": str(root)})

    assert result.exit_code == 2
    lines = result.output.splitlines()
    assert lines[0] == f"checking {root}"
    assert lines[-1] == "1 problem(s) found"
    [problem] = [line for line in lines if line.startswith("  ")]
    assert problem.startswith("  tutor/brainstem.yaml: not valid YAML")


def test_the_command_checks_the_content_folders_walls_too(
    small: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Issue 41: it read only the brain's content; a broken wall config of the content
    folder stopped the server later, at its start."""
    root = content_root(small)
    (root / "walls").mkdir()
    shutil.copy(CONTENT_DIR / "walls" / "demo.toml", root / "walls")
    (root / "walls" / "broken.toml").write_text('id = "broken"\n[grid]\ncolumns = "three"\n')
    result = CliRunner().invoke(main, ["content", "check", "--dir", str(root)])
    assert result.exit_code == 2
    assert f"{root / 'walls'}: problems" in result.output
    assert f"  {root / 'walls' / 'broken.toml'}: grid.columns: must be an integer" in result.output
    assert result.output.endswith("5 problem(s) found\n")
    (root / "walls" / "broken.toml").unlink()
    good = CliRunner().invoke(main, ["content", "check", "--dir", str(root)])
    assert good.exit_code == 0 and f"{root / 'walls'}: 1 walls: demo" in good.output


def test_a_content_folder_that_is_not_there_stops_the_command_with_one_line(
    tmp_path: Path,
) -> None:
    missing = tmp_path / "nowhere"
    result = CliRunner().invoke(
        main, ["content", "check"], env={"TAGWALL_CONTENT_DIR": str(missing)}
    )
    assert result.exit_code == 2
    assert result.output.splitlines() == [
        f"error: TAGWALL_CONTENT_DIR: {missing} is not a folder; copy the shipped "
        f"{CONTENT_DIR} there, or leave the setting out to use it"
    ]
