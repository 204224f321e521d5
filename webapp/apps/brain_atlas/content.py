"""The brain atlas's content: regions (names people may answer with, the atlas labels
that make them up) and tutor texts per user group, in files an instructor edits.

The app reads them from ``brain_atlas/`` of the content folder (``TAGWALL_CONTENT_DIR``,
:func:`atlas_folder`). ``regions.yaml`` lists the regions; ``tutor/<region id>.yaml``
holds each region's texts; ``references.yaml`` the works they cite;
``atlas-names.yaml`` a readable name for every atlas label (the names of the regions a
set leaves out are wrong answers in that set's quiz). :func:`check` says what is wrong
with them in words an editor can act on.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Literal, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from webapp.core.settings import CONTENT_DIR, Settings

FOLDER_NAME = "brain_atlas"
"""The app's subfolder of the content folder."""
ATLAS_DIR = CONTENT_DIR / FOLDER_NAME
"""The shipped content (the default of the functions that read a folder, for tests and
benchmarks); the server reads the folder of its settings, :func:`atlas_folder`."""
REGION_ID = r"^[a-z0-9]+(-[a-z0-9]+)*$"
TagSetName = Literal["full", "k5"]
M = TypeVar("M", bound=BaseModel)
Hemisphere = Literal["left", "right", "both"]


class Region(BaseModel):
    """A region with a pin on the wall: one atlas label, or a union of them."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(pattern=REGION_ID, max_length=64)
    name: str = Field(min_length=1, max_length=100)  # the correct answer, as shown
    synonyms: list[str] = Field(default_factory=list, max_length=20)
    abbreviations: list[str] = Field(default_factory=list, max_length=10)
    hemisphere: Hemisphere
    labels: list[int] = Field(min_length=1)  # Desikan-Killiany ids (atlas-desikankilliany.csv)
    sets: list[TagSetName] = Field(min_length=1)  # which tag sets show its pin


class Reference(BaseModel):
    model_config = ConfigDict(extra="forbid")

    citation: str = Field(min_length=10, max_length=500)
    url: str | None = Field(default=None, pattern=r"^https://")


class GroupText(BaseModel):
    model_config = ConfigDict(extra="forbid")

    text: str = Field(min_length=40, max_length=6_000)  # Markdown
    references: list[str] = Field(default_factory=list, max_length=20)


class ResearchText(BaseModel):
    """The research group's page: a short orientation and a curated reading list, shown
    (labelled offline) when the live literature search cannot be reached."""

    model_config = ConfigDict(extra="forbid")

    text: str = Field(min_length=40, max_length=6_000)
    references: list[str] = Field(min_length=1, max_length=20)
    search: str = Field(min_length=3, max_length=300)  # the PubMed query for the region


class Tutor(BaseModel):
    """One region's texts: ``k5`` for every region (children), the others for the
    full set's regions."""

    model_config = ConfigDict(extra="forbid")

    k5: GroupText | None = None
    undergraduate: GroupText | None = None
    medical: GroupText | None = None
    research: ResearchText | None = None


class AtlasLabel(BaseModel):
    id: int
    label: str
    hemisphere: Literal["L", "R", "B"]
    structure: str


SIDES: dict[Hemisphere, set[str]] = {"left": {"L"}, "right": {"R"}, "both": {"L", "R", "B"}}
GROUPS_OF_SET: dict[TagSetName, tuple[str, ...]] = {
    "k5": ("k5",),
    # Children scan full-set pins too (the instructor chooses the wall's pins): every
    # region has a children's text, so "For the K-5 group" never heads a university one.
    "full": ("k5", "undergraduate", "medical", "research"),
}


class ContentError(Exception):
    """The content has problems; ``problems`` lists each in words an editor can act on."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


class AtlasContent(BaseModel):
    """Everything the app reads from ``content/brain_atlas``, checked."""

    regions: list[Region]
    tutors: dict[str, Tutor]
    references: dict[str, Reference]
    labels: dict[int, AtlasLabel]
    atlas_names: dict[str, str] = Field(default_factory=dict)  # label -> readable name

    def region(self, region_id: str) -> Region | None:
        return next((r for r in self.regions if r.id == region_id), None)

    def in_set(self, tag_set: TagSetName) -> list[Region]:
        return [r for r in self.regions if tag_set in r.sets]

    def competitors(self, tag_set: TagSetName) -> list[str]:
        """The readable names of the atlas regions the set leaves out: no region of the
        set includes any of their label ids (either hemisphere), so in that set's quiz
        they are always wrong answers ("pars orbitalis", "cuneus"). In atlas order."""
        covered = {
            self.labels[label_id].label
            for region in self.in_set(tag_set)
            for label_id in region.labels
            if label_id in self.labels
        }
        names: dict[str, str] = {}
        for label in self.labels.values():
            name = self.atlas_names.get(label.label)
            if name is not None and label.label not in covered:
                names.setdefault(label.label, name)
        return list(names.values())

    def parts(self, tag_set: TagSetName) -> dict[str, list[str]]:
        """The readable names of the atlas regions each region of the set is made of
        (region id -> names, in label order): the K-5 frontal lobe's "Frontal pole"."""
        parts: dict[str, list[str]] = {}
        for region in self.in_set(tag_set):
            names = parts.setdefault(region.id, [])
            for label_id in region.labels:
                label = self.labels.get(label_id)
                name = self.atlas_names.get(label.label) if label is not None else None
                if name is not None and name not in names:
                    names.append(name)
        return parts


def atlas_folder(settings: Settings) -> Path:
    """Where the brain atlas reads its content: ``brain_atlas/`` of the content folder,
    or the shipped one when that folder has none."""
    return settings.content_folder(FOLDER_NAME)


def load_content(directory: Path = ATLAS_DIR) -> AtlasContent:
    """The content of ``directory``; ContentError listing every problem found."""
    problems: list[str] = []
    labels = _read_labels(directory / "atlas-desikankilliany.csv", problems)
    atlas_names = _read_atlas_names(directory / "atlas-names.yaml", labels, problems)
    regions = _read_list(directory / "regions.yaml", "regions", Region, problems)
    references = _read_mapping(directory / "references.yaml", Reference, problems)
    tutors: dict[str, Tutor] = {}
    unreadable: set[str] = set()  # their problems are said; "missing" would be wrong
    tutor_dir = directory / "tutor"
    for path in sorted(tutor_dir.glob("*.yaml")) if tutor_dir.is_dir() else []:
        tutor = _read_model(path, Tutor, problems)
        if tutor is not None:
            tutors[path.stem] = tutor
        else:
            unreadable.add(path.stem)
    content = AtlasContent(
        regions=regions,
        tutors=tutors,
        references=references,
        labels=labels,
        atlas_names=atlas_names,
    )
    problems += _cross_check(content, unreadable)
    if problems:
        raise ContentError(problems)
    return content


def check(directory: Path = ATLAS_DIR) -> list[str]:
    """What is wrong with the content (nothing: an empty list)."""
    try:
        load_content(directory)
    except ContentError as error:
        return error.problems
    return []


def _read_yaml(path: Path, problems: list[str], label: str = "") -> object:
    """The file's data; None (with its problem) when it is missing or no YAML, or
    when it is empty. ``label``: how problems name it (default: its name)."""
    label = label or path.name
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        problems.append(f"{label}: missing")
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        problems.append(f"{label}: not valid YAML: {error}".replace("\n", " "))
    return None


def _where(error: dict[str, object]) -> str:
    return ".".join(str(part) for part in error["loc"])  # type: ignore[attr-defined]


def _explain(label: str, error: ValidationError) -> list[str]:
    return [f"{label}: {_where(dict(e))}: {e['msg']}" for e in error.errors()]


def _read_model(path: Path, model: type[M], problems: list[str]) -> M | None:
    """A tutor file, its problems named ``tutor/<name>`` (one line for a broken file)."""
    label = f"tutor/{path.name}"
    said = len(problems)
    data = _read_yaml(path, problems, label)
    if data is None:
        if len(problems) == said:
            problems.append(f"{label}: empty")
        return None
    try:
        return model.model_validate(data)
    except ValidationError as error:
        problems += _explain(label, error)
        return None


def _read_list(path: Path, key: str, model: type[M], problems: list[str]) -> list[M]:
    data = _read_yaml(path, problems)
    if data is None:
        return []
    if not isinstance(data, dict) or not isinstance(data.get(key), list):
        problems.append(f"{path.name}: expected a list under `{key}:`")
        return []
    items = []
    for index, item in enumerate(data[key]):
        try:
            items.append(model.model_validate(item))
        except ValidationError as error:
            name = item.get("id", index) if isinstance(item, dict) else index
            problems += _explain(f"{path.name}: {key}[{name}]", error)
    return items


def _read_mapping(path: Path, model: type[M], problems: list[str]) -> dict[str, M]:
    data = _read_yaml(path, problems)
    if data is None:
        return {}
    if not isinstance(data, dict):
        problems.append(f"{path.name}: expected a mapping of id -> entry")
        return {}
    items = {}
    for key, value in data.items():
        try:
            items[str(key)] = model.model_validate(value)
        except ValidationError as error:
            problems += _explain(f"{path.name}: {key}", error)
    return items


def _read_labels(path: Path, problems: list[str]) -> dict[int, AtlasLabel]:
    try:
        with path.open(newline="", encoding="utf-8") as table:
            return {int(row["id"]): AtlasLabel.model_validate(row) for row in csv.DictReader(table)}
    except (OSError, KeyError, ValueError, ValidationError) as error:
        problems.append(f"{path.name}: cannot read the atlas labels: {error}")
        return {}


def _read_atlas_names(
    path: Path, labels: dict[int, AtlasLabel], problems: list[str]
) -> dict[str, str]:
    """``label: readable name`` for every label of the atlas CSV, and nothing else."""
    said = len(problems)
    data = _read_yaml(path, problems)
    if data is None:
        if len(problems) == said:
            problems.append(f"{path.name}: empty")
        return {}
    if not isinstance(data, dict):
        problems.append(f"{path.name}: expected a mapping of atlas label -> readable name")
        return {}
    known = {label.label for label in labels.values()}
    names: dict[str, str] = {}
    seen: dict[str, str] = {}
    for key, value in data.items():
        label = str(key)
        if not isinstance(value, str) or not value.strip() or len(value) > 100:
            problems.append(f"{path.name}: {label}: expected a name of 1 to 100 characters")
            continue
        if labels and label not in known:
            problems.append(f"{path.name}: {label}: not a label of the atlas CSV")
            continue
        other = seen.setdefault(value.strip().casefold(), label)
        if other != label:
            problems.append(f"{path.name}: {label}: {value!r} also names {other}")
        names[label] = value.strip()
    for label in sorted(known - names.keys() - {str(k) for k in data}):
        problems.append(f"{path.name}: no readable name for the atlas label {label!r}")
    return names


def _cross_check(content: AtlasContent, unreadable: set[str]) -> list[str]:
    """Problems between files: labels, names, tutor files (those ``unreadable`` have
    had their problem said) and references."""
    problems = []
    seen_ids: set[str] = set()
    names: dict[tuple[TagSetName, str], str] = {}
    left_out = {tag_set: _left_out(content, tag_set) for tag_set in GROUPS_OF_SET}
    used_labels: dict[tuple[str, int], str] = {}
    for region in content.regions:
        where = f"regions.yaml: {region.id}"
        if region.id in seen_ids:
            problems.append(f"{where}: the id is used twice")
        seen_ids.add(region.id)
        for label_id in region.labels:
            label = content.labels.get(label_id)
            if label is None:
                problems.append(f"{where}: {label_id} is not an atlas label")
            elif label.hemisphere not in SIDES[region.hemisphere]:
                problems.append(
                    f"{where}: label {label_id} ({label.label}) is in hemisphere "
                    f"{label.hemisphere}, not {region.hemisphere}"
                )
            for tag_set in region.sets:
                other = used_labels.setdefault((tag_set, label_id), region.id)
                if other != region.id:
                    problems.append(f"{where}: label {label_id} is also in {other} ({tag_set})")
        # Names need only be unique within a set: a quiz is always taken in one. (A
        # region with unknown labels has a problem already; its names wait for that.)
        labels_known = all(label_id in content.labels for label_id in region.labels)
        for text in [region.name, *region.synonyms, *region.abbreviations]:
            clashes: dict[str, list[str]] = {}
            for tag_set in region.sets:
                other = names.setdefault((tag_set, text.casefold()), region.id)
                if other != region.id:
                    clashes.setdefault(other, []).append(tag_set)
                left_out_label = left_out[tag_set].get(text.casefold())
                if left_out_label is not None and labels_known:
                    problems.append(
                        f"{where}: {text!r} is the atlas name of {left_out_label!r}, which no "
                        f"{tag_set} region includes (add the label, or drop the name)"
                    )
            for other, tag_sets in clashes.items():
                problems.append(f"{where}: {text!r} also names {other} ({', '.join(tag_sets)})")
        tutor = content.tutors.get(region.id)
        if tutor is None:
            if region.id not in unreadable:
                problems.append(f"tutor/{region.id}.yaml: missing")
            continue
        for tag_set in region.sets:
            for group in GROUPS_OF_SET[tag_set]:
                if getattr(tutor, group) is None:
                    problems.append(f"tutor/{region.id}.yaml: no text for {group}")
    for stem in sorted(content.tutors.keys() - seen_ids):
        problems.append(f"tutor/{stem}.yaml: no region {stem!r} in regions.yaml")
    for stem, tutor in sorted(content.tutors.items()):
        for group in ("k5", "undergraduate", "medical", "research"):
            text = getattr(tutor, group)
            for reference in text.references if text else []:
                if reference not in content.references:
                    problems.append(
                        f"tutor/{stem}.yaml: {group} cites {reference!r}, "
                        "which references.yaml does not list"
                    )
    return problems


def _left_out(content: AtlasContent, tag_set: TagSetName) -> dict[str, str]:
    """The set's competitors (atlas regions it leaves out): folded name -> label."""
    competitors = set(content.competitors(tag_set))
    return {
        name.casefold(): label for label, name in content.atlas_names.items() if name in competitors
    }
