"""A phone's steps one after another: the server's CPU per request beside two floors.

Three servers, each its own process under uvicorn, measured in the same run:

* the bare Starlette floor (``benchmarks.floors:starlette_app``, ``GET /healthz``:
  a plain-text answer);
* the bare FastAPI + Jinja floor (``benchmarks.floors:fastapi_app``, ``GET /page``: one
  dependency, a template of about 2 kB): the least a phone's page can cost in the
  framework tagwall is built on, and what every step is compared with;
* ``tagwall serve`` on SQLite with the brain atlas on the ``demo`` wall.

Each step is ``REQUESTS`` requests made one after another on one keep-alive connection
(one httpx client, one connection), and its cost is the CPU the server's process
spent meanwhile (user + system, ``/proc``), less what it spends idle, per request; the
client's own CPU is in another process and does not count. The steps of a phone:

* ``register``: a first scan, of the Student registration code, with no cookie (each
  request makes a visitor);
* ``scan``: a scan of a quiz pin by a phone in the room (its session cookie);
* ``pin``: the pin's page again, as the progress page links it;
* ``answer``: the quiz answer, a form POST with the page's CSRF token (the answer
  alternates, so each one is a change);
* ``progress``: the quiz progress page the answer redirects to;

and ``healthz``, the least request tagwall answers. The machine is shared and its
speed swings by two from minute to minute, so the FastAPI floor is measured again just
before each step, a step's ``ratio`` is its CPU in the floor of that moment, and the
round of all of them is run ``ROUNDS`` times: each figure is the median of its rounds.
The aim (issue 32): every phone step at most ``TARGET_RATIO`` floors.

Every request comes from 127.0.0.1, so the per-phone and per-address limits are lifted
(``LIMIT_SETTINGS``): only the cost of a request is measured.
"""

from __future__ import annotations

import re
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import httpx

from benchmarks.lecture_hall import PHONE_WALL, SECRET, USER_AGENT, hall_codes
from benchmarks.measuring import cpu_seconds, process_tree

REQUESTS = 300
ROUNDS = 5
IDLE_S = 2.0
WARMUP = 20
TARGET_RATIO = 2.0
LIMIT_SETTINGS = {
    "TAGWALL_SCAN_RATE_PER_MINUTE": "100000000",
    "TAGWALL_SCAN_RATE_PER_ADDRESS_PER_MINUTE": "100000000",
}
PHONE_STEPS = ("register", "scan", "pin", "answer", "progress")
ANSWERS = ("hippocampus", "amygdala")
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')

Request = Callable[[int], httpx.Response]  # the request of a step, given its index


def idle_rate(pids: list[int], seconds: float) -> float:
    """CPU seconds per second the server spends with no request (its own timers)."""
    if seconds <= 0:
        return 0.0
    before = cpu_seconds(pids)
    time.sleep(seconds)
    return (cpu_seconds(pids) - before) / seconds


def cpu_ms_per_request(pids: list[int], request: Request, count: int, idle: float = 0.0) -> float:
    """The server's CPU per request (ms) over ``count`` requests made one after another."""
    for index in range(min(WARMUP, count)):
        request(index)
    start, before = time.perf_counter(), cpu_seconds(pids)
    for index in range(count):
        request(index)
    spent = cpu_seconds(pids) - before - idle * (time.perf_counter() - start)
    return max(0.0, spent) / count * 1000


def client(base_url: str) -> httpx.Client:
    """A browser on one keep-alive connection."""
    return httpx.Client(
        base_url=base_url,
        timeout=120,
        headers={"User-Agent": USER_AGENT},
        limits=httpx.Limits(max_connections=1, max_keepalive_connections=1),
    )


def checked(response: httpx.Response) -> httpx.Response:
    if not 200 <= response.status_code < 400:
        raise RuntimeError(f"{response.request.url} answered {response.status_code}")
    return response


def phone_requests(
    register: str, pin: str, phone: httpx.Client, newcomer: httpx.Client
) -> dict[str, Request]:
    """Each step as a request that can be repeated: ``newcomer`` makes the first scans
    (its cookies cleared before each), ``phone`` (in the room: it scanned the
    registration code) the rest."""
    checked(phone.get(f"/t/{register}"))
    form = checked(phone.get(f"/t/{pin}"))
    found = _CSRF.search(form.text)
    if found is None:
        raise RuntimeError("the pin's page has no CSRF token")
    csrf = found.group(1)
    answer_path = f"/apps/brain/{PHONE_WALL}/pins/{pin}/answer"
    progress_path = checked(phone.post(answer_path, data={"answer": "x", "csrf": csrf})).headers[
        "location"
    ]

    def first_scan(_index: int) -> httpx.Response:
        newcomer.cookies.clear()
        return checked(newcomer.get(f"/t/{register}"))

    def answer(index: int) -> httpx.Response:
        return checked(phone.post(answer_path, data={"answer": ANSWERS[index % 2], "csrf": csrf}))

    return {
        "register": first_scan,
        "scan": lambda _: checked(phone.get(f"/t/{pin}")),
        "pin": lambda _: checked(phone.get(f"/apps/brain/{PHONE_WALL}/pins/{pin}")),
        "answer": answer,
        "progress": lambda _: checked(phone.get(progress_path)),
        "healthz": lambda _: checked(phone.get("/healthz")),
    }


def page(browser: httpx.Client, path: str) -> Request:
    return lambda _: checked(browser.get(path))


@contextmanager
def floor_server(app: str, scratch: Path) -> Iterator[Any]:
    """A floor app under uvicorn, as ``tagwall serve`` runs one."""
    from webapp.cli.testing import ServerProcess

    server = ServerProcess(var_dir=scratch / app, database_url="", secret="")
    server.command = [sys.executable, "-m", "uvicorn", f"benchmarks.floors:{app}"]
    server.command += ["--host", "127.0.0.1", "--port", str(server.port), "--log-level", "warning"]
    server.start()
    try:
        yield server
    finally:
        server.stop()


@contextmanager
def tagwall_server(scratch: Path) -> Iterator[tuple[Any, str, str]]:
    """``tagwall serve`` on SQLite, the brain on the phones' wall: the server, the
    registration code and a placed pin."""
    from webapp.cli.testing import ServerProcess
    from webapp.database.migrate import upgrade

    database_url = f"sqlite:///{scratch / 'tagwall.db'}"
    upgrade(database_url)
    server = ServerProcess(
        var_dir=scratch / "var", database_url=database_url, secret=SECRET, extra_env=LIMIT_SETTINGS
    )
    server.start()
    try:
        with httpx.Client(timeout=120) as operator:
            server.change(PHONE_WALL, {"app": "brain"}, operator)
        codes = hall_codes(database_url)
        yield server, codes.register, codes.pins[0]
    finally:
        server.stop()


def run(requests: int = REQUESTS, rounds: int = ROUNDS, idle_s: float = IDLE_S) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="tagwall-steps-") as tmp, ExitStack() as stack:
        scratch = Path(tmp)
        starlette = stack.enter_context(floor_server("starlette_app", scratch))
        fastapi = stack.enter_context(floor_server("fastapi_app", scratch))
        tagwall, register, pin = stack.enter_context(tagwall_server(scratch))
        tagwall_pids = process_tree(tagwall.pid)
        idle = idle_rate(tagwall_pids, idle_s)
        bare = page(stack.enter_context(client(starlette.url)), "/healthz")
        floor = page(stack.enter_context(client(fastapi.url)), "/page")
        phone = stack.enter_context(client(tagwall.url))
        steps = phone_requests(register, pin, phone, stack.enter_context(client(tagwall.url)))
        starlette_ms: list[float] = []
        pairs: dict[str, list[tuple[float, float]]] = {name: [] for name in steps}
        for _ in range(rounds):
            starlette_ms.append(cpu_ms_per_request(process_tree(starlette.pid), bare, requests))
            for name, request in steps.items():
                # the floor just before each step: both at the machine's speed of the moment
                floor_ms = cpu_ms_per_request(process_tree(fastapi.pid), floor, requests)
                step_ms = cpu_ms_per_request(tagwall_pids, request, requests, idle)
                pairs[name].append((step_ms, floor_ms))
    return figures_of(pairs, starlette_ms, requests, idle)


def figures_of(
    pairs: dict[str, list[tuple[float, float]]],
    starlette_ms: list[float],
    requests: int,
    idle: float,
) -> dict[str, Any]:
    """Each step's median CPU per request, and its median ratio to the FastAPI floor
    measured just before it; the floors' medians."""
    floor_ms = [floor for measured in pairs.values() for _, floor in measured]
    steps = {
        name: {
            "server_cpu_ms": round(statistics.median(step for step, _ in measured), 3),
            "ratio": round(
                statistics.median(step / max(floor, 1e-6) for step, floor in measured), 2
            ),
            "rounds_ms": [round(step, 3) for step, _ in measured],
            "floors_ms": [round(floor, 3) for _, floor in measured],
        }
        for name, measured in pairs.items()
    }
    worst = max(steps[name]["ratio"] for name in PHONE_STEPS)
    return {
        "requests_per_step": requests,
        "rounds": len(starlette_ms),
        "database": "sqlite",
        "limit_settings": LIMIT_SETTINGS,
        "tagwall_idle_cpu_s_per_s": round(idle, 4),
        "floors": {
            "starlette": {
                "server_cpu_ms": round(statistics.median(starlette_ms), 3),
                "rounds_ms": [round(v, 3) for v in starlette_ms],
            },
            "fastapi_jinja": {"server_cpu_ms": round(statistics.median(floor_ms), 3)},
        },
        "steps": steps,
        "worst_ratio": worst,
        "target_ratio": TARGET_RATIO,
        "meets_target": worst <= TARGET_RATIO,
    }


def summary(result: dict[str, Any]) -> str:
    floors = result["floors"]
    steps = ", ".join(
        f"{name} {step['server_cpu_ms']:.2f} ms ({step['ratio']:.1f}x)"
        for name, step in result["steps"].items()
    )
    return (
        f"   server CPU per request: Starlette {floors['starlette']['server_cpu_ms']:.2f} ms, "
        f"FastAPI + Jinja {floors['fastapi_jinja']['server_cpu_ms']:.2f} ms (the floor); "
        f"{steps}; worst phone step {result['worst_ratio']:.1f}x (aim <= "
        f"{result['target_ratio']:.0f}x)"
    )
