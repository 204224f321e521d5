"""Who people are to the wall: their role, user group and information class.

Plain types, imported by the settings (per-role limits) and by everything that
decides what a person sees or may do.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

Role = Literal["student", "instructor", "admin"]
ROLES: tuple[Role, ...] = ("student", "instructor", "admin")  # in rising order of privilege
UserGroup = Literal["k5", "undergraduate", "medical", "research"]
USER_GROUPS: tuple[UserGroup, ...] = ("k5", "undergraduate", "medical", "research")
InfoClass = Annotated[int, Field(ge=1, le=5)]
MAX_INFO_CLASS: dict[Role, int] = {"student": 3, "instructor": 5, "admin": 5}
DEFAULT_INFO_CLASS: dict[Role, int] = {"student": 1, "instructor": 5, "admin": 5}
