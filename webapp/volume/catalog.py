"""The volumes this server can show: the stores under one directory, opened once."""

from __future__ import annotations

from pathlib import Path

from webapp.core.caching import SizedCache
from webapp.volume.store import META_FILE, VolumeStore
from webapp.volume.tiles import EncodedTile

RENDER_CACHE_BYTES = 64 * 1024 * 1024


class VolumeCatalog:
    """Stores by name (their directory's name); each is opened on first use and kept,
    with its decoded-brick cache, for the life of the process."""

    def __init__(self, directory: Path, *, cache_voxels: int) -> None:
        self.directory = directory
        self.cache_voxels = cache_voxels
        self._open: dict[str, VolumeStore] = {}
        self.renders = SizedCache[EncodedTile](RENDER_CACHE_BYTES, lambda e: len(e.body))

    def names(self) -> list[str]:
        """The stores present now (a store built while running appears at once)."""
        if not self.directory.is_dir():
            return []
        return sorted(p.name for p in self.directory.iterdir() if (p / META_FILE).is_file())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def get(self, name: str) -> VolumeStore:
        """The store called ``name``; KeyError when there is none, VolumeStoreError
        when it cannot be read. A store rebuilt since it was opened is reopened."""
        path = self.directory / name
        if name not in self:
            self._open.pop(name, None)
            raise KeyError(name)
        store = self._open.get(name)
        stamp = (path / META_FILE).stat().st_mtime_ns
        if store is None or store.stamp != stamp:
            store = VolumeStore(path, cache_voxels=self.cache_voxels)
            self._open[name] = store
        return store
