"""The learning platforms registered with tagwall (``tagwall lti add``, the admin
page), and what tagwall tells a platform's administrator to paste."""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import urlsplit

from sqlalchemy import delete, select
from sqlalchemy.exc import IntegrityError

from webapp.database.connection import Database
from webapp.database.models import LtiPlatformRecord
from webapp.lti.messages import ToolValues
from webapp.people.audit import audit

# tagwall's paths as a tool: one home, the routes and the values to paste both read them.
LOGIN_PATH = "/lti/login"
LAUNCH_PATH = "/lti/launch"
JWKS_PATH = "/lti/jwks"


class PlatformError(Exception):
    """A registration that cannot be made; the message says why."""


@dataclass(frozen=True)
class Platform:
    id: int
    name: str
    issuer: str
    client_id: str
    deployment_ids: tuple[str, ...]
    auth_url: str
    token_url: str
    jwks_url: str

    @property
    def origins(self) -> list[str]:
        """Where the platform's pages are served from (its issuer's and its login
        endpoint's origins): the pages that may frame tagwall's launch pages."""
        return sorted({origin(self.issuer), origin(self.auth_url)} - {""})


def origin(url: str) -> str:
    """``scheme://host[:port]`` of an http(s) URL, else ""."""
    parts = urlsplit(url)
    return f"{parts.scheme}://{parts.netloc}" if parts.scheme in ("http", "https") else ""


def _platform(record: LtiPlatformRecord) -> Platform:
    return Platform(
        id=record.id,
        name=record.name,
        issuer=record.issuer,
        client_id=record.client_id,
        deployment_ids=tuple(record.deployment_ids),
        auth_url=record.auth_url,
        token_url=record.token_url,
        jwks_url=record.jwks_url,
    )


def tool_values(base_url: str) -> ToolValues:
    """The values an LMS administrator enters for tagwall: one URL for launches and deep
    links alike (tagwall reads the message type)."""
    launch = base_url + LAUNCH_PATH
    return ToolValues.model_validate(
        {
            "login_url": base_url + LOGIN_PATH,
            "redirect_uris": [launch],
            "jwks_url": base_url + JWKS_PATH,
            "deep_linking_url": launch,
            "target_link_uri": launch,
        }
    )


def add_platform(
    db: Database,
    *,
    name: str,
    issuer: str,
    client_id: str,
    deployment_ids: list[str],
    auth_url: str,
    token_url: str,
    jwks_url: str,
    actor: str,
) -> Platform:
    """Register a platform; the same issuer and client id again replace its deployments
    and URLs (a platform's admin re-registering)."""
    for label, url in (("issuer", issuer), ("auth URL", auth_url), ("token URL", token_url)):
        if not origin(url):
            raise PlatformError(f"the {label} must be an http(s) URL, not {url!r}")
    if not origin(jwks_url):
        raise PlatformError(f"the JWKS URL must be an http(s) URL, not {jwks_url!r}")
    deployments = [d.strip() for d in deployment_ids if d.strip()]
    if not deployments:
        raise PlatformError("give at least one deployment id (the platform shows it)")
    if not client_id.strip():
        raise PlatformError("give the client id the platform made for tagwall")
    try:
        with db.session() as session:
            record = session.scalars(
                select(LtiPlatformRecord).where(
                    LtiPlatformRecord.issuer == issuer, LtiPlatformRecord.client_id == client_id
                )
            ).first()
            if record is None:
                record = LtiPlatformRecord(issuer=issuer, client_id=client_id.strip())
                session.add(record)
            record.name = (name.strip() or origin(issuer))[:80]
            record.deployment_ids = deployments
            record.auth_url, record.token_url, record.jwks_url = auth_url, token_url, jwks_url
            session.flush()
            audit(session, "lti_platform_added", actor=actor, issuer=issuer, client_id=client_id)
            return _platform(record)
    except IntegrityError as error:  # the same registration made at the same moment
        raise PlatformError("that platform was registered just now; try again") from error


def remove_platform(db: Database, platform_id: int, actor: str) -> bool:
    with db.session() as session:
        gone = session.execute(
            delete(LtiPlatformRecord).where(LtiPlatformRecord.id == platform_id)
        ).rowcount  # type: ignore[attr-defined]
        if gone:
            audit(session, "lti_platform_removed", actor=actor, platform=platform_id)
    return bool(gone)


def list_platforms(db: Database) -> list[Platform]:
    with db.session() as session:
        records = session.scalars(select(LtiPlatformRecord).order_by(LtiPlatformRecord.id))
        return [_platform(r) for r in records]


def find_platform(db: Database, issuer: str, client_id: str | None) -> Platform | None:
    """The platform of ``issuer`` (and ``client_id``, when the platform says which of
    its registrations it means: a launch's ``aud``, a login's ``client_id``)."""
    query = select(LtiPlatformRecord).where(LtiPlatformRecord.issuer == issuer)
    if client_id:
        query = query.where(LtiPlatformRecord.client_id == client_id)
    with db.session() as session:
        found = session.scalars(query.order_by(LtiPlatformRecord.id)).all()
        return _platform(found[0]) if len(found) == 1 else None


def get_platform(db: Database, platform_id: int) -> Platform | None:
    with db.session() as session:
        record = session.get(LtiPlatformRecord, platform_id)
        return _platform(record) if record else None


def framing_origins(db: Database) -> list[str]:
    """Every registered platform's origins: who may frame the launch pages."""
    return sorted({o for platform in list_platforms(db) for o in platform.origins})
