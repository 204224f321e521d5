"""What every wall has whatever app it shows: the registration codes."""

from __future__ import annotations

from fastapi import Response

from wall_client.layout import Wall
from webapp.apps import Scan
from webapp.routes.pages import render
from webapp.tags import TagSpec

REGISTRATION_ROLES = (("student", "Student"), ("instructor", "Instructor"))


class CoreApp:
    name: str = "core"
    default_tag_set: str | None = None

    def declare_tags(self, wall: Wall) -> list[TagSpec]:
        """The student and instructor codes, permanent on the registration screen."""
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
        role = scan.tag.params.get("role")
        if role == "student":
            return render(scan.request, "registered.html", wall=scan.wall, role="student")
        return render(
            scan.request,
            "registered.html",
            wall=scan.wall,
            role=None,
            status_code=403,
        )
