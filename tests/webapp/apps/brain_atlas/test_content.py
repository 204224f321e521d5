"""The brain atlas's content files and `tagwall content check`: what an editor is told."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from webapp.apps.brain_atlas.content import ATLAS_DIR, check, load_content
from webapp.cli import main

TEXT = "A text long enough to be a real paragraph about this part of the brain."


def write(directory: Path, name: str, data: object) -> None:
    path = directory / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


@pytest.fixture
def small(tmp_path: Path) -> Path:
    """A small, correct content folder: one quiz region and one K-5 region."""
    shutil.copy(ATLAS_DIR / "atlas-desikankilliany.csv", tmp_path)
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
        {"undergraduate": dict(group), "medical": dict(group), "research": research},
    )
    write(tmp_path, "tutor/brainstem.yaml", {"k5": {"text": TEXT}})
    return tmp_path


def test_a_correct_folder_loads(small: Path) -> None:
    content = load_content(small)
    assert [r.id for r in content.in_set("full")] == ["precentral-gyrus"]
    assert content.region("brainstem") is not None and check(small) == []


def test_the_shipped_content_is_complete() -> None:
    content = load_content()
    assert len(content.in_set("full")) == 23 and len(content.in_set("k5")) == 11
    assert check() == []


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
        ({"synonyms": ["Brainstem"]}, "'Brainstem' also names precentral-gyrus"),
    ],
)
def test_region_problems_are_named(small: Path, change: dict[str, object], message: str) -> None:
    edit_regions(small, change)
    problems = check(small)
    assert any(message in problem for problem in problems), problems


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


def test_the_command_prints_a_summary_or_the_problems(small: Path) -> None:
    runner = CliRunner()
    good = runner.invoke(main, ["content", "check", "--dir", str(small)])
    assert good.exit_code == 0, good.output
    assert "ok: 1 quiz regions, 1 K-5 regions, 2 tutor files, 1 references" in good.output
    edit_regions(small, {"labels": [99]})
    bad = runner.invoke(main, ["content", "check", "--dir", str(small)])
    assert bad.exit_code == 2
    assert "99 is not an atlas label" in bad.output and "1 problem(s) found" in bad.output
