"""Whether a wall has room for the core's codes and each installed app's, before class.

The rules live in :mod:`tag_service.fit` (the server's own placement, asked again at
nearer distances); this module hands it the codes: the registration app's (the core's,
which every wall must carry) and each app's :meth:`~webapp.apps.hooks.WallApp.screen_tags`,
sized as the server sizes them for the URL they will carry. ``tagwall config check``,
``tagwall serve`` and the dashboard all say what :func:`wall_fit` finds, so they agree.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from tag_service.codes import modules_across, symbol_variants
from tag_service.fit import FitProblem, SlotCode, check_fit
from wall_client.layout import Wall
from webapp.apps.hooks import WallApp
from webapp.apps.installed import REGISTRATION
from webapp.tags.registry import TagSpec, content_payload, url_code_sizes


def slot_codes(specs: Sequence[TagSpec], base_url: str) -> list[SlotCode]:
    """The screen codes among ``specs`` as the placement sees them: URL codes as large
    as a tag URL of ``base_url`` makes them, direct codes as their payload does."""
    codes = []
    for spec in specs:
        if spec.screen is None or not spec.active:
            continue
        direct = content_payload(spec.kind, spec.content())
        sizes = (
            url_code_sizes(base_url)
            if direct is None
            else tuple(modules_across(symbol) for symbol in symbol_variants(direct))
        )
        codes.append(SlotCode(spec.label, spec.screen, spec.slot, sizes))
    return codes


def wall_fit(wall: Wall, apps: Mapping[str, WallApp], base_url: str) -> list[FitProblem]:
    """What of the core's and the installed apps' codes does not fit ``wall`` at its
    design distances, with what would make room (:func:`tag_service.fit.check_fit`)."""
    core_app = apps.get(REGISTRATION)
    core = slot_codes(core_app.screen_tags(wall), base_url) if core_app else []
    others = {
        name: slot_codes(app.screen_tags(wall), base_url)
        for name, app in apps.items()
        if name != REGISTRATION
    }
    return check_fit(wall, core, others, url_code_sizes(base_url))


def fit_lines(problems: Sequence[FitProblem]) -> list[str]:
    """One line per problem, errors (core codes left out) first: what the command line,
    the server's log and the dashboard print."""
    ordered = sorted(problems, key=lambda p: not p.required)
    return [f"{'error' if p.required else 'warning'}: {p.message()}" for p in ordered]
