"""The tag registry: issuing codes, declaring an app's tags, placing tag sets.

``tag_service`` holds the pure rules (codes, sizing, placement, decoding); this
module keeps them in the database. A *layout* is one placement of a wall's tag set,
stored immutably; the wall state names the layout in use, so switching sets or
re-placing is an ordinary (heavy) wall-state change that every tile applies in sync.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import lru_cache
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator
from sqlalchemy import delete, func, or_, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from tag_service.codes import (
    ALPHABET,
    CODE_LENGTH,
    Contact,
    PayloadKind,
    matrix_rows,
    modules_across,
    new_code,
    symbol_variants,
    tel_payload,
    text_payload,
    url_payload,
    vcard_payload,
)
from tag_service.placement import CAPTION_OF_SIDE, SPREAD_OF_SIDE, PlacementRequest, place
from tag_service.sizing import code_size, min_module_mm
from wall_client.layout import CodePurpose, Wall
from webapp.database.connection import Database, as_utc
from webapp.database.models import TagLayoutRecord, TagRecord, WallStateRecord
from webapp.tags.schemas import PlacedCode, TagUpdate, UnplacedCode

LAYOUTS_KEPT = 20
"""Layouts kept per wall: the one in use and a few before it (tiles mid-swap fetch them)."""

_ISSUE_ATTEMPTS = 5
_SAFE_NAME = r"^[A-Za-z0-9_.:-]+$"


class ContactSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1, max_length=100)
    phone: str | None = Field(default=None, max_length=40)
    email: str | None = Field(default=None, max_length=200)
    organization: str | None = Field(default=None, max_length=200)
    url: str | None = Field(default=None, max_length=300)


class TagSpec(BaseModel):
    """A tag as an app declares it or an operator issues it."""

    model_config = ConfigDict(extra="forbid")

    name: str | None = Field(default=None, min_length=1, max_length=100, pattern=_SAFE_NAME)
    label: str = Field(default="", max_length=200)
    app: str = Field(min_length=1, max_length=64, pattern=_SAFE_NAME)
    action: str = Field(min_length=1, max_length=64, pattern=_SAFE_NAME)
    params: dict[str, Any] = Field(default_factory=dict)
    kind: PayloadKind = "url"
    text: str | None = Field(default=None, max_length=500)
    number: str | None = Field(default=None, max_length=40)
    contact: ContactSpec | None = None
    tag_set: str | None = Field(default=None, min_length=1, max_length=64, pattern=_SAFE_NAME)
    anchor: tuple[float, float] | None = None
    screen: Literal["public", "menu", "registration"] | None = None
    slot: int = Field(default=0, ge=0, le=99)
    size_mm: float | None = Field(default=None, gt=0, le=5_000)
    clear_mm: float | None = Field(
        default=None,
        gt=0,
        le=1_000,
        description="keep a square of side 2*clear_mm around the anchor free of codes:"
        " the code stands on a pin beside what it marks (anchored tags only)",
    )
    priority: int = Field(default=0, ge=-1_000, le=1_000)
    active: bool = True
    expires_at: datetime | None = None

    @model_validator(mode="after")
    def _check(self) -> TagSpec:
        if (self.anchor is None) == (self.screen is None):
            raise ValueError("give a tag either an anchor (wall mm) or a screen slot")
        if self.clear_mm is not None and self.anchor is None:
            raise ValueError("clear_mm keeps the area around an anchor free: give an anchor")
        content_payload(self.kind, self.content())  # raises PayloadError with the reason
        if self.expires_at is not None:
            self.expires_at = as_utc(self.expires_at)
        return self

    def content(self) -> dict[str, Any]:
        """What a direct (non-URL) tag carries, as stored."""
        if self.kind == "text":
            return {"text": self.text or ""}
        if self.kind == "tel":
            return {"number": self.number or ""}
        if self.kind == "vcard":
            return {"contact": self.contact.model_dump() if self.contact else {"name": ""}}
        return {}


PLACE = "place"
"""The params key of a tag issued at a place (:class:`Place`): ``{"app", "id", "label"}``."""


class Place(BaseModel):
    """A named point of an app's material that the wall shows now (an image's hotspot),
    where an instructor may stand a code of their own: the app's name, an id unique
    within the app, a label for the dashboard, its point in scene mm, and the square kept
    free around it (``clear_mm``, as for a tag: a code stands beside what it marks)."""

    model_config = ConfigDict(frozen=True)

    app: str = Field(min_length=1, max_length=64, pattern=_SAFE_NAME)
    id: str = Field(min_length=1, max_length=100)
    label: str = Field(max_length=200)
    anchor: tuple[float, float]
    clear_mm: float = Field(default=0.0, ge=0, le=1_000)

    def binding(self) -> dict[str, str]:
        """What a tag standing at the place keeps under :data:`PLACE` (the label too, for
        lists while the place is not shown)."""
        return {"app": self.app, "id": self.id, "label": self.label}


def content_payload(kind: str, content: dict[str, Any]) -> str | None:
    """The payload of a direct tag; None for URL tags (their payload names the server)."""
    if kind == "text":
        return text_payload(content.get("text", ""))
    if kind == "tel":
        return tel_payload(content.get("number", ""))
    if kind == "vcard":
        return vcard_payload(Contact(**content.get("contact", {"name": ""})))
    return None


def payload_of(tag: TagRecord, base_url: str) -> str:
    """What the tag's QR symbol encodes."""
    direct = content_payload(tag.kind, tag.content)
    return direct if direct is not None else url_payload(base_url, tag.code)


def _fill(record: TagRecord, spec: TagSpec) -> None:
    record.name = spec.name
    record.label = spec.label
    record.app = spec.app
    record.action = spec.action
    record.params = spec.params
    record.kind = spec.kind
    record.content = spec.content()
    record.tag_set = spec.tag_set
    record.anchor_x, record.anchor_y = spec.anchor if spec.anchor else (None, None)
    record.screen = spec.screen
    record.slot = spec.slot
    record.size_mm = spec.size_mm
    record.clear_mm = spec.clear_mm
    record.priority = spec.priority
    record.active = spec.active
    record.expires_at = spec.expires_at


def issue(db: Database, wall_id: str, spec: TagSpec, created_by: str) -> TagRecord:
    """Register a new tag under a fresh random code (or, for a named tag, update it)."""
    for _ in range(_ISSUE_ATTEMPTS):
        try:
            with db.session() as session:
                return _issue(session, wall_id, spec, created_by)
        except IntegrityError:
            continue  # a code collision, or a concurrent declaration of the same name
    raise RuntimeError(f"could not register tag {spec.name or spec.label!r} on {wall_id!r}")


def _issue(
    session: Session,
    wall_id: str,
    spec: TagSpec,
    created_by: str,
    known: dict[str, TagRecord] | None = None,
) -> TagRecord:
    """Fill in the tag named like ``spec`` (found in ``known`` when the caller looked
    its names up already), or a new one."""
    record = None
    if spec.name is not None:
        record = (
            known.get(spec.name)
            if known is not None
            else session.scalar(
                select(TagRecord).where(TagRecord.wall_id == wall_id, TagRecord.name == spec.name)
            )
        )
    if record is None:
        record = TagRecord(code=new_code(), wall_id=wall_id, created_by=created_by)
        session.add(record)
    _fill(record, spec)
    session.flush()
    return record


def declare(db: Database, wall_id: str, app: str, specs: Sequence[TagSpec]) -> None:
    """Make ``app``'s named tags on the wall exactly ``specs``, in one transaction.

    Codes of tags declared before never change; tags the app no longer declares are
    switched off, not deleted, so their scan history stays. A name another app's tag
    has on the wall is refused: an app's codes stay its own.
    """
    if any(spec.name is None or spec.app != app for spec in specs):
        raise ValueError(f"declared tags need a name and app {app!r}")
    names = {spec.name for spec in specs}
    for _ in range(_ISSUE_ATTEMPTS):
        try:
            with db.session() as session:
                named = sorted(name for name in names if name)
                known = {
                    record.name: record
                    for record in session.scalars(
                        select(TagRecord).where(
                            TagRecord.wall_id == wall_id,
                            or_(TagRecord.app == app, TagRecord.name.in_(named)),
                        )
                    )
                    if record.name is not None
                }
                taken = sorted(f"{r.name} ({r.app})" for r in known.values() if r.app != app)
                if taken:
                    raise ValueError(
                        f"app {app!r} declares tags named as other apps' on {wall_id!r}: "
                        + ", ".join(taken)
                    )
                for spec in specs:
                    _issue(session, wall_id, spec, f"app:{app}", known)
                stale = session.scalars(
                    select(TagRecord).where(
                        TagRecord.wall_id == wall_id,
                        TagRecord.app == app,
                        TagRecord.name.is_not(None),
                        TagRecord.active.is_(True),
                    )
                )
                for record in stale:
                    if record.name not in names:
                        record.active = False
            return
        except IntegrityError:
            continue
    raise RuntimeError(f"could not declare the tags of {app!r} on {wall_id!r}")


def find(db: Database, code: str) -> TagRecord | None:
    with db.session() as session:
        return session.get(TagRecord, code)


def wall_tags(db: Database, wall_id: str) -> list[TagRecord]:
    with db.session() as session:
        return list(
            session.scalars(
                select(TagRecord)
                .where(TagRecord.wall_id == wall_id)
                .order_by(TagRecord.tag_set, TagRecord.created_at, TagRecord.code)
            )
        )


def active_tags_per_app(db: Database, wall_id: str) -> dict[str, int]:
    """How many active tags each app has on the wall."""
    with db.session() as session:
        rows = session.execute(
            select(TagRecord.app, func.count())
            .where(TagRecord.wall_id == wall_id, TagRecord.active.is_(True))
            .group_by(TagRecord.app)
        )
        return {app: int(count) for app, count in rows}


def tag_sets(db: Database, wall_id: str) -> list[str]:
    """The wall's named tag sets (tags without a set stand in every set)."""
    with db.session() as session:
        names = session.scalars(
            select(TagRecord.tag_set)
            .where(TagRecord.wall_id == wall_id, TagRecord.tag_set.is_not(None))
            .distinct()
        )
        return sorted(name for name in names if name is not None)


def is_live(tag: TagRecord, now: datetime | None = None) -> bool:
    """Active and not expired: the one rule for whether a tag still works."""
    now = now or datetime.now(UTC)
    expires = tag.expires_at
    return tag.active and (expires is None or as_utc(expires) > now)


def shown_in(tag: TagRecord, tag_set: str | None) -> bool:
    """Whether ``tag`` belongs on the wall while ``tag_set`` is the active set."""
    return tag.tag_set is None or tag.tag_set == tag_set


def stand_at_places(db: Database, wall_id: str, places: Sequence[Place]) -> None:
    """Anchor each issued tag bound to a place where that place stands now, with its
    clearance; one whose place the wall does not show now stands nowhere (no anchor, so
    it is not placed) until the place is shown again. The one rule for codes that follow
    an app's material as the view moves. Declared tags are left to their apps, which
    anchor them at every declaration."""
    shown: dict[tuple[object, object], Place] = {(p.app, p.id): p for p in places}
    with db.session() as session:
        issued = session.scalars(
            select(TagRecord).where(TagRecord.wall_id == wall_id, TagRecord.name.is_(None))
        )
        for tag in issued:
            bound = tag.params.get(PLACE)
            if not isinstance(bound, dict):
                continue
            place = shown.get((bound.get("app"), bound.get("id")))
            if place is None:
                tag.anchor_x = tag.anchor_y = None
                continue
            tag.anchor_x, tag.anchor_y = place.anchor
            tag.clear_mm = place.clear_mm
            if bound != place.binding():  # relabelled (a hotspot's new title)
                tag.params = {**tag.params, PLACE: place.binding()}


def _tags_to_place(
    session: Session, wall_id: str, tag_set: str | None, apps: Collection[str]
) -> list[TagRecord]:
    """The live tags that stand on the wall while ``tag_set`` is shown: those of the
    installed ``apps`` only (an app's codes leave the wall while it is not installed,
    and come back, with their codes, when it is again)."""
    rows = session.scalars(
        select(TagRecord)
        .where(
            TagRecord.wall_id == wall_id,
            TagRecord.app.in_(sorted(apps)),
            or_(TagRecord.tag_set.is_(None), TagRecord.tag_set == tag_set),
            # a tag at a place the wall does not show now stands nowhere
            or_(TagRecord.anchor_x.is_not(None), TagRecord.screen.is_not(None)),
        )
        .order_by(TagRecord.priority.desc(), TagRecord.created_at, TagRecord.code)
    )
    now = datetime.now(UTC)
    return [tag for tag in rows if is_live(tag, now)]


def layout_for(
    db: Database, wall: Wall, tag_set: str | None, base_url: str, apps: Collection[str]
) -> int:
    """The id of a layout placing ``tag_set`` as its tags stand now.

    A layout's inputs (wall geometry, tags, payloads) are hashed and an existing
    layout with the same inputs is reused, so restarts and switching back and forth
    place nothing again.
    """
    with db.session() as session:
        tags = _tags_to_place(session, wall.id, tag_set, apps)
        payloads = [payload_of(tag, base_url) for tag in tags]
        digest = _inputs_hash(wall, tag_set, tags, payloads)
        existing = session.scalar(
            select(TagLayoutRecord.id)
            .where(TagLayoutRecord.wall_id == wall.id, TagLayoutRecord.inputs_hash == digest)
            .order_by(TagLayoutRecord.id.desc())
            .limit(1)
        )
        if existing is not None:
            return existing
        placed, unplaced = compute_layout(wall, tags, payloads)
        record = TagLayoutRecord(
            wall_id=wall.id,
            tag_set=tag_set,
            inputs_hash=digest,
            placed=placed,
            unplaced=unplaced,
        )
        session.add(record)
        session.flush()
        recent = (
            select(TagLayoutRecord.id)
            .where(TagLayoutRecord.wall_id == wall.id)
            .order_by(TagLayoutRecord.id.desc())
            .limit(LAYOUTS_KEPT)
            .scalar_subquery()
        )
        in_use = session.get(WallStateRecord, wall.id)
        session.execute(
            delete(TagLayoutRecord).where(
                TagLayoutRecord.wall_id == wall.id,
                TagLayoutRecord.id.not_in(recent),
                TagLayoutRecord.id != (in_use.state.get("tag_layout", 0) if in_use else 0),
            )
        )
        return record.id


@dataclass(frozen=True)
class Preview:
    """A tag set as it would be placed if one app declared other tags: what a view the
    wall does not show yet would carry (phones are told where a thing can be scanned)."""

    wall: Wall
    digest: str  # the placement's inputs: equal digests, equal placements
    tags: list[TagRecord]  # detached; the app's new tags carry stand-in codes
    payloads: list[str]

    def placed_names(self) -> set[str]:
        """The names of the tags that would get a place on the wall."""
        placed, _ = compute_layout(self.wall, self.tags, self.payloads)
        by_code = {tag.code: tag.name for tag in self.tags}
        return {name for p in placed if (name := by_code[p["code"]]) is not None}


def preview(
    db: Database,
    wall: Wall,
    tag_set: str | None,
    base_url: str,
    apps: Collection[str],
    app: str,
    specs: Sequence[TagSpec],
) -> Preview:
    """``tag_set`` placed as :func:`layout_for` would place it after ``app`` declared
    exactly ``specs``, without touching the registry. Tags the app has keep their
    codes; new ones get stand-in codes of the same length (so the same symbol size),
    derived from their names so that equal inputs give equal digests."""
    now = datetime.now(UTC)
    with db.session() as session:
        others = [
            tag
            for tag in _tags_to_place(session, wall.id, tag_set, apps)
            if tag.app != app or not tag.name
        ]
        known = {
            tag.name: tag
            for tag in session.scalars(
                select(TagRecord).where(TagRecord.wall_id == wall.id, TagRecord.app == app)
            )
            if tag.name
        }
    staged = []
    for spec in specs:
        if not spec.active or spec.tag_set not in (None, tag_set):
            continue
        existing = known.get(spec.name or "")
        record = TagRecord(
            code=existing.code if existing else _stand_in_code(spec.name or spec.label),
            wall_id=wall.id,
            created_at=as_utc(existing.created_at) if existing else now,
        )
        _fill(record, spec)
        staged.append(record)
    tags = sorted(others + staged, key=lambda t: (-(t.priority or 0), as_utc(t.created_at), t.code))
    payloads = [payload_of(tag, base_url) for tag in tags]
    return Preview(wall, _inputs_hash(wall, tag_set, tags, payloads), tags, payloads)


def _stand_in_code(name: str) -> str:
    digest = hashlib.sha256(name.encode()).digest()
    return "".join(ALPHABET[byte % len(ALPHABET)] for byte in digest[:CODE_LENGTH])


def compute_layout(
    wall: Wall, tags: Sequence[TagRecord], payloads: Sequence[str]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Place ``tags`` on ``wall``: what tiles draw, and what could not be placed and why.

    Both lists are in code order: codes are random, so the order says nothing about
    which tag came first (a quiz's pins are placed in an order that must stay secret)."""
    variants = {tag.code: symbol_variants(p) for tag, p in zip(tags, payloads, strict=True)}
    requests = [
        PlacementRequest(
            key=tag.code,
            sizes=tuple(modules_across(symbol) for symbol in variants[tag.code]),
            module_mm=min_module_mm(wall.design_distance_m(purpose_of(tag))),
            anchor=anchor_of(tag),
            screen=tag.screen,
            slot=tag.slot,
            preferred_mm=tag.size_mm,
            clear_mm=tag.clear_mm or 0.0,
            caption=bool(tag.label),
        )
        for tag in tags
    ]
    result = place(wall, requests)
    by_code = {tag.code: tag for tag in tags}
    payload_by_code = {tag.code: p for tag, p in zip(tags, payloads, strict=True)}
    placed = [
        PlacedCode(
            code=p.key,
            label=by_code[p.key].label,
            kind=by_code[p.key].kind,
            payload=payload_by_code[p.key],
            display=p.display_id,
            rect=p.rect.xywh,
            pixels=p.pixels,
            px_per_module=p.px_per_module,
            modules=p.modules,
            error=variants[p.key][p.variant].error or "M",
            version=int(variants[p.key][p.variant].version),
            matrix=matrix_rows(variants[p.key][p.variant]),
            anchor=anchor_of(by_code[p.key]) or p.rect.center,
            leader=p.leader,
            caption=p.caption.xywh if p.caption else None,
            purpose=purpose_of(by_code[p.key]),
        ).model_dump(mode="json")
        for p in sorted(result.placed, key=lambda p: p.key)
    ]
    unplaced = [
        UnplacedCode(code=u.key, label=by_code[u.key].label, reason=u.reason).model_dump()
        for u in sorted(result.unplaced, key=lambda u: u.key)
    ]
    return placed, unplaced


def purpose_of(tag: TagRecord) -> CodePurpose:
    """Codes on a designated screen (registration, menus) serve people in their seats;
    anchored codes mark something on the scene, and people walk up to them."""
    return "seat" if tag.screen is not None else "walk-up"


def anchor_of(tag: TagRecord) -> tuple[float, float] | None:
    if tag.anchor_x is None or tag.anchor_y is None:
        return None
    return (tag.anchor_x, tag.anchor_y)


def _inputs_hash(
    wall: Wall, tag_set: str | None, tags: Sequence[TagRecord], payloads: Sequence[str]
) -> str:
    geometry = [(d.id, d.rect.xywh, d.resolution, d.rotation) for d in wall.displays]
    inputs = {
        "wall": [
            wall.id,
            wall.bezel_mode,
            wall.seat_distance_m,
            wall.walk_up_distance_m,
            geometry,
            wall.screens,
        ],
        "set": tag_set,
        "tags": [
            [
                t.code,
                t.label,
                t.kind,
                anchor_of(t),
                t.screen,
                t.slot,
                t.size_mm,
                t.clear_mm,
                t.priority,
                payload,
            ]
            for t, payload in zip(tags, payloads, strict=True)
        ],
    }
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def get_layout(db: Database, wall_id: str, layout_id: int) -> TagLayoutRecord | None:
    with db.session() as session:
        record = session.get(TagLayoutRecord, layout_id)
        return record if record is not None and record.wall_id == wall_id else None


def update_tag(db: Database, code: str, update: TagUpdate) -> TagRecord:
    """Apply an operator's change to a tag (fields not given stay as they are)."""
    with db.session() as session:
        tag = session.get(TagRecord, code)
        if tag is None:
            raise KeyError(code)
        given = update.model_dump(exclude_unset=True)
        if "label" in given and update.label is not None:
            tag.label = update.label
        if "active" in given and update.active is not None:
            tag.active = update.active
        if "expires_at" in given:
            tag.expires_at = as_utc(update.expires_at) if update.expires_at else None
        return tag


@lru_cache(maxsize=16)
def url_code_sizes(base_url: str) -> tuple[int, ...]:
    """The widths (modules) a tag URL's symbol may take, in the order placement tries
    them. Every code's URL has the same length, so one stands for all; encoding it is
    milliseconds of work that pages asking "how big are codes here" would repeat."""
    payload = url_payload(base_url, "0" * CODE_LENGTH)
    return tuple(modules_across(symbol) for symbol in symbol_variants(payload))


def anchored_code_side_mm(base_url: str, wall: Wall) -> float:
    """How wide a code anchored in the scene stands on this wall: the smallest symbol
    that carries a tag URL, at the walk-up distance, on a display of the stage. Apps
    size what they keep clear around their codes by it."""
    modules = min(url_code_sizes(base_url))
    display = wall.display(wall.stage_ids[0])
    return code_size(display, modules, min_module_mm(wall.walk_up_distance_m)).side_mm


def places_anchored(
    wall: Wall,
    base_url: str,
    anchors: Sequence[tuple[str, tuple[float, float]]],
    clear_mm: float = 0.0,
) -> set[str]:
    """The keys of ``anchors`` that find a spot when URL tags with captions are anchored
    there (each keeping ``clear_mm`` around its anchor) and placed in this order, as
    :func:`compute_layout` places them (give the tags falling priorities in this order).
    Apps try their anchored codes so before declaring them, and hand what would not fit
    to codes that do, or choose the order that leaves fewest out."""
    sizes = url_code_sizes(base_url)
    module_mm = min_module_mm(wall.walk_up_distance_m)
    requests = [
        PlacementRequest(
            key=key,
            sizes=sizes,
            module_mm=module_mm,
            anchor=anchor,
            clear_mm=clear_mm,
            caption=True,
        )
        for key, anchor in anchors
    ]
    return {placed.key for placed in place(wall, requests).placed}


def anchored_footprint_mm(base_url: str, wall: Wall) -> tuple[float, float]:
    """Width and height an anchored code takes with its caption and the gap kept
    around it: what apps count with when they decide how many codes a view holds."""
    side = anchored_code_side_mm(base_url, wall)
    return side * (1 + 2 * SPREAD_OF_SIDE), side * (1 + CAPTION_OF_SIDE + 2 * SPREAD_OF_SIDE)
