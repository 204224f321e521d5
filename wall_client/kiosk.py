"""Kiosk launcher: one full-screen Chromium per display of a render node, kept alive.

A wall runs unattended, so the launcher's job is less starting browsers than keeping
them up: every display gets its own browser process (own profile, so instances do not
merge into one), placed on its monitor by window position and size, and a supervisor
restarts any that exit. Restarts back off (doubling, capped) so a browser that cannot
start does not spin the CPU, and a display stuck in a crash loop is reported loudly
but never abandoned: the wall should heal by itself once the cause is fixed.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any

from wall_client.layout import Display

BROWSER_CANDIDATES: tuple[str, ...] = (
    "chromium",
    "chromium-browser",
    "google-chrome",
    "google-chrome-stable",
)

# Flags for every kiosk browser. Nobody stands at a wall with a keyboard, so anything
# that waits for a click, pauses work in the background or changes the page is off.
KIOSK_FLAGS: tuple[str, ...] = (
    # Full screen, no tabs, address bar or window chrome.
    "--kiosk",
    # No welcome page or "make Chromium your default browser" prompt on a fresh profile.
    "--no-first-run",
    "--no-default-browser-check",
    # After a crash or power cut, no "restore pages?" bubble covering the tile.
    "--disable-session-crashed-bubble",
    "--hide-crash-restore-bubble",
    # No info bars ("controlled by automated software", unsupported flag warnings).
    "--disable-infobars",
    # No modal error dialogs that would wait forever for someone to press OK.
    "--noerrdialogs",
    # No "translate this page?" bar (older and newer spelling of the switch).
    "--disable-translate",
    "--disable-features=Translate",
    # Tiles animate in sync with the rest of the wall: keep timers, rendering and
    # requestAnimationFrame at full speed even when Chromium thinks the window is hidden
    # or occluded (kiosk windows on other monitors often look that way to it).
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--disable-renderer-backgrounding",
    # Scenes may play video with sound; nobody is there to click "play".
    "--autoplay-policy=no-user-gesture-required",
    # Updates are the operator's business; no update checks or nags (one year).
    "--check-for-update-interval=31536000",
    # No "unlock your keyring" dialog on desktops with a keyring: it would block the tile.
    "--password-store=basic",
)

# How long stop() lets browsers shut down after SIGTERM before killing them.
DEFAULT_GRACE_PERIOD = 5.0

log = logging.getLogger("tagwall.kiosk")


class KioskError(RuntimeError):
    """The kiosk cannot be launched as asked (no browser, a display without URL)."""


def find_browser(candidates: Sequence[str] = BROWSER_CANDIDATES) -> str:
    """The first candidate browser on PATH, so ``tagwall kiosk`` works without --browser."""
    for name in candidates:
        path = shutil.which(name)
        if path:
            return path
    raise KioskError(
        f"no Chromium browser found on PATH (looked for {', '.join(candidates)}); "
        "install Chromium (e.g. `apt install chromium`) or Google Chrome, "
        "or pass --browser /path/to/browser"
    )


def kiosk_command(display: Display, url: str, *, browser: str, profile_dir: Path) -> list[str]:
    """The argv that shows ``url`` full screen on ``display``.

    The window is placed at the display's desktop origin with its native size, so kiosk
    mode goes full screen on that monitor; the page, not the OS, handles rotation.
    """
    x, y = display.desktop_origin
    width, height = display.resolution
    return [
        browser,
        *KIOSK_FLAGS,
        f"--window-position={x},{y}",
        f"--window-size={width},{height}",
        # Own profile per display: with a shared one, Chromium hands the URL to the
        # running instance and exits, and every tile would land in one window.
        f"--user-data-dir={profile_dir}",
        url,
    ]


def plan(
    displays: Sequence[Display],
    urls: Mapping[str, str],
    *,
    browser: str,
    profile_root: Path,
) -> list[tuple[str, list[str]]]:
    """One ``(display_id, argv)`` per display, in display-index order (primary first)."""
    missing = [display.id for display in displays if display.id not in urls]
    if missing:
        raise KioskError(f"no tile URL for display(s): {', '.join(missing)}")
    ordered = sorted(displays, key=lambda display: (display.index, display.id))
    return [
        (
            display.id,
            kiosk_command(
                display, urls[display.id], browser=browser, profile_dir=profile_root / display.id
            ),
        )
        for display in ordered
    ]


def format_plan(commands: Sequence[tuple[str, Sequence[str]]]) -> list[str]:
    """Printable, shell-quoted commands, so a dry run can be pasted into a shell."""
    return [f"{display_id}: {shlex.join(argv)}" for display_id, argv in commands]


@dataclass
class RestartPolicy:
    """When to restart one display's browser: doubling backoff plus a crash-loop guard.

    The backoff resets once a browser has run for ``window`` seconds, so a crash after
    days of service restarts quickly. More than ``limit`` exits within ``window`` is a
    crash loop: restarts continue, but only every ``maximum`` seconds.
    """

    initial: float
    maximum: float
    window: float
    limit: int
    delay: float = field(init=False)
    exits: deque[float] = field(init=False, default_factory=deque)

    def __post_init__(self) -> None:
        self.delay = self.initial

    def after_exit(self, started_at: float, now: float) -> tuple[float, bool]:
        """Seconds to wait before the next start, and whether this is a crash loop."""
        if now - started_at >= self.window:
            self.delay = self.initial
        self.exits.append(now)
        while self.exits and self.exits[0] < now - self.window:
            self.exits.popleft()
        looping = len(self.exits) > self.limit
        delay = self.maximum if looping else self.delay
        self.delay = min(self.delay * 2, self.maximum)
        return delay, looping


@dataclass
class _Browser:
    """One display's browser under supervision."""

    display_id: str
    argv: list[str]
    policy: RestartPolicy
    process: subprocess.Popen[bytes] | None = None
    started_at: float = 0.0
    start_at: float = -math.inf  # clock time of the next (re)start


class KioskSupervisor:
    """Runs one browser per display and restarts any that exit, until stopped.

    ``run()`` blocks; ``stop()`` (from another thread, or SIGTERM/SIGINT when ``run()``
    is in the main thread) makes it terminate every browser and return. ``clock`` and
    ``sleep`` are injectable for tests; by default ``sleep`` is an interruptible wait
    that ``stop()`` cuts short.
    """

    def __init__(
        self,
        commands: Sequence[tuple[str, Sequence[str]]],
        *,
        backoff_initial: float = 1.0,
        backoff_max: float = 30.0,
        crash_window: float = 60.0,
        crash_limit: int = 5,
        poll_interval: float = 0.5,
        grace_period: float = DEFAULT_GRACE_PERIOD,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], object] | None = None,
    ) -> None:
        if not commands:
            raise ValueError("no browsers to supervise")
        if not 0 < backoff_initial <= backoff_max:
            raise ValueError("need 0 < backoff_initial <= backoff_max")
        if crash_window <= 0 or crash_limit < 1 or poll_interval <= 0 or grace_period < 0:
            raise ValueError("need crash_window, poll_interval > 0, crash_limit >= 1, grace >= 0")
        self._browsers = [
            _Browser(
                display_id,
                list(argv),
                RestartPolicy(backoff_initial, backoff_max, crash_window, crash_limit),
            )
            for display_id, argv in commands
        ]
        self._poll_interval = poll_interval
        self._grace_period = grace_period
        self._clock = clock
        self._wake = threading.Event()
        self._sleep: Callable[[float], object] = sleep or self._wake.wait
        # A plain flag, not only the event: signal handlers must not take locks.
        self._stop_requested = False
        self._stop_signal: int | None = None
        self._lock = threading.Lock()
        self._running = False
        self._run_thread: int | None = None
        self._done = threading.Event()

    def run(self) -> None:
        """Start every browser and keep them running until ``stop()``; then end them all."""
        with self._lock:
            if self._running:
                raise RuntimeError("KioskSupervisor.run() is already running")
            self._running = True
            self._run_thread = threading.get_ident()
            self._done.clear()
        previous = self._install_signal_handlers()
        try:
            while not self._stop_requested:
                for browser in self._browsers:
                    if self._stop_requested:
                        break
                    self._tend(browser)
                self._sleep(self._poll_interval)
            if self._stop_signal is not None:
                log.info("received %s", signal.Signals(self._stop_signal).name)
        finally:
            try:
                self._terminate_all()
            finally:
                self._restore_signal_handlers(previous)
                with self._lock:
                    self._running = False
                    self._run_thread = None
                self._done.set()

    def stop(self) -> None:
        """End supervision: ``run()`` terminates every browser and returns.

        Called from another thread, waits until the browsers are gone. A supervisor
        stopped before ``run()`` makes ``run()`` return at once.
        """
        self._stop_requested = True
        self._wake.set()
        with self._lock:
            running = self._running
            own_thread = self._run_thread == threading.get_ident()
            if not running:
                self._terminate_all()
        if running and not own_thread:
            self._done.wait(self._grace_period + 10.0)

    def _tend(self, browser: _Browser) -> None:
        """Start a browser that is due, or notice one that exited and schedule it."""
        now = self._clock()
        if browser.process is None:
            if now >= browser.start_at:
                self._start(browser, now)
            return
        if not _leader_exited(browser.process):
            return
        code = _reap(browser.process)
        browser.process = None
        delay, looping = browser.policy.after_exit(browser.started_at, now)
        browser.start_at = now + delay
        how = _describe_exit(code)
        if looping:
            log.error(
                "%s: browser %s; it exited %d times within %s s (crash loop): "
                "restarting every %s s until it stays up; check that the tile URL is "
                "reachable and that the browser starts when run by hand (tagwall kiosk "
                "--dry-run prints the command)",
                browser.display_id,
                how,
                len(browser.policy.exits),
                _seconds(browser.policy.window),
                _seconds(delay),
            )
        else:
            log.warning(
                "%s: browser %s; restarting in %s s", browser.display_id, how, _seconds(delay)
            )

    def _start(self, browser: _Browser, now: float) -> None:
        """Launch a browser in its own session, so stopping it reaches its children too."""
        browser.started_at = now
        try:
            profile = _profile_dir(browser.argv)
            if profile is not None:
                profile.mkdir(parents=True, exist_ok=True)
            browser.process = subprocess.Popen(
                browser.argv, stdin=subprocess.DEVNULL, start_new_session=True
            )
        except OSError as error:
            delay, _ = browser.policy.after_exit(now, now)
            browser.start_at = now + delay
            log.error(
                "%s: could not start browser %s: %s; retrying in %s s",
                browser.display_id,
                browser.argv[0],
                error,
                _seconds(delay),
            )
            return
        log.info("%s: started browser (pid %d)", browser.display_id, browser.process.pid)

    def _terminate_all(self) -> None:
        """SIGTERM every browser's process group, then SIGKILL what outlives the grace."""
        processes = [b.process for b in self._browsers if b.process is not None]
        for browser in self._browsers:
            browser.process = None
        if not processes:
            return
        log.info("stopping %d browser(s)", len(processes))
        for process in processes:
            if not _leader_exited(process):
                _signal_group(process.pid, signal.SIGTERM)
        deadline = time.monotonic() + self._grace_period
        while time.monotonic() < deadline and not all(_leader_exited(p) for p in processes):
            time.sleep(0.05)
        for process in processes:
            _reap(process)

    def _install_signal_handlers(self) -> dict[int, Any]:
        """Make SIGTERM (systemd stop) and SIGINT (Ctrl-C) end run() cleanly."""
        if threading.current_thread() is not threading.main_thread():
            return {}

        def handle(signum: int, frame: FrameType | None) -> None:
            self._stop_signal = signum  # logged by run(): no logging (locks) in a handler
            self._stop_requested = True

        previous: dict[int, Any] = {}
        for signum in (signal.SIGTERM, signal.SIGINT):
            previous[signum] = signal.signal(signum, handle)
        return previous

    @staticmethod
    def _restore_signal_handlers(previous: dict[int, Any]) -> None:
        for signum, handler in previous.items():
            if handler is not None:
                signal.signal(signum, handler)


def _profile_dir(argv: Sequence[str]) -> Path | None:
    """The ``--user-data-dir`` of a browser command, to create before launching."""
    prefix = "--user-data-dir="
    for arg in argv:
        if arg.startswith(prefix):
            return Path(arg[len(prefix) :])
    return None


def _leader_exited(process: subprocess.Popen[bytes]) -> bool:
    """Whether the browser's main process has exited, without reaping it.

    An unreaped (zombie) leader keeps its pid, and so its process group id, reserved:
    the group can then be killed without hitting an unrelated process.
    """
    if process.returncode is not None:
        return True
    if sys.platform != "linux":
        return process.poll() is not None
    try:
        result = os.waitid(os.P_PID, process.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:
        return process.poll() is not None
    return result is not None


def _reap(process: subprocess.Popen[bytes]) -> int:
    """Kill whatever is left of the browser's process group and collect its exit code."""
    if process.returncode is not None:  # reaped already: its group id may be reused
        return process.returncode
    _signal_group(process.pid, signal.SIGKILL)
    return process.wait()


def _signal_group(pgid: int, signum: signal.Signals) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):  # group already gone
        os.killpg(pgid, signum)


def _describe_exit(code: int) -> str:
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = str(-code)
        return f"was killed by signal {name}"
    return f"exited with code {code}"


def _seconds(value: float) -> str:
    """Seconds for log lines: ``2.0``, ``30.0``, and short delays such as ``0.05``."""
    return f"{value:.1f}" if value >= 1 else f"{value:.2g}"
