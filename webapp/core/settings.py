"""Settings from the environment (``TAGWALL_*``), with embedded defaults for the demo."""

from __future__ import annotations

import os
import secrets
import socket
from functools import cached_property
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, IPvAnyNetwork, ValidationError, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from webapp.core.oidc import OIDCProvider, ProviderName
from webapp.core.roles import (
    DEFAULT_INFO_CLASS,
    MAX_INFO_CLASS,
    ROLES,
    InfoClass,
    Role,
    UserGroup,
)

# Where phones must reach the server (the wall's purpose), so it listens on every
# interface by default; TAGWALL_HOST=127.0.0.1 keeps it on this machine.
EVERY_INTERFACE = ("0.0.0.0", "::", "")
LOOPBACK_NAMES = ("localhost", "::1")

PROJECT_ROOT = Path(__file__).resolve().parents[2]
CONTENT_DIR = PROJECT_ROOT / "content"
"""The content shipped in the checkout: the default of ``TAGWALL_CONTENT_DIR`` and what
a content folder falls back on. What runs reads :meth:`Settings.content_folder`."""

# Secrets that appear in docs and examples; running with one of them outside dev
# would let anyone forge tile tokens and sessions.
KNOWN_DEFAULT_SECRETS = frozenset(
    {"", "changeme", "change-me", "secret", "tagwall", "dev", "development", "insecure", "test"}
)
MIN_SECRET_LENGTH = 16


class Settings(BaseSettings):
    """Everything tagwall reads from its environment.

    Each field maps to ``TAGWALL_<NAME>``; see the README's configuration reference.
    """

    # A JSON setting may also be given a key at a time (TAGWALL_OIDC_PROVIDERS__CAMPUS__
    # CLIENT_SECRET): a secret in a variable of its own, the rest in a file more may read.
    model_config = SettingsConfigDict(
        env_prefix="TAGWALL_", extra="ignore", env_nested_delimiter="__"
    )

    env: Literal["dev", "production"] = "dev"
    host: str = "0.0.0.0"
    port: int = Field(default=8000, ge=1, le=65535)
    var_dir: Path = Path("var")
    database_url: str = ""
    public_base_url: str = ""
    secret_key: str = ""
    # Teaching content an installation may change: each app reads its own subfolder.
    content_dir: Path = CONTENT_DIR
    # Empty: the content folder's walls (resolved_wall_configs).
    wall_configs: Annotated[list[Path], NoDecode] = Field(default_factory=list)
    default_wall: str = "demo"
    # The app a wall shows before anyone chose one (an installed app's name).
    first_app: str = Field(default="pattern", min_length=1, max_length=64)
    # The installed apps to load (empty: all of them); the registration codes' always.
    apps: Annotated[list[str], NoDecode] = Field(default_factory=list)
    workers: int = Field(default=1, ge=1, le=256)
    bus: Literal["memory", "redis"] = "memory"
    redis_url: str = Field(default="redis://127.0.0.1:6379/0", pattern=r"^(redis|rediss|unix)://")
    # Keys are named under the prefix, so several installations can share one Redis.
    redis_prefix: str = Field(default="tagwall", pattern=r"^[A-Za-z0-9_.:-]{1,64}$")
    apply_lead_ms: int = Field(default=250, ge=0, le=10_000)
    swap_timeout_ms: int = Field(default=3_000, ge=100, le=60_000)
    tile_queue_size: int = Field(default=256, ge=8, le=100_000)
    event_history: int = Field(default=1_000, ge=10)
    max_frame_bytes: int = Field(default=4_096, ge=256)
    scan_rate_per_minute: int = Field(default=30, ge=1)
    scan_rate_per_address_per_minute: int = Field(default=600, ge=1)
    visitor_settle_s: int = Field(default=10, ge=0, le=3_600)
    wall_action_rate_per_minute: int = Field(default=12, ge=1)
    new_visitor_actions_per_address_per_minute: int = Field(default=6, ge=1)
    actions_per_address_per_minute: int = Field(default=300, ge=1)
    actions_per_wall_per_minute: int = Field(default=120, ge=1)
    scan_upload_max_bytes: int = Field(default=10_000_000, ge=10_000)
    trusted_proxies: Annotated[list[IPvAnyNetwork], NoDecode] = Field(default_factory=list)
    address_rules_grant_roles: bool = False
    default_user_group: UserGroup = "undergraduate"
    info_class_max: dict[Role, InfoClass] = Field(default_factory=lambda: dict(MAX_INFO_CLASS))
    info_class_default: dict[Role, InfoClass] = Field(
        default_factory=lambda: dict(DEFAULT_INFO_CLASS)
    )
    pairing_ttl_s: int = Field(default=60, ge=10, le=3_600)
    # Staff sign-in: local accounts' passwords, and the campus's OpenID providers.
    password_sign_in: bool = True
    oidc_providers: dict[ProviderName, OIDCProvider] = Field(default_factory=dict)
    oidc_leeway_s: int = Field(default=120, ge=0, le=600)
    login_free_attempts: int = Field(default=3, ge=1)
    login_client_free_attempts: int = Field(default=10, ge=1)
    login_max_delay_s: float = Field(default=300.0, ge=1)
    login_parallel_checks: int = Field(default=2, ge=1, le=64)
    publish_rate_per_minute: int = Field(default=3, ge=1)
    # How long a page of a long publication stays on the public screen
    # (webapp.publishing.screen).
    public_words_per_minute: int = Field(default=150, ge=10, le=100_000)
    public_page_min_s: float = Field(default=10.0, ge=0.5, le=3_600)
    balloon_seconds: int = Field(default=30, ge=1, le=3_600)
    volume_dir: Path | None = None
    volume_budget_voxels: int = Field(default=1 << 24, ge=4_096)
    volume_cache_voxels: int = Field(default=1 << 26, ge=0)
    # The brain atlas's literature search for the research group (NCBI E-utilities).
    pubmed_url: str = Field(
        default="https://eutils.ncbi.nlm.nih.gov/entrez/eutils/", pattern=r"^https?://"
    )
    pubmed_timeout: float = Field(default=5.0, gt=0, le=60)
    pubmed_results: int = Field(default=8, ge=1, le=50)
    pubmed_cache_seconds: int = Field(default=86_400, ge=0)
    pubmed_email: str | None = None  # sent with tool=tagwall, as NCBI asks of clients
    brain_group_switch_cooldown: float = Field(default=30.0, ge=0, le=3_600)

    @field_validator("wall_configs", mode="before")
    @classmethod
    def _split_paths(cls, value: object) -> object:
        """Accept ``a.toml:walls/`` like PATH, as well as a list."""
        if isinstance(value, str):
            return [part for part in value.split(os.pathsep) if part]
        return value

    @field_validator("content_dir", mode="after")
    @classmethod
    def _an_existing_folder(cls, value: Path) -> Path:
        """A content folder that is not there would leave every app without its
        content: say so at start, rather than at a phone's first scan."""
        if not value.is_dir():
            raise ValueError(
                f"{value} is not a folder; copy the shipped {CONTENT_DIR} there, or leave "
                "the setting out to use it"
            )
        return value

    @field_validator("trusted_proxies", "apps", mode="before")
    @classmethod
    def _split_commas(cls, value: object) -> object:
        """Accept ``10.0.0.1, 10.1.0.0/16`` (``brain, census``) as well as a list."""
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @field_validator("info_class_max", "info_class_default", mode="after")
    @classmethod
    def _every_role(cls, value: dict[Role, int]) -> dict[Role, int]:
        missing = set(ROLES) - value.keys()
        if missing:
            raise ValueError(f"give a class for every role; missing: {', '.join(sorted(missing))}")
        return value

    @model_validator(mode="after")
    def _refuse_known_secrets(self) -> Settings:
        if self.env == "production" and not self.secret_key:
            raise ValueError(
                "TAGWALL_SECRET_KEY is required in production: sessions, tile URLs and the "
                "operator link are signed with it, and every process of a wall must share "
                "it. Make one with: python3 -c 'import secrets; print(secrets.token_urlsafe(32))'"
            )
        if self.env != "dev" and self.secret_key:
            if self.secret_key.lower() in KNOWN_DEFAULT_SECRETS:
                raise ValueError("TAGWALL_SECRET_KEY is a well-known default; set a random one")
            if len(self.secret_key) < MIN_SECRET_LENGTH:
                raise ValueError(
                    f"TAGWALL_SECRET_KEY must be at least {MIN_SECRET_LENGTH} characters"
                )
        return self

    @model_validator(mode="after")
    def _someone_can_sign_in(self) -> Settings:
        if not self.password_sign_in and not self.oidc_providers:
            raise ValueError(
                "TAGWALL_PASSWORD_SIGN_IN=false needs an OpenID provider in "
                "TAGWALL_OIDC_PROVIDERS: otherwise no instructor can sign in"
            )
        return self

    @model_validator(mode="after")
    def _share_what_several_workers_need(self) -> Settings:
        """Several worker processes share one wall only through Redis and PostgreSQL."""
        if self.workers > 1 and self.bus == "memory":
            raise ValueError(
                f"TAGWALL_WORKERS={self.workers} needs TAGWALL_BUS=redis: the memory bus "
                "reaches the tiles of one process only"
            )
        if self.workers > 1 and self.resolved_database_url.startswith("sqlite"):
            raise ValueError(
                f"TAGWALL_WORKERS={self.workers} needs PostgreSQL (TAGWALL_DATABASE_URL): "
                "SQLite serves one process"
            )
        return self

    @property
    def resolved_database_url(self) -> str:
        """The database URL, defaulting to SQLite under ``var_dir``."""
        return self.database_url or f"sqlite:///{self.var_dir / 'tagwall.db'}"

    @property
    def resolved_volume_dir(self) -> Path:
        """Where built volume stores live: configured, else ``var_dir/volumes``."""
        return self.volume_dir or self.var_dir / "volumes"

    def content_folder(self, name: str) -> Path:
        """The subfolder ``name`` of the content folder (an app's, or ``walls``), else
        the shipped one of that name: an installation brings only the content it
        changes. Each app names its own subfolder, so the core names no app."""
        own = self.content_dir / name
        shipped = CONTENT_DIR / name
        return shipped if not own.is_dir() and shipped.is_dir() else own

    def content_fallbacks(self) -> list[str]:
        """One line per shipped subfolder the content folder lacks (and so falls back
        on), for ``serve`` to say at start."""
        if self.content_dir.resolve() == CONTENT_DIR.resolve():
            return []
        return [
            f"content: {self.content_dir} has no {shipped.name}/; using the shipped {shipped}"
            for shipped in sorted(CONTENT_DIR.iterdir())
            if shipped.is_dir() and not (self.content_dir / shipped.name).is_dir()
        ]

    @property
    def resolved_wall_configs(self) -> list[Path]:
        """The wall configs: configured, else the content folder's ``walls``."""
        return self.wall_configs or [self.content_folder("walls")]

    @property
    def listens_everywhere(self) -> bool:
        return self.host in EVERY_INTERFACE

    @property
    def listens_locally_only(self) -> bool:
        """Bound to loopback: nothing but this machine reaches the server."""
        return self.host in LOOPBACK_NAMES or self.host.startswith("127.")

    @cached_property
    def server_url(self) -> str:
        """This server as a browser on the wall's network reaches it (tile URLs)."""
        host = lan_address() if self.listens_everywhere else self.host
        return _http_url(host, self.port)

    @property
    def local_url(self) -> str:
        """This server as this machine's own browser and commands reach it: over
        loopback wherever it listens there, so nothing secret crosses the network."""
        if self.listens_everywhere:
            return _http_url("127.0.0.1", self.port)
        return _http_url(self.host, self.port)

    @cached_property
    def resolved_public_base_url(self) -> str:
        """Where codes send phones: configured (a proxy or a name), else where the
        server listens, on this machine's LAN address when it listens everywhere."""
        if self.public_base_url:
            return self.public_base_url.rstrip("/")
        return self.server_url

    @cached_property
    def resolved_secret_key(self) -> str:
        """The signing secret: configured, else (in dev only) generated once into
        ``var_dir``."""
        if self.secret_key:
            return self.secret_key
        path = self.var_dir / "secret_key"
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.touch(mode=0o600)
            path.write_text(secrets.token_urlsafe(32))
        return path.read_text().strip()


def setting_name(model: type[BaseSettings], field: str) -> str:
    """A field (``info_class_max``, ``info_class_max.student``) as the operator writes
    it in the environment: ``TAGWALL_INFO_CLASS_MAX.student``. The core's settings and
    an app's own (its own prefix) alike."""
    head, _, rest = field.partition(".")
    if head not in model.model_fields:
        return field
    prefix = model.model_config.get("env_prefix", "")
    return f"{prefix}{head.upper()}{'.' + rest if rest else ''}"


def setting_problems(error: ValidationError, model: type[BaseSettings]) -> list[str]:
    """One line per problem of settings that failed validation, each naming the
    setting (a rule between settings, which has no one field, names them itself)."""
    lines = []
    for problem in error.errors():
        field = ".".join(str(part) for part in problem["loc"])
        where = f"{setting_name(model, field)}: " if field else ""
        lines.append(where + problem["msg"].removeprefix("Value error, "))
    return lines


def _http_url(host: str, port: int) -> str:
    return f"http://[{host}]:{port}" if ":" in host else f"http://{host}:{port}"


def lan_address() -> str:
    """This machine's address on the local network, or loopback when it has none.

    Connecting a UDP socket sends no packet; it only asks the kernel which source
    address it would route from.
    """
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # TEST-NET-1: never routed, never contacted
            address = str(probe.getsockname()[0])
        except OSError:
            return "127.0.0.1"
    return address if not address.startswith("0.") else "127.0.0.1"
