"""What every wall has whatever app it shows: the student and instructor registration
codes."""

from __future__ import annotations

from urllib.parse import quote, urlsplit

from fastapi import Response, status
from fastapi.responses import RedirectResponse

from wall_client.layout import Wall
from webapp.apps.hooks import Scan, WallApp
from webapp.core.roles import Role
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState
from webapp.people.person import Person, address_grant, assume, grant, remember_person
from webapp.tags.registry import TagSpec
from webapp.web.context import AppContext
from webapp.web.templating import render

REGISTRATION_ROLES = (("student", "Student"), ("instructor", "Instructor"))


class RegistrationApp(WallApp):
    """The registration codes every wall carries whatever app it shows (the app named
    ``core``: its codes are the core's, on the registration screen)."""

    name: str = "core"

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """The student and instructor codes, permanent on the registration screen."""
        return self.screen_tags(wall)

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        """The student and instructor codes: every wall must have room for them."""
        return [
            TagSpec(
                name=f"register-{role}",
                label=label,
                app=self.name,
                action="register",
                params={"role": role},
                screen="registration",
                slot=slot,
            )
            for slot, (role, label) in enumerate(REGISTRATION_ROLES)
        ]

    async def on_scan(self, scan: Scan) -> Response:
        """Student: always. Instructor: only a phone already authorised (signed in,
        paired, or by an address rule where those are on); others go to sign in and
        come back to this code. An instructor's own link opens its page."""
        if scan.tag.action == "link":
            return _open_link(scan)
        person = await scan.person()
        context = scan.context
        if scan.tag.params.get("role") == "instructor" and not person.may_assume("instructor"):
            authority = await run_blocking(
                address_grant, context.db, scan.address, context.settings
            )
            if authority is None:
                back = quote(f"/t/{scan.tag.code}")
                return RedirectResponse(f"/login?next={back}", status.HTTP_303_SEE_OTHER)
            person = await run_blocking(
                grant, context.db, person, "instructor", authority, context.settings, scan.address
            )
        role: Role = "instructor" if scan.tag.params.get("role") == "instructor" else "student"
        registered: Person = await run_blocking(
            assume, context.db, person, role, context.settings, scan.address
        )
        remember_person(scan.request, registered)
        return render(scan.request, "registered.html", wall=scan.wall)


def _open_link(scan: Scan) -> Response:
    """The web page of an instructor's own link code; only http(s), whatever a tag
    issued through the raw API says."""
    url = str(scan.tag.params.get("url", ""))
    if urlsplit(url).scheme not in ("http", "https"):
        return render(
            scan.request,
            "scan_problem.html",
            status_code=status.HTTP_404_NOT_FOUND,
            title="Not a web page",
            detail="This code's link is not a web address.",
            wall_id=scan.wall.id,
        )
    return RedirectResponse(url, status.HTTP_303_SEE_OTHER)
