"""Running and stopping asyncio tasks: what the bus, the hub and the app factory share."""

from __future__ import annotations

import asyncio
import functools
import inspect
import logging
import types
from collections.abc import Coroutine, Generator
from typing import Any

log = logging.getLogger(__name__)


def run_now(coroutine: Coroutine[Any, Any, None]) -> asyncio.Task[None] | None:
    """Run ``coroutine`` on the caller's turn up to its first wait: ``None`` when it
    finished there, otherwise a task that carries on from that wait (what Python 3.12's
    eager tasks do). Raises what the coroutine raised before waiting."""
    try:
        awaited = coroutine.send(None)
    except StopIteration:
        return None
    rest = asyncio.get_running_loop().create_task(_carry_on(coroutine, awaited))
    rest.add_done_callback(lambda _: _unwind(coroutine))
    return rest


def _unwind(coroutine: Coroutine[Any, Any, None]) -> None:
    """A task cancelled before its first step never resumed its coroutine: throw the
    cancellation in, so that its waits and locks let go of it."""
    if inspect.getcoroutinestate(coroutine) != inspect.CORO_SUSPENDED:  # it ran to its end
        return
    try:
        coroutine.throw(asyncio.CancelledError())
    except (asyncio.CancelledError, StopIteration):
        return
    except Exception:
        log.exception("a write abandoned by its task failed as it unwound")
        return
    coroutine.close()  # it waited again: abandon it there


async def _carry_on(coroutine: Coroutine[Any, Any, None], awaited: Any) -> None:
    await _resume(coroutine, awaited)


@types.coroutine
def _resume(coroutine: Coroutine[Any, Any, None], awaited: Any) -> Generator[Any, Any, None]:
    """Hand a started coroutine's waits to the task awaiting this, and its wake-ups
    (or cancellation) back to the coroutine, until it returns."""
    while True:
        try:
            yield awaited
        except BaseException as error:  # the task's cancellation, passed on
            resume = functools.partial(coroutine.throw, error)
        else:
            resume = functools.partial(coroutine.send, None)
        try:
            awaited = resume()
        except StopIteration:
            return


async def cancel_and_wait(*tasks: asyncio.Task[None]) -> None:
    """Cancel ``tasks`` and wait for them to end, cancelling again while one carries on:
    Python 3.11's ``asyncio.wait_for`` (which redis-py sends through) drops a
    cancellation that arrives as the send completes."""
    while pending := [task for task in tasks if not task.done()]:
        for task in pending:
            task.cancel()
        await asyncio.wait(pending, timeout=0.1)
    for task in tasks:
        if not task.cancelled():
            task.exception()  # retrieved: whoever awaited it has seen it
