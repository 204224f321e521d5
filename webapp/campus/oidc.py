"""Staff sign in with the campus's OpenID providers (``TAGWALL_OIDC_PROVIDERS``).

Authlib's Starlette client does the protocol: discovery from the issuer, the
authorization code flow with PKCE (S256), ``state`` and ``nonce`` (kept with the PKCE
verifier in a signed cookie of the sign-in's own paths, for :data:`SIGN_IN_WINDOW_S` at
most: the browser that starts a sign-in is the one that finishes it, once), and the ID
token checked through joserfc against the provider's JWKS: its signature, ``iss``,
``aud``, ``exp``, ``iat`` and ``nonce``, with ``TAGWALL_OIDC_LEEWAY_S`` seconds of
leeway for clocks that disagree. Claims the provider gives only at its userinfo endpoint
(as a provider that keeps ID tokens small does) are asked there.

Whatever goes wrong is a :class:`SignInFailed`: the page's status and words, and the
log's reason. A provider that does not answer at start leaves the server running: its
button says it is unavailable, the log says why once, and it is asked again every
:data:`RETRY_S` seconds and whenever someone presses its button.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlencode

import httpx2
from authlib.common.errors import AuthlibBaseError
from authlib.integrations.base_client.errors import MismatchingStateError
from authlib.integrations.starlette_client import OAuth
from joserfc.errors import (
    BadSignatureError,
    ClaimError,
    ExpiredTokenError,
    InvalidKeyIdError,
    JoseError,
    MissingClaimError,
)
from joserfc.jwk import KeySet
from starlette.requests import Request
from starlette.responses import Response

from webapp.core.oidc import OIDCProvider
from webapp.core.settings import Settings
from webapp.people.accounts import CampusIdentity
from webapp.people.person import plain_name

log = logging.getLogger(__name__)

SIGN_IN_PATH = "/login/oidc"
SIGN_IN_COOKIE = "tagwall_signin"
SIGN_IN_WINDOW_S = 600
"""How long a browser has from a provider's button to the provider's answer."""
PROVIDER_TIMEOUT_S = 10.0
RETRY_S = 60.0
"""How often a provider that did not answer is asked again."""
WELL_KNOWN = "/.well-known/openid-configuration"
_NEEDED_METADATA = ("authorization_endpoint", "token_endpoint", "jwks_uri")
_NEXT = "next"  # where the browser goes once signed in, kept beside Authlib's state


class SignInFailed(Exception):
    """A campus sign-in that cannot go on: the page's ``status`` and ``detail``, and
    the ``reason`` the log gets."""

    def __init__(self, status: int, detail: str, reason: str) -> None:
        super().__init__(reason)
        self.status = status
        self.detail = detail
        self.reason = reason


@dataclass(frozen=True)
class SignedIn:
    """What a provider vouched for: who the person is there, every claim it gave, and
    where the browser was going."""

    identity: CampusIdentity
    claims: Mapping[str, Any]
    next: str

    @property
    def who(self) -> str:
        """The person as the refusal page and the log name them."""
        return str(self.claims.get("email") or self.identity.name_hint)


def _problem(error: Exception) -> str:
    """An error met on the way to a provider, as one line of the log and the page."""
    if isinstance(error, httpx2.HTTPStatusError):
        return f"{error.request.url} answered HTTP {error.response.status_code}"
    if isinstance(error, httpx2.HTTPError):
        return f"{error.__class__.__name__} ({error})".replace(" ()", "")
    return str(error)


@dataclass(frozen=True)
class Button:
    """A provider's button on the sign-in page."""

    key: str
    label: str
    available: bool  # False: it did not answer when last asked (pressing asks again)


class Provider:
    """One configured provider: its Authlib client, and what was found when it was
    last asked."""

    def __init__(self, key: str, config: OIDCProvider, registry: OAuth) -> None:
        self.key = key
        self.config = config
        self.client = registry.register(
            key,
            client_id=config.client_id,
            client_secret=config.client_secret.get_secret_value(),
            server_metadata_url=config.issuer.rstrip("/") + WELL_KNOWN,
            client_kwargs={
                "scope": " ".join(config.scopes),
                "code_challenge_method": "S256",
                "timeout": PROVIDER_TIMEOUT_S,
            },
        )
        self.problem: str | None = None  # why it did not answer when last asked
        self.ready = False  # its metadata and keys are read

    @property
    def metadata(self) -> dict[str, Any]:
        metadata: dict[str, Any] = self.client.server_metadata
        return metadata

    async def discover(self) -> bool:
        """Read the provider's metadata and keys (whether it answers); the log says
        so once when it stops answering, and once when it answers again."""
        try:
            metadata = await self.client.load_server_metadata()
            if metadata.get("issuer") != self.config.issuer:
                raise ValueError(
                    f"it says its issuer is {metadata.get('issuer')!r}, not "
                    f"{self.config.issuer!r}: set issuer to exactly what it says"
                )
            missing = [name for name in _NEEDED_METADATA if not metadata.get(name)]
            if missing:
                raise ValueError(f"its metadata names no {', '.join(missing)}")
            KeySet.import_key_set(await self.client.fetch_jwk_set(force=True))
        except (httpx2.HTTPError, ValueError, TypeError, JoseError) as error:
            self.metadata.clear()  # read again next time
            self.lost(error)
            return False
        # Only what the provider's keys can sign: never "none", never a client secret's HMAC.
        metadata["id_token_signing_alg_values_supported"] = [
            alg
            for alg in metadata.get("id_token_signing_alg_values_supported") or ["RS256"]
            if alg != "none" and not alg.startswith("HS")
        ]
        if self.problem is not None:
            log.info("campus sign-in %r (%s) answers again", self.key, self.config.issuer)
        self.problem = None
        self.ready = True
        return True

    def lost(self, error: Exception) -> SignInFailed:
        """The provider did not answer (at start, or at a sign-in): its button says so
        until it answers again, and the log says why once."""
        problem = _problem(error)
        if problem != self.problem:
            log.warning(
                "campus sign-in %r (%s) is unavailable: %s; asked again every %d s",
                self.key,
                self.config.issuer,
                problem,
                RETRY_S,
            )
        self.problem = problem
        self.ready = False
        return self.unreachable()

    def unreachable(self) -> SignInFailed:
        return SignInFailed(
            503,
            f"{self.config.name} cannot be reached right now: {self.problem}. Try again "
            "in a minute; if it goes on, tell the people who run tagwall.",
            f"{self.config.issuer} cannot be reached: {self.problem}",
        )


class CampusSignIn:
    """A server's campus providers: their buttons, the sign-ins through them, and the
    sign-out each offers."""

    def __init__(self, settings: Settings) -> None:
        registry = OAuth()
        self.settings = settings
        self.providers = {
            key: Provider(key, config, registry) for key, config in settings.oidc_providers.items()
        }

    async def follow(self) -> None:
        """Ask every provider at start, then every :data:`RETRY_S` those not read yet."""
        while True:
            await asyncio.gather(*(p.discover() for p in self.providers.values() if not p.ready))
            await asyncio.sleep(RETRY_S)

    def buttons(self) -> list[Button]:
        return [Button(key, p.config.name, p.problem is None) for key, p in self.providers.items()]

    def provider(self, key: str) -> Provider:
        provider = self.providers.get(key)
        if provider is None:
            raise SignInFailed(404, "There is no such sign-in here.", f"no provider {key!r}")
        return provider

    def redirect_uri(self, key: str) -> str:
        """Where the provider sends the browser back: what its admin registers."""
        return f"{self.settings.resolved_public_base_url}{SIGN_IN_PATH}/{key}/callback"

    @property
    def post_logout_uri(self) -> str:
        return f"{self.settings.resolved_public_base_url}/"

    async def _ready(self, provider: Provider) -> None:
        if not provider.ready and not await provider.discover():
            raise provider.unreachable()

    async def begin(self, request: Request, key: str, next_path: str) -> Response:
        """Send the browser to the provider, with a new state, nonce and PKCE
        challenge kept for its answer."""
        provider = self.provider(key)
        await self._ready(provider)
        response: Response = await provider.client.authorize_redirect(
            request, self.redirect_uri(key)
        )
        request.session[_NEXT] = next_path
        return response

    async def check_answer(self, request: Request, key: str) -> Provider:
        """The provider whose answer this is, when it answers a sign-in this browser
        started (its ``state``) and comes from that provider (RFC 9207's ``iss``): the
        checks that cost nothing, before any request to the provider."""
        provider = self.provider(key)
        query = request.query_params
        if error := query.get("error"):
            description = query.get("error_description") or ""
            raise SignInFailed(
                401,
                f"{provider.config.name} did not sign you in"
                + (f": {description}" if description else f" ({error}).")
                + " Start again from the sign-in page.",
                f"the provider answered {error}: {description}".rstrip(": "),
            )
        await self._ready(provider)
        state = await provider.client.framework.get_state_data(request.session, query.get("state"))
        if state is None:
            raise SignInFailed(
                400,
                "This sign-in did not start in this browser, took longer than "
                f"{SIGN_IN_WINDOW_S // 60} minutes, or was finished already. Start again "
                "from the sign-in page.",
                "no sign-in of this browser has that state (wrong, replayed or expired)",
            )
        issuer = query.get("iss")
        sends_iss = provider.metadata.get("authorization_response_iss_parameter_supported")
        if issuer is None and sends_iss:
            issuer = ""  # RFC 9207 2.4: a provider that says it sends iss must send it
        if issuer is not None and issuer != provider.config.issuer:
            raise SignInFailed(
                400,
                f"This answer does not come from {provider.config.name}. Start again from "
                "the sign-in page.",
                f"the answer's iss is {issuer!r}, not {provider.config.issuer!r}",
            )
        return provider

    async def finish(self, request: Request, provider: Provider) -> SignedIn:
        """Trade the answer's code (once: its state is forgotten first) for tokens, and
        check the ID token; the person's claims, userinfo's included."""
        name = provider.config.name
        try:
            token = await provider.client.authorize_access_token(
                request, claims_options=self._claims_options(provider), leeway=self.leeway
            )
            claims: dict[str, Any] | None = token.get("userinfo")
            if claims is None:
                raise SignInFailed(
                    502,
                    f"{name} answered without an ID token, so no one was signed in.",
                    "the token response has no id_token",
                )
            if provider.metadata.get("userinfo_endpoint"):
                userinfo = await provider.client.userinfo(token=token)
                if userinfo.get("sub") != claims["sub"]:  # Core 5.3.4: not this person's
                    raise SignInFailed(
                        502,
                        f"{name}'s answers disagree about who signed in, so no one was.",
                        "the userinfo's sub is not the ID token's",
                    )
                claims = {**userinfo, **claims}
        except MismatchingStateError:  # this browser finished it meanwhile
            raise SignInFailed(
                400,
                "This sign-in was finished already. Start again from the sign-in page.",
                "the sign-in's state was used meanwhile",
            ) from None
        except AuthlibBaseError as error:
            raise SignInFailed(
                400,
                f"{name} refused this sign-in ({error.error}: {error.description or ''}). "
                "A sign-in code works once and for a short time: start again from the "
                "sign-in page.",
                f"the token endpoint answered {error.error}: {error.description}",
            ) from None
        except JoseError as error:
            raise self._untrusted(provider, error) from None
        except (httpx2.HTTPStatusError, ValueError) as error:
            raise SignInFailed(
                502,
                f"{name} could not finish the sign-in ({_problem(error)}). Try again in a minute.",
                _problem(error),
            ) from None
        except httpx2.HTTPError as error:
            raise provider.lost(error) from None
        return SignedIn(
            identity=CampusIdentity(
                issuer=provider.config.issuer,
                subject=str(claims["sub"]),
                name_hint=str(
                    claims.get("preferred_username") or claims.get("email") or claims["sub"]
                ),
                full_name=plain_name(str(claims.get("name") or "")),
            ),
            claims=claims,
            next=str(request.session.pop(_NEXT, "")),
        )

    @property
    def leeway(self) -> int:
        return self.settings.oidc_leeway_s

    @staticmethod
    def _claims_options(provider: Provider) -> dict[str, dict[str, Any]]:
        """What the ID token must say (OpenID Connect Core 3.1.3.7): this issuer, this
        client among its audiences, whom and when; Authlib adds the nonce, ``azp``
        and ``at_hash``."""
        return {
            "iss": {"essential": True, "value": provider.config.issuer},
            "aud": {"essential": True, "value": provider.config.client_id},
            "sub": {"essential": True},
            "exp": {"essential": True},
            "iat": {"essential": True},
        }

    def _untrusted(self, provider: Provider, error: JoseError) -> SignInFailed:
        """The words for an ID token that fails its checks."""
        name = provider.config.name
        clocks = (
            f"this server's clock and {name}'s disagree by more than the {self.leeway} s "
            "allowed: set both right (NTP) and start again"
        )
        if isinstance(error, BadSignatureError | InvalidKeyIdError):
            words = f"is not signed by {name}'s keys: it was forged or changed on the way"
        elif isinstance(error, ExpiredTokenError):
            words = f"had expired when it arrived; if it was new, {clocks}"
        elif isinstance(error, MissingClaimError):
            words = f"lacks what every ID token says ({error.claim})"
        elif isinstance(error, ClaimError) and error.claim in ("iat", "nbf"):
            words = f"was issued in the future by this server's clock: {clocks}"
        elif isinstance(error, ClaimError) and error.claim == "aud":
            words = "is meant for another client, not tagwall's"
        elif isinstance(error, ClaimError) and error.claim == "iss":
            words = f"comes from another issuer, not {provider.config.issuer}"
        elif isinstance(error, ClaimError) and error.claim == "nonce":
            words = "answers another sign-in (its nonce): a token replayed"
        elif isinstance(error, ClaimError):
            words = f"has a wrong {error.claim} claim"
        else:
            words = "cannot be read"
        return SignInFailed(
            401,
            f"The ID token from {name} {words}. No one was signed in.",
            f"ID token refused: {error.__class__.__name__}: {error}",
        )

    def end_session(self, issuer: str) -> tuple[str, str] | None:
        """The sign-out page of the provider of ``issuer`` (its name and URL), when it
        has one: signing out of tagwall leaves the person signed in there."""
        for provider in self.providers.values():
            if provider.config.issuer != issuer:
                continue
            page = provider.config.end_session_url or provider.metadata.get("end_session_endpoint")
            if page:
                query = urlencode(
                    {
                        "client_id": provider.config.client_id,
                        "post_logout_redirect_uri": self.post_logout_uri,
                    }
                )
                return provider.config.name, f"{page}{'&' if '?' in page else '?'}{query}"
        return None
