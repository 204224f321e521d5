"""Kiosk launcher: browser commands, the plan, and the supervisor with fake browsers.

The fake browsers are small shell scripts. Each finds its ``--user-data-dir`` (the
per-display profile the supervisor creates) and appends its pid to ``launches`` there,
so tests can count starts per display. Waits poll against generous deadlines: these
tests must pass on a loaded two-core machine.
"""

from __future__ import annotations

import logging
import os
import re
import shlex
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from wall_client.kiosk import (
    KIOSK_FLAGS,
    KioskError,
    KioskSupervisor,
    RestartPolicy,
    find_browser,
    format_plan,
    kiosk_command,
    plan,
)
from wall_client.layout import Display, Rect, Rotation

DEADLINE = 10.0
URL = "http://wall.example:8000/tile/main/r1c1?token=a&b=c d"

FIND_PROFILE = """#!/bin/sh
for arg in "$@"; do
  case "$arg" in --user-data-dir=*) dir="${arg#--user-data-dir=}" ;; esac
done
printf '%s\\n' "$$" >> "$dir/launches"
"""

# Records its argv, starts a child (as Chromium does) and waits.
RECORDER = (
    FIND_PROFILE
    + """printf '%s\\n' "$@" > "$dir/argv"
sleep 1000 &
printf '%s\\n' "$!" > "$dir/child"
wait
"""
)
CRASHER = FIND_PROFILE + "exit 1\n"
# Ignores SIGTERM (its child inherits that), so only SIGKILL ends it.
STUBBORN = (
    FIND_PROFILE
    + """trap '' TERM
sleep 1000 &
printf '%s\\n' "$!" > "$dir/child"
wait
wait
"""
)


def make_display(
    display_id: str,
    index: int,
    *,
    origin: tuple[int, int] = (0, 0),
    resolution: tuple[int, int] = (1920, 1080),
    rotation: Rotation = 0,
) -> Display:
    return Display(
        id=display_id,
        rect=Rect(0.0, 0.0, 600.0, 340.0),
        resolution=resolution,
        rotation=rotation,
        node="node1",
        index=index,
        desktop_origin=origin,
    )


def write_script(path: Path, text: str) -> Path:
    path.write_text(text)
    path.chmod(0o755)
    return path


def wait_for(predicate: Callable[[], bool], what: str, timeout: float = DEADLINE) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.02)


def launches(profile: Path) -> list[int]:
    try:
        return [int(line) for line in (profile / "launches").read_text().split()]
    except FileNotFoundError:
        return []


def read_pid(path: Path) -> int | None:
    try:
        text = path.read_text().strip()
    except FileNotFoundError:
        return None
    return int(text) if text else None


def alive(pid: int) -> bool:
    """True while ``pid`` runs; zombies (which an init may never reap) count as gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")


def commands_for(
    browser: Path, profile_root: Path, ids: tuple[str, ...] = ("r1c1",)
) -> list[tuple[str, list[str]]]:
    displays = [make_display(d, i, origin=(1920 * i, 0)) for i, d in enumerate(ids)]
    urls = {d: f"http://wall.example/tile/{d}" for d in ids}
    return plan(displays, urls, browser=str(browser), profile_root=profile_root)


@contextmanager
def supervising(supervisor: KioskSupervisor) -> Iterator[threading.Thread]:
    """Run the supervisor in a thread; stop it and check run() returned on exit."""
    errors: list[BaseException] = []

    def target() -> None:
        try:
            supervisor.run()
        except BaseException as error:
            errors.append(error)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    try:
        yield thread
    finally:
        supervisor.stop()
        thread.join(DEADLINE)
        assert not thread.is_alive(), "run() did not return after stop()"
    assert not errors, errors


def restart_delays(caplog: pytest.LogCaptureFixture, display_id: str) -> list[float]:
    pattern = re.compile(rf"^{display_id}: browser .*restarting (?:in|every) ([0-9.]+) s")
    delays = []
    for record in list(caplog.records):
        match = pattern.match(record.getMessage())
        if match:
            delays.append(float(match.group(1)))
    return delays


# -- commands -----------------------------------------------------------------------


def test_kiosk_command_places_window_and_ends_with_url(tmp_path: Path) -> None:
    # Rotated panels still get their native size: the page rotates, not the OS.
    display = make_display("r1c2", 1, origin=(1920, 0), resolution=(1920, 1080), rotation=90)
    argv = kiosk_command(display, URL, browser="/usr/bin/chromium", profile_dir=tmp_path / "p")

    assert argv[0] == "/usr/bin/chromium"
    assert argv[-1] == URL
    assert "--window-position=1920,0" in argv
    assert "--window-size=1920,1080" in argv
    assert f"--user-data-dir={tmp_path / 'p'}" in argv
    for flag in KIOSK_FLAGS:
        assert flag in argv
    for flag in (
        "--kiosk",
        "--no-first-run",
        "--no-default-browser-check",
        "--disable-session-crashed-bubble",
        "--hide-crash-restore-bubble",
        "--disable-infobars",
        "--noerrdialogs",
        "--disable-features=Translate",
        "--disable-background-timer-throttling",
        "--disable-backgrounding-occluded-windows",
        "--disable-renderer-backgrounding",
        "--autoplay-policy=no-user-gesture-required",
        "--check-for-update-interval=31536000",
    ):
        assert flag in argv
    assert all(arg.startswith("--") for arg in argv[1:-1])


def test_plan_orders_by_display_index_with_a_profile_each(tmp_path: Path) -> None:
    displays = (
        make_display("r1c3", 2, origin=(3840, 0)),
        make_display("r1c1", 0),
        make_display("r1c2", 1, origin=(1920, 0)),
    )
    urls = {d.id: f"http://wall.example/tile/{d.id}" for d in displays}
    commands = plan(displays, urls, browser="chromium", profile_root=tmp_path / "kiosk")

    assert [display_id for display_id, _ in commands] == ["r1c1", "r1c2", "r1c3"]
    for display_id, argv in commands:
        assert argv[-1] == urls[display_id]
        assert f"--user-data-dir={tmp_path / 'kiosk' / display_id}" in argv
    assert "--window-position=3840,0" in commands[2][1]
    assert not (tmp_path / "kiosk").exists(), "planning (a dry run) must not touch the disk"


def test_plan_without_url_for_a_display_fails(tmp_path: Path) -> None:
    displays = (make_display("r1c1", 0), make_display("r1c2", 1))
    with pytest.raises(KioskError, match="r1c2"):
        plan(displays, {"r1c1": URL}, browser="chromium", profile_root=tmp_path)


def test_format_plan_is_shell_quoted(tmp_path: Path) -> None:
    profile_root = tmp_path / "kiosk profiles"
    commands = plan(
        (make_display("r1c1", 0),), {"r1c1": URL}, browser="chromium", profile_root=profile_root
    )
    (line,) = format_plan(commands)

    display_id, _, command = line.partition(": ")
    assert display_id == "r1c1"
    assert shlex.split(command) == commands[0][1]
    assert shlex.split(command)[-1] == URL


# -- finding a browser --------------------------------------------------------------


def test_find_browser_on_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    write_script(bin_dir / "google-chrome", "#!/bin/sh\n")
    write_script(bin_dir / "chromium", "#!/bin/sh\n")
    monkeypatch.setenv("PATH", str(bin_dir))

    assert find_browser() == str(bin_dir / "chromium")
    assert find_browser(("google-chrome",)) == str(bin_dir / "google-chrome")


def test_find_browser_without_one_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))

    with pytest.raises(KioskError, match="install Chromium") as caught:
        find_browser()
    assert "--browser" in str(caught.value)


# -- restart policy -----------------------------------------------------------------


def test_restart_policy_doubles_up_to_the_cap_and_resets_after_a_stable_run() -> None:
    policy = RestartPolicy(initial=1.0, maximum=8.0, window=60.0, limit=100)
    delays = [policy.after_exit(started_at=t, now=t + 0.5)[0] for t in range(5)]
    assert delays == [1.0, 2.0, 4.0, 8.0, 8.0]

    delay, looping = policy.after_exit(started_at=100.0, now=200.0)  # ran 100 s
    assert (delay, looping) == (1.0, False)
    assert policy.after_exit(started_at=201.0, now=202.0) == (2.0, False)


def test_restart_policy_flags_a_crash_loop_and_recovers_when_exits_age_out() -> None:
    policy = RestartPolicy(initial=0.1, maximum=30.0, window=60.0, limit=3)
    results = [policy.after_exit(started_at=float(t), now=t + 0.1) for t in range(5)]
    assert [looping for _, looping in results] == [False, False, False, True, True]
    assert [delay for delay, looping in results if looping] == [30.0, 30.0]

    # Long after: the old exits left the window (no stable run needed to leave the loop).
    assert policy.after_exit(started_at=100.0, now=130.0)[1] is False


# -- supervisor ---------------------------------------------------------------------


def test_supervisor_starts_every_browser_and_stop_ends_them(tmp_path: Path) -> None:
    browser = write_script(tmp_path / "chromium", RECORDER)
    root = tmp_path / "profiles"
    commands = commands_for(browser, root, ("r1c1", "r1c2", "r1c3"))
    supervisor = KioskSupervisor(commands, poll_interval=0.02, grace_period=5.0)

    with supervising(supervisor) as thread:
        wait_for(
            lambda: all(read_pid(root / d / "child") for d, _ in commands), "every browser to start"
        )
        for display_id, argv in commands:
            assert (root / display_id / "argv").read_text().splitlines() == argv[1:]
        pids = [launches(root / d)[0] for d, _ in commands]
        children = [read_pid(root / d / "child") for d, _ in commands]
        assert all(alive(pid) for pid in pids)
        supervisor.stop()
        thread.join(DEADLINE)
        assert not thread.is_alive()

    for pid in [*pids, *children]:
        assert pid is not None and not alive(pid), f"process {pid} survived stop()"
    assert all(len(launches(root / d)) == 1 for d, _ in commands)


def test_stop_kills_browsers_that_ignore_sigterm(tmp_path: Path) -> None:
    browser = write_script(tmp_path / "chromium", STUBBORN)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(commands_for(browser, root), poll_interval=0.02, grace_period=0.3)

    with supervising(supervisor):
        wait_for(lambda: read_pid(root / "r1c1" / "child") is not None, "the browser to start")
        leader, child = launches(root / "r1c1")[0], read_pid(root / "r1c1" / "child")
    assert child is not None
    assert not alive(leader)
    # The leader is reaped; the group's SIGKILL reaches the orphaned child asynchronously.
    wait_for(lambda: not alive(child), "the stubborn child to die", timeout=2.0)


def test_crashing_browser_restarts_with_growing_backoff(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="tagwall.kiosk")
    browser = write_script(tmp_path / "chromium", CRASHER)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(
        commands_for(browser, root),
        backoff_initial=0.05,
        backoff_max=0.4,
        crash_limit=1000,
        poll_interval=0.01,
    )

    started = time.monotonic()
    with supervising(supervisor):
        wait_for(lambda: len(restart_delays(caplog, "r1c1")) >= 6, "six restarts", 20.0)
        elapsed = time.monotonic() - started

    delays = restart_delays(caplog, "r1c1")
    assert delays[:6] == [0.05, 0.1, 0.2, 0.4, 0.4, 0.4]
    assert elapsed >= sum(delays[:5])  # the backoff really waited (a lower bound only)
    assert len(launches(root / "r1c1")) >= 6
    assert "r1c1: browser exited with code 1; restarting in 0.05 s" in caplog.messages


def test_crash_loop_is_reported_and_retried_at_the_maximum_backoff(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="tagwall.kiosk")
    browser = write_script(tmp_path / "chromium", CRASHER)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(
        commands_for(browser, root),
        backoff_initial=0.01,
        backoff_max=0.05,
        crash_window=60.0,
        crash_limit=2,
        poll_interval=0.01,
    )

    def loop_errors() -> list[logging.LogRecord]:
        return [
            r
            for r in list(caplog.records)
            if r.levelno == logging.ERROR and "crash loop" in r.getMessage()
        ]

    with supervising(supervisor):
        wait_for(lambda: len(loop_errors()) >= 3, "the crash loop to be reported, repeatedly")
        wait_for(lambda: len(launches(root / "r1c1")) >= 6, "retries to continue")

    first = loop_errors()[0].getMessage()
    assert first.startswith("r1c1: browser exited with code 1; it exited 3 times within 60.0 s")
    assert "restarting every 0.05 s" in first
    assert restart_delays(caplog, "r1c1")[:5] == [0.01, 0.02, 0.05, 0.05, 0.05]


def test_browser_killed_from_outside_is_restarted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="tagwall.kiosk")
    browser = write_script(tmp_path / "chromium", RECORDER)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(
        commands_for(browser, root), backoff_initial=0.05, poll_interval=0.02
    )

    with supervising(supervisor):
        wait_for(lambda: len(launches(root / "r1c1")) == 1, "the browser to start")
        first = launches(root / "r1c1")[0]
        os.kill(first, signal.SIGKILL)
        wait_for(lambda: len(launches(root / "r1c1")) == 2, "the browser to restart")
        assert alive(launches(root / "r1c1")[1])

    assert "r1c1: browser was killed by signal SIGKILL; restarting in 0.05 s" in caplog.messages


def test_missing_browser_is_retried_not_fatal(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="tagwall.kiosk")
    supervisor = KioskSupervisor(
        commands_for(tmp_path / "no-such-browser", tmp_path / "profiles"),
        backoff_initial=0.01,
        backoff_max=0.02,
        poll_interval=0.01,
    )

    def failures() -> int:
        return sum("could not start browser" in message for message in list(caplog.messages))

    with supervising(supervisor):
        wait_for(lambda: failures() >= 3, "repeated start attempts")
    assert (tmp_path / "profiles" / "r1c1").is_dir()


def test_stop_before_run_makes_run_return_at_once(tmp_path: Path) -> None:
    browser = write_script(tmp_path / "chromium", RECORDER)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(commands_for(browser, root), poll_interval=0.02)
    supervisor.stop()
    supervisor.run()
    assert launches(root / "r1c1") == []


def test_sigterm_stops_run_in_the_main_thread(tmp_path: Path) -> None:
    assert threading.current_thread() is threading.main_thread()
    browser = write_script(tmp_path / "chromium", RECORDER)
    root = tmp_path / "profiles"
    supervisor = KioskSupervisor(commands_for(browser, root), poll_interval=0.02)
    before = signal.getsignal(signal.SIGTERM)

    def send_sigterm() -> None:
        # Handlers are installed before the first launch, so this cannot kill pytest.
        try:
            wait_for(lambda: read_pid(root / "r1c1" / "child") is not None, "the browser")
        finally:  # without a started browser, still end run(); the asserts below fail
            os.kill(os.getpid(), signal.SIGTERM)

    sender = threading.Thread(target=send_sigterm, daemon=True)
    sender.start()
    supervisor.run()  # returns once SIGTERM arrives
    sender.join(DEADLINE)

    assert signal.getsignal(signal.SIGTERM) is before
    leader, child = launches(root / "r1c1")[0], read_pid(root / "r1c1" / "child")
    assert child is not None
    assert not alive(leader)
    # The leader is reaped; the group's SIGKILL reaches the orphaned child asynchronously.
    wait_for(lambda: not alive(child), "the stubborn child to die", timeout=2.0)


def test_supervisor_rejects_bad_settings() -> None:
    with pytest.raises(ValueError):
        KioskSupervisor([])
    with pytest.raises(ValueError):
        KioskSupervisor([("r1c1", ["chromium"])], backoff_initial=5.0, backoff_max=1.0)
