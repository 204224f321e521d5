"""The one way to run blocking work (a database round trip, a render, a password hash)
off the event loop.

:func:`run_blocking` hands the call to a worker thread of the shared pool, so the loop
keeps serving other connections meanwhile. Work that must not queue behind a lecture
hall's page requests, or that must not run too many at once, waits for a limiter of its
own (:func:`run_blocking_within`): the walls' changes (``WallHub.run_sync``) and the
sign-ins' password checks. The one exception is :meth:`Database.read
<webapp.database.connection.Database.read>`, which runs a phone's short read inline on
SQLite, where a tenth of a millisecond costs less than the hand-off to a thread.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import ParamSpec, TypeVar

from anyio import CapacityLimiter, to_thread

P = ParamSpec("P")
T = TypeVar("T")


async def run_blocking(function: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
    """``function(*args, **kwargs)`` in a worker thread of the shared pool."""
    return await to_thread.run_sync(partial(function, *args, **kwargs))


async def run_blocking_within(
    limiter: CapacityLimiter, function: Callable[P, T], *args: P.args, **kwargs: P.kwargs
) -> T:
    """Like :func:`run_blocking`, among at most the limiter's number at once."""
    return await to_thread.run_sync(partial(function, *args, **kwargs), limiter=limiter)
