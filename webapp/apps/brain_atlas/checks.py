"""The brain atlas's part of ``tagwall content check``: its regions, tutor texts,
references and view presets, every problem found (an editor fixes them all at once)."""

from __future__ import annotations

from pathlib import Path

from webapp.apps.brain_atlas.content import ContentError, load_content
from webapp.apps.brain_atlas.pins import AtlasVolumes, PinCache
from webapp.apps.brain_atlas.views import VIEWS_NAME, load_views, showing
from webapp.apps.hooks import ContentCheck


def check_folder(folder: Path) -> ContentCheck:
    """The atlas content in ``folder``: its files, and every region's pin shown by one
    of the view presets (computed from the label volume)."""
    try:
        loaded = load_content(folder)
        presets = load_views(folder / VIEWS_NAME)
        shown = showing(presets, loaded.regions, AtlasVolumes.load(folder), PinCache())
    except ContentError as error:
        return ContentCheck(folder, "", error.problems)
    unseen = [f"views.yaml: no view shows the pin of {r}" for r, ids in shown.items() if not ids]
    summary = (
        f"{len(loaded.in_set('full'))} quiz regions, {len(loaded.in_set('k5'))} K-5 "
        f"regions, {len(loaded.tutors)} tutor files, {len(loaded.references)} references, "
        f"{len(presets)} views showing every pin"
    )
    return ContentCheck(folder, summary, unseen)
