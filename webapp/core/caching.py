"""A bounded cache of rendered things (tile images, tile map views) by what made them."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

T = TypeVar("T")

IMMUTABLE = "public, max-age=31536000, immutable"
"""Cache-Control for what is named by its content (code images, placed layouts):
the name changes whenever the content would."""


def _one(_: object) -> int:
    return 1


class SizedCache(Generic[T]):
    """Entries by key, least recently used dropped first once their sizes pass
    ``max_size`` (bytes, or by default a count): a reloaded tile, the overview and
    several viewers ask for the same renders, a class's phones for the same hints,
    which cost far more to make than to keep. Safe to share between threads."""

    def __init__(self, max_size: int, size: Callable[[T], int] = _one) -> None:
        self.max_size = max_size
        self._size = size
        self._entries: OrderedDict[Hashable, T] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()

    def get(self, key: Hashable) -> T | None:
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
            return entry

    def put(self, key: Hashable, entry: T) -> None:
        with self._lock:
            if key in self._entries:
                return
            self._entries[key] = entry
            self._bytes += self._size(entry)
            while self._bytes > self.max_size and self._entries:
                _, dropped = self._entries.popitem(last=False)
                self._bytes -= self._size(dropped)
