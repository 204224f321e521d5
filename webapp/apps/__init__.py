"""Wall applications: each declares its tags and answers the scans of them.

An app is a small plug-in: the core resolves a scanned code to its tag and hands the
scan to the app named on the tag, which returns the phone page. Adding an app means
adding a module here and listing it in :func:`builtin_apps`; the core knows nothing
app-specific.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from fastapi import Request, Response

from wall_client.layout import Wall
from webapp.models import TagRecord
from webapp.tags import TagSpec
from webapp.visitors import Visitor

if TYPE_CHECKING:
    from webapp.services import Services


@dataclass(frozen=True)
class Scan:
    """A resolved scan, as an app's handler receives it."""

    request: Request
    services: Services
    wall: Wall
    tag: TagRecord
    visitor: Visitor


class WallApp(Protocol):
    name: str
    default_tag_set: str | None  # the set shown when the app comes on the wall

    def declare_tags(self, wall: Wall) -> list[TagSpec]:
        """The named tags the app needs on ``wall`` (declared at every start)."""
        ...

    async def on_scan(self, scan: Scan) -> Response:
        """The phone page for a scan of one of the app's tags."""
        ...


def builtin_apps() -> dict[str, WallApp]:
    from webapp.apps.core import CoreApp
    from webapp.apps.pattern import PatternApp

    apps: tuple[WallApp, ...] = (CoreApp(), PatternApp())
    return {app.name: app for app in apps}
