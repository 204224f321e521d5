"""The image store: pyramids of the right shape, and nothing kept of a refused input."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
import pyvips
from PIL import Image

from tests.webapp.apps.image.samples import FOREIGN, png_declaring, quadrants, save
from webapp.apps.image.store import (
    LOCK,
    STALE_S,
    TILE_SIZE,
    ImageRefused,
    ImageStore,
    NoLibvips,
    deep_zoom_levels,
)


@pytest.fixture
def store(tmp_path: Path) -> ImageStore:
    return ImageStore(tmp_path / "images")


@pytest.mark.parametrize("suffix,kind", [(".png", "PNG"), (".jpg", "JPEG"), (".tif", "TIFF")])
def test_an_image_becomes_a_deep_zoom_pyramid(
    store: ImageStore, tmp_path: Path, suffix: str, kind: str
) -> None:
    source = save(tmp_path / f"scan{suffix}", quadrants(700, 300))
    added = store.add(source, title="A scan")
    assert (added.title, added.width, added.height, added.format) == ("A scan", 700, 300, kind)
    assert added.levels == deep_zoom_levels(700, 300) == 11  # 1 px .. 1024 px
    assert store.images() == [added] and store.get(added.id) == added
    folder = store.root / added.id / "pyramid_files"
    for level in range(added.levels):
        cols, rows = added.tile_grid(level)
        shrink = 2 ** (added.levels - 1 - level)
        assert (cols, rows) == (
            math.ceil(math.ceil(700 / shrink) / TILE_SIZE),
            math.ceil(math.ceil(300 / shrink) / TILE_SIZE),
        )
        tiles = sorted(p.name for p in (folder / str(level)).glob("*.jpg"))
        assert len(tiles) == cols * rows, level
    assert (cols, rows) == (2, 1)  # the full size: 512 + 188 by 300
    with Image.open(store.tile(added.id, 10, 1, 0)) as corner:
        assert corner.size == (700 - 512, 300)
        red, green, blue = corner.getpixel((150, 280))
    assert red > 230 and green > 230 and blue > 180  # the bottom-right of the image


def test_the_title_defaults_to_the_file_name_and_tiles_outside_are_unknown(
    store: ImageStore, tmp_path: Path
) -> None:
    added = store.add(save(tmp_path / "cells.png", quadrants(40, 30)))
    assert added.title == "cells" and added.source == "cells.png"
    for outside in [(added.levels, 0, 0), (5, 1, 0), (-1, 0, 0)]:
        with pytest.raises(KeyError):
            store.tile(added.id, *outside)
    with pytest.raises(KeyError):
        store.get("../../etc")


def _truncated(path: Path) -> Path:
    save(path, quadrants(400, 300))
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    return path


@pytest.mark.parametrize(
    "make,message",
    [
        (lambda d: _truncated(d / "half.jpg"), r"half\.jpg is damaged or truncated"),
        (lambda d: _truncated(d / "half.png"), r"half\.png is damaged or truncated"),
        (
            lambda d: (d / "notes.png").write_text("not an image") and d / "notes.png",
            r"notes\.png is not a PNG, JPEG or TIFF image",
        ),
        (lambda d: (d / "empty.jpg").write_bytes(b"") or d / "empty.jpg", r"empty\.jpg is empty"),
        (
            lambda d: save(d / "anim.gif", quadrants(20, 20)),
            r"anim\.gif is not a PNG, JPEG or TIFF",
        ),
        (lambda d: png_declaring(d / "zero.png", 0, 0), r"zero\.png is not a PNG|has no pixels"),
        (
            lambda d: png_declaring(d / "bomb.png", 100_000, 100_000),
            r"bomb\.png declares 100000 x 100000 px \(1e\+10 pixels\), more than the 1\.2e\+09",
        ),
    ],
    ids=["truncated-jpeg", "truncated-png", "text", "empty", "gif", "zero", "bomb"],
)
def test_a_bad_input_is_refused_in_one_line_and_nothing_is_kept(
    store: ImageStore, tmp_path: Path, make: object, message: str
) -> None:
    assert callable(make)
    source = make(tmp_path)
    with pytest.raises(ImageRefused, match=message) as refused:
        store.add(source)
    assert "\n" not in str(refused.value)
    assert store.images() == []
    assert not store.root.exists() or list(store.root.iterdir()) == []  # no orphan pyramid


@pytest.fixture
def operations(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The libvips operations called from now on, by name (every loader is one)."""
    called: list[str] = []
    call = pyvips.Operation.call

    def recorded(name: str, *args: object, **kwargs: object) -> object:
        called.append(name)
        return call(name, *args, **kwargs)

    monkeypatch.setattr(pyvips.Operation, "call", staticmethod(recorded))
    return called


@pytest.mark.parametrize("name", sorted(FOREIGN))
def test_an_svg_pdf_or_postscript_under_an_images_name_reaches_no_decoder(
    store: ImageStore, tmp_path: Path, name: str, operations: list[str]
) -> None:
    """Its first bytes are no PNG's, JPEG's or TIFF's: refused before libvips is asked
    (librsvg, poppler and ImageMagick parse what they are given, and have had holes)."""
    source = tmp_path / name
    source.write_bytes(FOREIGN[name])
    with pytest.raises(ImageRefused, match=rf"^{name} is not a PNG, JPEG or TIFF image\.$"):
        store.add(source)
    assert operations == []
    assert not store.root.exists() or list(store.root.iterdir()) == []


@pytest.mark.parametrize(
    "suffix,loader", [(".png", "pngload"), (".jpg", "jpegload"), (".tif", "tiffload")]
)
def test_each_format_is_read_by_its_own_loader_only(
    store: ImageStore, tmp_path: Path, suffix: str, loader: str, operations: list[str]
) -> None:
    store.probe(save(tmp_path / f"scan{suffix}", quadrants(40, 30)), f"scan{suffix}")
    assert [name for name in operations if "load" in name.lower()] == [loader]


def test_no_other_libvips_loader_runs_in_a_server_that_adds_images(
    store: ImageStore, tmp_path: Path
) -> None:
    """Whatever asks libvips for a file in the process once the store has, by guessing
    the loader or naming it, gets nothing from librsvg, poppler or ImageMagick: only
    the three loaders are left (the PDFs slides come from are rendered elsewhere,
    never by libvips)."""
    store.probe(save(tmp_path / "scan.png", quadrants(40, 30)), "scan.png")
    loaders = {"drawing.png": "svgload", "slides.png": "pdfload", "poster.png": "magickload"}
    for name, data in FOREIGN.items():
        path = str(tmp_path / name)
        (tmp_path / name).write_bytes(data)
        with pytest.raises(pyvips.Error, match="operation is blocked"):
            pyvips.Image.new_from_file(path)
        with pytest.raises(pyvips.Error, match="operation is blocked"):
            getattr(pyvips.Image, loaders[name])(path)


def test_a_libvips_that_cannot_block_its_other_loaders_adds_nothing(
    store: ImageStore, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(pyvips, "at_least_libvips", lambda major, minor: False)
    with pytest.raises(NoLibvips, match=r"libvips 8\.13 or later is needed"):
        store.add(save(tmp_path / "scan.png", quadrants(40, 30)))
    assert not store.root.exists() or list(store.root.iterdir()) == []


def test_what_a_killed_build_left_is_swept_once_stale(store: ImageStore, tmp_path: Path) -> None:
    kept = store.add(save(tmp_path / "kept.png", quadrants(40, 30)))
    (store.root / ".building-0123456789ab" / "pyramid_files").mkdir(parents=True)
    (store.root / ".upload-feed").write_bytes(b"half an upload")
    (store.root / ".removing-0123456789ab-1f2e3d4c" / "pyramid_files").mkdir(parents=True)
    assert store.sweep() == []  # young: perhaps still running
    later = time.time() + STALE_S + 1
    swept = sorted(p.name for p in store.sweep(now=later))
    assert swept == [".building-0123456789ab", ".removing-0123456789ab-1f2e3d4c", ".upload-feed"]
    assert [p.name for p in store.root.iterdir()] == [kept.id]


def test_a_retitled_image_keeps_its_place_and_a_removed_one_leaves_nothing(
    store: ImageStore, tmp_path: Path
) -> None:
    older = store.add(save(tmp_path / "older.png", quadrants(40, 30)))
    newer = store.add(save(tmp_path / "newer.png", quadrants(40, 30)))
    assert [i.id for i in store.images()] == [newer.id, older.id]
    renamed = store.retitle(older.id, "Kidney, H&E")
    assert renamed == older.model_copy(update={"title": "Kidney, H&E"})
    assert store.get(older.id) == renamed
    assert [i.id for i in store.images()] == [newer.id, older.id]  # its time kept
    assert {p.name for p in (store.root / older.id).iterdir()} == {
        "manifest.json",
        "pyramid_files",
        "pyramid.dzi",
        LOCK,
    }  # no temporary manifest left behind

    assert store.remove(older.id) == renamed
    assert [p.name for p in store.root.iterdir()] == [newer.id]  # nothing hidden left
    assert not store.holds(older.id) and store.holds(newer.id)
    for missing in (older.id, "../../etc"):
        with pytest.raises(KeyError):
            store.remove(missing)
        with pytest.raises(KeyError):
            store.retitle(missing, "x")
