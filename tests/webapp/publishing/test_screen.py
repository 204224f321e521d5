"""Publishing to the public screen: escaped rendering, moderation, the lock, persistence."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest
from fastapi import FastAPI
from jinja2 import Environment
from pydantic import ValidationError
from sqlalchemy import select

from wall_client.config import load_walls
from webapp.core.settings import CONTENT_DIR, Settings
from webapp.database.connection import Database
from webapp.database.models import PublicationRecord
from webapp.engine.wall_state import PublicItem, PublicPolicy, read_state
from webapp.people.person import Person, grant, load_person
from webapp.people.visitors import Visitor
from webapp.publishing.publication import Block, Publication, render_item
from webapp.publishing.screen import (
    PublishRefused,
    clear,
    decide,
    screen_layout,
    set_policy,
    submit,
    waiting,
)
from webapp.server.app import create_app
from webapp.server.services import Services

WALL = "demo"
EVIL = '<script>alert(1)</script>"onload='


@asynccontextmanager
async def running(app: FastAPI) -> AsyncIterator[Services]:
    """The app's services, with its startup (and shutdown) run."""
    async with app.router.lifespan_context(app):
        services: Services = app.state.services
        yield services


def templates_of(app: FastAPI) -> Environment:
    env: Environment = app.state.templates.env
    return env


def student(services: Services) -> Person:
    return load_person(services.db, Visitor.fresh(), "127.0.0.1", services.settings)


def instructor(services: Services) -> Person:
    return grant(
        services.db, student(services), "instructor", "login:ines", services.settings, "127.0.0.1"
    )


async def publish(
    app: FastAPI, services: Services, person: Person, title: str = "Hello"
) -> PublicationRecord:
    _, state = read_state(services.db, WALL)
    return await submit(
        services,
        services.walls[WALL],
        state,
        templates_of(app),
        person,
        Publication(title=title, blocks=[Block(kind="text", text=f"about {title}")]),
        source="test",
    )


def on_screen(db: Database) -> PublicItem | None:
    return read_state(db, WALL)[1].public


def status_of(db: Database, publication_id: int) -> str:
    with db.session() as session:
        record = session.get(PublicationRecord, publication_id)
    assert record is not None
    return record.status


# --- rendering and validation ------------------------------------------------------


def test_everything_rendered_is_escaped(app: FastAPI) -> None:
    publication = Publication(
        title=EVIL,
        blocks=[
            Block(kind="text", text=EVIL),
            Block(kind="facts", rows=[(EVIL, "<b>bold</b>"), ("plain", EVIL)]),
            Block(kind="image", src='/static/x.png" onerror="alert(1)'),
        ],
    )
    html = render_item(templates_of(app), publication, EVIL, at_ms=0)
    assert "<script>" not in html and "</script>" not in html
    assert '"onload=' not in html
    assert "<b>" not in html
    assert '" onerror="' not in html
    assert html.count("&lt;script&gt;alert(1)&lt;/script&gt;&#34;onload=") == 5
    assert "&lt;b&gt;bold&lt;/b&gt;" in html
    assert 'src="/static/x.png&#34; onerror=&#34;alert(1)"' in html
    assert "Published by &lt;script&gt;" in html
    assert "00:00 UTC, 01 Jan 1970" in html


def test_a_plain_publication_renders_its_blocks(app: FastAPI) -> None:
    publication = Publication(
        title="Tides",
        blocks=[
            Block(kind="text", text="High water at noon."),
            Block(kind="facts", rows=[("Height", "3 m")]),
            Block(kind="image", src="/static/tides.png"),
        ],
    )
    html = render_item(templates_of(app), publication, "a student", at_ms=86_400_000 + 3_600_000)
    assert "<h1>Tides</h1>" in html
    assert "<p>High water at noon.</p>" in html
    assert "<dt>Height</dt><dd>3 m</dd>" in html
    assert '<img src="/static/tides.png" alt="">' in html
    assert "Published by a student · 01:00 UTC, 02 Jan 1970" in html


def test_markdown_blocks_format_but_never_inject(app: FastAPI) -> None:
    publication = Publication(
        title="Hippocampus", blocks=[Block(kind="markdown", text=f"**Memory.** {EVIL}")]
    )
    html = render_item(templates_of(app), publication, "a student", at_ms=0)
    assert '<div class="markdown"><p><strong>Memory.</strong>' in html
    assert "<script>" not in html and "&lt;script&gt;" in html


@pytest.mark.parametrize(
    "src",
    [
        "https://evil.example/x.png",
        "//evil.example/x.png",
        "javascript:alert(1)",
        "data:image/png;base64,AAAA",
        "static/x.png",
    ],
)
def test_images_come_from_this_site_only(src: str) -> None:
    with pytest.raises(ValidationError, match="images come from this site only"):
        Block(kind="image", src=src)


def test_site_paths_and_no_image_are_fine() -> None:
    assert Block(kind="image", src="/static/x.png").src == "/static/x.png"
    assert Block(kind="text").src == ""


def test_blocks_are_only_the_known_kinds_and_fields() -> None:
    with pytest.raises(ValidationError):
        Block(kind="html", text="<b>x</b>")  # type: ignore[arg-type]
    with pytest.raises(ValidationError):
        Block.model_validate({"kind": "text", "html": "<b>x</b>"})
    with pytest.raises(ValidationError):
        Block(kind="text", text="x" * 8_001)


def test_a_chart_is_one_svg_without_script() -> None:
    svg = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><rect/></svg>'
    assert Block(kind="chart", svg=svg).svg == svg
    for bad in (
        "<b>x</b>",
        svg + "<script>alert(1)</script>",
        svg.replace("<rect/>", "<script>alert(1)</script>"),
        svg.replace("<rect/>", "<foreignObject><p>x</p></foreignObject>"),
    ):
        with pytest.raises(ValidationError):
            Block(kind="chart", svg=bad)


def test_a_chart_is_shown_as_drawn(app: FastAPI) -> None:
    svg = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><rect/></svg>'
    publication = Publication(title="t", blocks=[Block(kind="chart", svg=svg)])
    html = render_item(templates_of(app), publication, "a student", 0)
    assert f'<figure class="chart">{svg}</figure>' in html


@pytest.mark.parametrize(
    "wall_id,box,smallest,largest",
    [
        # 0.63 mm pixels, seats at 2 m: 16' capitals are 9.3 mm, 13.3 mm type, 22 px
        ("demo", (1920, 1080), 22, 32),
        # 30-inch panels of 0.25 mm pixels seen from 2.5 m: three times the pixels
        ("hiperwall", (2560, 1600), 67, 100),
    ],
)
def test_the_public_screen_type_is_readable_from_the_seats(
    wall_id: str, box: tuple[int, int], smallest: int, largest: int
) -> None:
    wall = load_walls([CONTENT_DIR / "walls"])[wall_id]
    layout = screen_layout(wall, Settings())
    assert layout is not None
    assert (layout.box, layout.min_font_px, layout.max_font_px) == (box, smallest, largest)
    assert (layout.words_per_minute, layout.page_min_ms) == (150, 10_000)


def test_publication_limits() -> None:
    with pytest.raises(ValidationError):
        Publication(title="")
    with pytest.raises(ValidationError):
        Publication(title="x" * 201)
    with pytest.raises(ValidationError):
        Publication(title="many", blocks=[Block(kind="text")] * 51)
    with pytest.raises(ValidationError):
        Publication.model_validate({"title": "x", "script": "alert(1)"})
    assert Publication(title="x" * 200, blocks=[Block(kind="text")] * 50).title == "x" * 200


# --- submitting and deciding ---------------------------------------------------------


async def test_an_unmoderated_student_publication_is_shown_at_once(app: FastAPI) -> None:
    async with running(app) as services:
        person = student(services)
        record = await publish(app, services, person, "Tides")
        assert record.status == "shown"
        assert record.author == "a student" and record.visitor_id == person.visitor.id
        assert record.source == "test"
        item = on_screen(services.db)
        assert item is not None and item.id == record.id
        assert item.title == "Tides" and item.author == "a student"
        assert item.html == record.html and "<p>about Tides</p>" in item.html
        assert waiting(services.db, WALL) == []


async def test_a_new_publication_retires_the_one_shown(app: FastAPI) -> None:
    async with running(app) as services:
        first = await publish(app, services, student(services), "First")
        second = await publish(app, services, student(services), "Second")
        assert status_of(services.db, first.id) == "cleared"
        assert status_of(services.db, second.id) == "shown"
        item = on_screen(services.db)
        assert item is not None and item.id == second.id


async def test_moderated_student_publications_wait(app: FastAPI) -> None:
    async with running(app) as services:
        await set_policy(services, services.walls[WALL], PublicPolicy(moderated=True))
        assert read_state(services.db, WALL)[1].public_policy.moderated
        first = await publish(app, services, student(services), "First")
        second = await publish(app, services, student(services), "Second")
        assert first.status == second.status == "pending"
        assert on_screen(services.db) is None
        assert [r.id for r in waiting(services.db, WALL)] == [first.id, second.id]
        assert waiting(services.db, "another-wall") == []
        # staff are not held
        own = await publish(app, services, instructor(services), "From the front")
        assert own.status == "shown"
        item = on_screen(services.db)
        assert item is not None and item.id == own.id


async def test_approving_shows_it_and_retires_the_one_shown(app: FastAPI) -> None:
    async with running(app) as services:
        shown = await publish(app, services, student(services), "Shown")
        await set_policy(services, services.walls[WALL], PublicPolicy(moderated=True))
        held = await publish(app, services, student(services), "Held")
        assert held.status == "pending"
        item = on_screen(services.db)
        assert item is not None and item.id == shown.id, "a held one leaves the screen alone"
        decided = await decide(services, services.walls[WALL], held.id, True, "login:ines")
        assert decided.status == "shown" and decided.decided_by == "login:ines"
        assert decided.decided_at is not None
        item = on_screen(services.db)
        assert item is not None and item.id == held.id and item.title == "Held"
        assert status_of(services.db, shown.id) == "cleared"
        assert waiting(services.db, WALL) == []


async def test_rejecting_leaves_the_screen_as_it_was(app: FastAPI) -> None:
    async with running(app) as services:
        shown = await publish(app, services, student(services), "Shown")
        await set_policy(services, services.walls[WALL], PublicPolicy(moderated=True))
        held = await publish(app, services, student(services), "Held")
        version, _ = read_state(services.db, WALL)
        decided = await decide(services, services.walls[WALL], held.id, False, "login:ines")
        assert decided.status == "rejected" and decided.decided_by == "login:ines"
        assert status_of(services.db, held.id) == "rejected"
        assert status_of(services.db, shown.id) == "shown"
        after, state = read_state(services.db, WALL)
        assert after == version, "the wall did not change"
        assert state.public is not None and state.public.id == shown.id
        assert waiting(services.db, WALL) == []


@pytest.mark.walls("demo", "kl-3x3")
async def test_only_a_waiting_publication_can_be_decided(app: FastAPI) -> None:
    async with running(app) as services:
        shown = await publish(app, services, student(services), "Shown")
        await set_policy(services, services.walls[WALL], PublicPolicy(moderated=True))
        rejected = await publish(app, services, student(services), "Rejected")
        await decide(services, services.walls[WALL], rejected.id, False, "login:ines")
        held = await publish(app, services, student(services), "Held")
        for publication_id in (999_999, rejected.id, shown.id):
            for approve in (True, False):
                with pytest.raises(KeyError):
                    await decide(
                        services, services.walls[WALL], publication_id, approve, "login:ines"
                    )
        with pytest.raises(KeyError):
            another = next(wall for name, wall in services.walls.items() if name != WALL)
            await decide(services, another, held.id, True, "login:ines")
        assert status_of(services.db, rejected.id) == "rejected"
        assert status_of(services.db, held.id) == "pending"
        item = on_screen(services.db)
        assert item is not None and item.id == shown.id
        approved = await decide(services, services.walls[WALL], held.id, True, "login:ines")
        assert approved.status == "shown"
        with pytest.raises(KeyError):
            await decide(services, services.walls[WALL], held.id, True, "login:ines")


async def test_a_locked_screen_refuses_students_but_not_instructors(app: FastAPI) -> None:
    async with running(app) as services:
        await set_policy(services, services.walls[WALL], PublicPolicy(locked=True))
        with pytest.raises(PublishRefused, match="locked"):
            await publish(app, services, student(services), "Refused")
        with services.db.session() as session:
            assert session.scalars(select(PublicationRecord)).all() == [], "nothing stored"
        assert on_screen(services.db) is None
        own = await publish(app, services, instructor(services), "From the front")
        assert own.status == "shown"
        item = on_screen(services.db)
        assert item is not None and item.id == own.id


async def test_clear_empties_the_screen(app: FastAPI) -> None:
    async with running(app) as services:
        shown = await publish(app, services, student(services), "Shown")
        await clear(services, services.walls[WALL])
        assert on_screen(services.db) is None
        assert status_of(services.db, shown.id) == "cleared"
        await clear(services, services.walls[WALL])  # clearing an empty screen is fine
        assert on_screen(services.db) is None


async def test_the_screen_the_queue_and_the_policy_survive_a_restart(
    app: FastAPI, settings: Settings, db: Database
) -> None:
    async with running(app) as services:
        await set_policy(services, services.walls[WALL], PublicPolicy(moderated=True))
        approved = await publish(app, services, student(services), "Approved")
        held = await publish(app, services, student(services), "Held")
        await decide(services, services.walls[WALL], approved.id, True, "login:ines")
    # the app is shut down; a new connection to the same database sees it all
    _, state = read_state(db, WALL)
    assert state.public is not None and state.public.id == approved.id
    assert state.public.title == "Approved"
    assert state.public_policy == PublicPolicy(moderated=True)
    assert [r.id for r in waiting(db, WALL)] == [held.id]
    assert status_of(db, approved.id) == "shown"
    async with running(create_app(settings)) as services:  # and a new app starting keeps it
        item = on_screen(services.db)
        assert item is not None and item.id == approved.id
        assert [r.id for r in waiting(services.db, WALL)] == [held.id]
