"""kill -9 of the server while a class answers, publishes and the wall changes: after a
restart every acknowledged answer, state change and publication is there, and the open
tiles come back to the server's version by themselves, without reloading.

Runs on SQLite and, in CI's second pass, on PostgreSQL (the shared ``database_url``).
"""

from __future__ import annotations

import csv
import io
import os
import re
import signal
import threading
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Browser
from sqlalchemy import select

from tests.browser.conftest import open_tiles, serve, version_of
from webapp.cli.testing import ServerProcess, wait_until
from webapp.database.connection import Database
from webapp.database.models import PublicationRecord, WallEventRecord
from webapp.tags.registry import wall_tags

STUDENTS = 16
TILES = ["r1c1", "r1c2", "r2c1"]
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')


@dataclass
class Acknowledged:
    """What the server said it had done before it was killed."""

    answers: set[tuple[str, str]] = field(default_factory=set)  # (student, answer text)
    publications: dict[str, int] = field(default_factory=dict)  # student name -> count
    versions: dict[int, dict[str, bool]] = field(default_factory=dict)  # version -> layers
    lock: threading.Lock = field(default_factory=threading.Lock)


def student(
    server: ServerProcess,
    number: int,
    codes: dict[str, list[str]],
    seen: Acknowledged,
    stop: threading.Event,
) -> None:
    """Register, choose a name, then answer pins and now and then publish, until the
    server dies (or the test stops the class)."""
    name = f"student{number:02d}"
    try:
        with httpx.Client(base_url=server.url, timeout=10) as phone:
            phone.get(f"/t/{codes['register'][0]}")
            csrf = _CSRF.search(phone.get("/me").text).group(1)  # type: ignore[union-attr]
            profile = {"csrf": csrf, "display_name": name, "user_group": "k5", "info_class": "1"}
            phone.post("/me", data=profile)
            for turn, pin in enumerate(codes["pins"]):
                if stop.is_set():
                    return
                text = f"{name}answer{turn}"
                answered = phone.post(
                    f"/apps/brain/demo/pins/{pin}/answer", data={"answer": text, "csrf": csrf}
                )
                if answered.status_code == 303:
                    with seen.lock:
                        seen.answers.add((name, text))
                if turn % 4 == number % 4:
                    published = phone.post(
                        "/publish", data={"code": codes["publish"][0], "csrf": csrf}
                    )
                    if published.status_code == 200 and "on the public screen" in published.text:
                        with seen.lock:
                            seen.publications[name] = seen.publications.get(name, 0) + 1
    except httpx.HTTPError:
        return  # the server died under this phone: what it did not hear back, it did not get


def operator(server: ServerProcess, seen: Acknowledged, stop: threading.Event) -> None:
    """The instructor turns the grid on and off, as fast as the server acknowledges."""
    shown = False
    with httpx.Client(base_url=server.url, timeout=10, headers=server.operator()) as client:
        while not stop.is_set():
            shown = not shown
            try:
                response = client.post("/api/walls/demo/state", json={"layers": {"grid": shown}})
            except httpx.HTTPError:
                return
            if response.status_code == 200:
                with seen.lock:
                    seen.versions[response.json()["version"]] = {"grid": shown}


@pytest.mark.persistence
@pytest.mark.alone  # a kill -9 with requests in flight
def test_nothing_acknowledged_is_lost_to_a_kill_9(
    browser: Browser, tmp_path: Path, database_url: str
) -> None:
    server = serve(tmp_path, database_url)
    db = Database(database_url)
    try:
        server.change("demo", {"app": "brain"})  # its pins are made; a quiz round starts
        pins = [t.code for t in wall_tags(db, "demo") if t.action == "pin" and t.active][:24]
        server.change("demo", {"app": "pattern"})  # answers still count; tiles draw less
        tags = wall_tags(db, "demo")
        codes = {
            "register": [t.code for t in tags if t.name == "register-student"],
            "publish": [t.code for t in tags if t.name == "setup-r2c2"],
            "pins": pins,
        }
        assert codes["register"] and codes["publish"] and len(codes["pins"]) >= 12
        pages = open_tiles(browser, server, "demo", TILES)
        start = server.version("demo")
        wait_until(
            lambda: all(version_of(p) == start for p in pages), what="tiles to draw the wall"
        )
        for page in pages:  # a reload would wipe this
            page.evaluate("window.__sinceStart = true")

        seen, stop = Acknowledged(), threading.Event()
        workers = [
            threading.Thread(target=student, args=(server, n, codes, seen, stop))
            for n in range(STUDENTS)
        ]
        workers.append(threading.Thread(target=operator, args=(server, seen, stop)))
        for worker in workers:
            worker.start()
        wait_until(
            lambda: len(seen.answers) >= STUDENTS * 4 and len(seen.versions) >= 5,
            timeout=60,
            what="the class to be well under way",
        )
        os.kill(server.pid, signal.SIGKILL)  # mid-way: requests are in flight
        server.process.wait()  # type: ignore[union-attr]
        stop.set()
        for worker in workers:
            worker.join(30)
        with seen.lock:
            answers, publications = set(seen.answers), dict(seen.publications)
            versions = dict(seen.versions)
        server.process = None
        server.start()

        exported = httpx.get(
            f"{server.url}/api/apps/brain/walls/demo/answers.csv",
            headers=server.operator(),
            timeout=30,
        )
        assert exported.status_code == 200
        stored = {
            (row["name"], row["answer"]) for row in csv.DictReader(io.StringIO(exported.text))
        }
        assert answers <= stored, f"lost answers: {sorted(answers - stored)[:5]}"

        with db.session() as session:
            rows = session.scalars(select(PublicationRecord)).all()
            authors = [r.author for r in rows]
            events = {
                r.version: r.changes
                for r in session.scalars(
                    select(WallEventRecord).where(WallEventRecord.wall_id == "demo")
                )
            }
        for name, count in publications.items():
            assert authors.count(f"{name} (student)") >= count, f"lost a publication of {name}"
        for version, layers in versions.items():
            assert version in events, f"lost the acknowledged state change {version}"
            assert events[version]["layers"]["grid"] == layers["grid"]
        now = server.version("demo")
        assert now >= max(versions)

        wait_until(
            lambda: all(version_of(p) == now for p in pages),
            timeout=60,
            what=f"the tiles to come back to version {now} by themselves",
        )
        assert all(p.evaluate("window.__sinceStart === true") for p in pages), "no reload"
        assert sum(publications.values()) > 0 and len(versions) >= 5
        print(
            f"\nacknowledged before kill -9: {len(answers)} answers, "
            f"{sum(publications.values())} publications, {len(versions)} state changes; "
            f"all there after the restart (version {now})"
        )
    finally:
        server.stop()
        db.dispose()
