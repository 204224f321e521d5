"""tagwall's half of LTI 1.3's security (1EdTech Security Framework 1.0): the third-party
login initiation, the id_token checked against the platform's published keys, the
deep-linking response signed with tagwall's key, and service tokens for the roster and
the gradebook (client credentials with a signed client assertion).

JOSE is joserfc's; nothing here parses or checks a JWT by hand."""

from __future__ import annotations

import logging
import time
import uuid
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlencode

import httpx
from joserfc import jwt
from joserfc.errors import ExpiredTokenError, JoseError
from joserfc.jwk import KeySet
from joserfc.jws import extract_compact
from pydantic import ValidationError

from webapp.core.settings import Settings
from webapp.core.threads import run_blocking
from webapp.database.connection import Database
from webapp.lti import passes
from webapp.lti.keys import ALGORITHM, signing_key
from webapp.lti.messages import (
    DL,
    LTI,
    MEMBERSHIP_SCOPE,
    SCORE_SCOPE,
    AccessToken,
    Launch,
    LoginInitiation,
    Member,
    MembershipContainer,
    ResourceLinkItem,
    Score,
)
from webapp.lti.platforms import LAUNCH_PATH, Platform, find_platform, get_platform

log = logging.getLogger(__name__)

JWKS_KEPT_S = 300.0  # a platform's keys are asked again after this, or for an unknown kid
TOKEN_MARGIN_S = 60.0  # a service token is renewed this long before it expires
TIMEOUT = httpx.Timeout(10.0)


class LaunchError(Exception):
    """A launch or deep link tagwall refuses: ``message`` for the person (a page),
    ``detail`` for the log."""

    def __init__(self, message: str, detail: str, status: int = 400) -> None:
        super().__init__(detail)
        self.message = message
        self.detail = detail
        self.status = status


class ServiceError(Exception):
    """A platform's service (token, roster, scores) that did not answer as it should."""


@dataclass(frozen=True)
class Verified:
    """A launch whose id_token passed every check."""

    platform: Platform
    launch: Launch


@dataclass
class LtiTool:
    """One per server process: the platforms' keys and service tokens kept a while."""

    db: Database
    settings: Settings
    _client: httpx.AsyncClient | None = None
    _keys: dict[int, tuple[float, KeySet]] = field(default_factory=dict)
    _tokens: dict[tuple[int, str], tuple[float, str]] = field(default_factory=dict)

    @property
    def client(self) -> httpx.AsyncClient:
        """One client for the platforms (made at the first launch: most servers have
        none)."""
        if self._client is None:
            self._client = httpx.AsyncClient(timeout=TIMEOUT, follow_redirects=False)
        return self._client

    async def close(self) -> None:
        if self._client is not None:
            await self._client.aclose()

    # --- login initiation and launch ---------------------------------------------------

    async def login(self, initiation: LoginInitiation, base_url: str) -> str:
        """Where the browser goes next: the platform's authorization endpoint, with a
        fresh ``state`` and ``nonce`` kept server-side (single use)."""
        platform = await run_blocking(find_platform, self.db, initiation.iss, initiation.client_id)
        if platform is None:
            raise LaunchError(
                "This learning platform is not registered with tagwall. Ask the "
                "administrator to add it (tagwall lti add).",
                f"login from unknown issuer {initiation.iss!r} "
                f"(client id {initiation.client_id!r})",
            )
        deployment = initiation.lti_deployment_id
        if deployment is not None and deployment not in platform.deployment_ids:
            raise _unknown_deployment(platform, deployment)
        redirect_uri = base_url + LAUNCH_PATH
        nonce = uuid.uuid4().hex
        state = await run_blocking(
            passes.issue, self.db, "state", {"platform": platform.id, "nonce": nonce}
        )
        query = {
            "scope": "openid",
            "response_type": "id_token",
            "response_mode": "form_post",
            "prompt": "none",
            "client_id": platform.client_id,
            "redirect_uri": redirect_uri,
            "login_hint": initiation.login_hint,
            "state": state,
            "nonce": nonce,
        }
        if initiation.lti_message_hint is not None:
            query["lti_message_hint"] = initiation.lti_message_hint
        joiner = "&" if "?" in platform.auth_url else "?"
        return f"{platform.auth_url}{joiner}{urlencode(query)}"

    async def verify(self, id_token: str, state: str) -> Verified:
        """The launch in ``id_token``, after every check LTI 1.3 asks of a tool: the
        state is ours and unused, the token is signed by the platform's key, ``iss``,
        ``aud`` (and ``azp``), ``exp`` and ``iat`` (with ``TAGWALL_LTI_LEEWAY_S``), the
        nonce is the state's, the deployment is registered, the message type and version
        are LTI 1.3's, and the claims a launch needs are there."""
        kept = await run_blocking(passes.take, self.db, "state", state)
        if kept is None:
            raise LaunchError(
                "This launch has expired or was used already. Open tagwall from your course again.",
                "launch with an unknown, expired or used state",
            )
        platform = await run_blocking(get_platform, self.db, int(kept["platform"]))
        if platform is None:
            raise LaunchError(
                "This learning platform is no longer registered with tagwall.",
                "launch of a platform removed since its login",
            )
        try:
            header = extract_compact(id_token.encode()).headers()  # the key id only
        except (JoseError, ValueError) as error:
            raise _bad_token(platform, f"not a JWT: {error}") from error
        keys = await self._platform_keys(platform, refresh=False)
        if header.get("kid") and not _has_kid(keys, str(header["kid"])):
            keys = await self._platform_keys(platform, refresh=True)  # the platform rotated
        try:
            token = jwt.decode(id_token, keys, algorithms=[ALGORITHM])
            jwt.JWTClaimsRegistry(
                now=int(time.time()),
                leeway=self.settings.lti_leeway_s,
                iss={"essential": True, "value": platform.issuer},
                aud={"essential": True, "value": platform.client_id},
                exp={"essential": True},
                iat={"essential": True},
                nonce={"essential": True, "value": kept["nonce"]},
                sub={"essential": True},
            ).validate(token.claims)
        except ExpiredTokenError as error:
            raise LaunchError(
                "This launch has expired. Open tagwall from your course again (and check "
                "that this computer's clock is right).",
                f"expired id_token from {platform.issuer}: {error}",
            ) from error
        except (JoseError, ValueError) as error:
            raise _bad_token(platform, str(error)) from error
        claims = token.claims
        several = isinstance(claims["aud"], list) and len(claims["aud"]) > 1
        if (several or "azp" in claims) and claims.get("azp") != platform.client_id:
            raise _bad_token(platform, f"azp {claims.get('azp')!r} is not the client id")
        try:
            launch = Launch.model_validate(claims)
        except ValidationError as error:
            missing = ", ".join(
                str(problem["loc"][0]).removeprefix(LTI).removeprefix(DL)
                for problem in error.errors()
            )
            raise LaunchError(
                "The learning platform's launch lacks what tagwall needs "
                f"({missing}). Ask the platform's administrator.",
                f"launch from {platform.issuer} with missing or wrong claims: {missing}",
            ) from error
        if launch.deployment_id not in platform.deployment_ids:
            raise _unknown_deployment(platform, launch.deployment_id)
        if launch.message_type == "LtiResourceLinkRequest" and launch.resource_link is None:
            raise LaunchError(
                "The learning platform's launch names no link. Ask the platform's administrator.",
                f"resource link launch from {platform.issuer} without resource_link",
            )
        if launch.message_type == "LtiDeepLinkingRequest" and launch.deep_linking is None:
            raise LaunchError(
                "The learning platform asked for a link without saying where it goes "
                "back to. Ask the platform's administrator.",
                f"deep linking request from {platform.issuer} without its settings",
            )
        return Verified(platform, launch)

    async def _platform_keys(self, platform: Platform, *, refresh: bool) -> KeySet:
        kept = self._keys.get(platform.id)
        if kept is not None and not refresh and kept[0] > time.monotonic():
            return kept[1]
        try:
            answer = await self.client.get(platform.jwks_url)
            answer.raise_for_status()
            keys = KeySet.import_key_set(answer.json())
        except (httpx.HTTPError, ValueError, JoseError) as error:
            if kept is not None:  # asked again for a new kid: the known keys still serve
                return kept[1]
            raise LaunchError(
                "tagwall could not read the learning platform's keys, so it cannot trust "
                "this launch. Try again in a minute; if it keeps happening, tell the "
                "platform's administrator.",
                f"JWKS of {platform.issuer} at {platform.jwks_url} unreadable: {error!r}",
                status=502,
            ) from error
        self._keys[platform.id] = (time.monotonic() + JWKS_KEPT_S, keys)
        return keys

    # --- deep linking --------------------------------------------------------------------

    async def deep_link_response(
        self, platform: Platform, deployment_id: str, data: str | None, item: ResourceLinkItem
    ) -> str:
        """The signed LtiDeepLinkingResponse carrying ``item`` back to the platform."""
        now = int(time.time())
        claims: dict[str, Any] = {
            "iss": platform.client_id,
            "aud": platform.issuer,
            "iat": now,
            "exp": now + 600,
            "nonce": uuid.uuid4().hex,
            LTI + "message_type": "LtiDeepLinkingResponse",
            LTI + "version": "1.3.0",
            LTI + "deployment_id": deployment_id,
            DL + "content_items": [item.model_dump(exclude_defaults=False)],
        }
        if data is not None:
            claims[DL + "data"] = data
        return await self._sign(claims)

    async def _sign(self, claims: dict[str, Any]) -> str:
        key = await run_blocking(signing_key, self.db)
        return jwt.encode({"alg": ALGORITHM, "kid": key.kid, "typ": "JWT"}, claims, key)

    # --- services: roster and gradebook ------------------------------------------------------

    async def _service_token(self, platform: Platform, scope: str) -> str:
        kept = self._tokens.get((platform.id, scope))
        if kept is not None and kept[0] > time.monotonic():
            return kept[1]
        now = int(time.time())
        assertion = await self._sign(
            {
                "iss": platform.client_id,
                "sub": platform.client_id,
                "aud": platform.token_url,
                "iat": now,
                "exp": now + 300,
                "jti": uuid.uuid4().hex,
            }
        )
        form = {
            "grant_type": "client_credentials",
            "client_assertion_type": "urn:ietf:params:oauth:client-assertion-type:jwt-bearer",
            "client_assertion": assertion,
            "scope": scope,
        }
        try:
            answer = await self.client.post(platform.token_url, data=form)
            answer.raise_for_status()
            token = AccessToken.model_validate(answer.json())
        except (httpx.HTTPError, ValueError) as error:
            raise ServiceError(f"no service token from {platform.token_url}: {error}") from error
        expires = time.monotonic() + max(0.0, token.expires_in - TOKEN_MARGIN_S)
        self._tokens[(platform.id, scope)] = (expires, token.access_token)
        return token.access_token

    async def roster(self, platform: Platform, memberships_url: str) -> list[Member]:
        """The course's members (NRPS 2.0), following ``next`` links page by page."""
        token = await self._service_token(platform, MEMBERSHIP_SCOPE)
        members: list[Member] = []
        url: str | None = memberships_url
        for _ in range(100):  # a roster of 100 pages is a runaway, not a course
            if url is None:
                break
            try:
                answer = await self.client.get(
                    url,
                    headers={
                        "Authorization": f"Bearer {token}",
                        "Accept": "application/vnd.ims.lti-nrps.v2.membershipcontainer+json",
                    },
                )
                answer.raise_for_status()
                members += MembershipContainer.model_validate(answer.json()).members
            except (httpx.HTTPError, ValueError) as error:
                raise ServiceError(f"roster from {url}: {error}") from error
            url = answer.links.get("next", {}).get("url")
        return members

    async def post_score(self, platform: Platform, lineitem_url: str, score: Score) -> None:
        """Post ``score`` to the line item (AGS 2.0): its ``/scores`` beside any query."""
        token = await self._service_token(platform, SCORE_SCOPE)
        path, _, query = lineitem_url.partition("?")
        url = f"{path.rstrip('/')}/scores" + (f"?{query}" if query else "")
        try:
            answer = await self.client.post(
                url,
                content=score.model_dump_json(exclude_defaults=False),
                headers={
                    "Authorization": f"Bearer {token}",
                    "Content-Type": "application/vnd.ims.lis.v1.score+json",
                },
            )
        except httpx.HTTPError as error:
            raise ServiceError(f"score to {url}: {error!r}") from error
        if answer.status_code == 401:
            self._tokens.pop((platform.id, SCORE_SCOPE), None)  # a token revoked early
        if not answer.is_success:
            raise ServiceError(f"score to {url}: {answer.status_code} {answer.text[:200]}")


def _has_kid(keys: KeySet, kid: str) -> bool:
    return any(key.kid == kid for key in keys.keys)


def _bad_token(platform: Platform, detail: str) -> LaunchError:
    return LaunchError(
        "tagwall could not verify this launch from your course (its signature or its "
        "details are wrong). Open tagwall from your course again; if it keeps happening, "
        "tell the platform's administrator.",
        f"id_token from {platform.issuer} refused: {detail}",
    )


def _unknown_deployment(platform: Platform, deployment: str) -> LaunchError:
    return LaunchError(
        "This deployment of tagwall in your learning platform is not registered. Ask the "
        "administrator to add its deployment id (tagwall lti add).",
        f"unknown deployment {deployment!r} of {platform.issuer}",
    )
