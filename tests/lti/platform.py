"""A small LMS for the tests: lti1p3platform (PyPI, not ours) behind FastAPI, run in its
own process (``python -m uvicorn tests.lti.platform:app``), so tagwall meets a real
platform's redirects, key set, service tokens, roster and gradebook.

One course (``bio101``, "Biology 101"), an instructor and three students. The tests
point it at a tagwall server (``POST /admin/tool``), add tagwall to the course by deep
linking, launch the link as anyone, and read the gradebook (``GET /admin/gradebook``).

lti1p3platform is thinly tested. Where it is wrong against the 1EdTech specs, this file
patches it, each patch saying so (``PATCH:``):

1. Its id_tokens carry no ``kid`` (it asks jwcrypto for a PEM key's kid, which has
   none), and its key set publishes keys without one: the Security Framework (5.1.3,
   5.4) has the kid name the key. Patched: the key's RFC 7638 thumbprint is its kid.
2. Its authorization endpoint never checks the tool's ``redirect_uri`` against the
   registered ones (Security Framework 5.1.1.5: it MUST), nor ``response_type``,
   ``scope``, ``prompt``, ``response_mode`` or the ``login_hint``'s user. Patched.
3. It decodes the tool's JWTs (deep-linking responses, client assertions) with
   ``verify_aud`` off and checks no ``iss``: a deep-linking response must have the
   platform as ``aud`` and the client id as ``iss`` (DL 2.0, 4.2), a client assertion
   the token endpoint as ``aud`` (RFC 7523 3). Patched: both checked.
4. Its score service accepts any JSON (``# TODO: validate score``) and any token of the
   AGS scopes: a score needs ``userId``, ``activityProgress``, ``gradingProgress`` and
   ``timestamp`` (AGS 2.0, 3.4) and a token with the ``score`` scope. Patched.
"""

from __future__ import annotations

import html
import json
import typing as t
from urllib.parse import urlencode

import jwt as pyjwt
import requests
from cryptography.hazmat.primitives import serialization
from cryptography.hazmat.primitives.asymmetric import rsa
from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from jwcrypto.jwk import JWK
from lti1p3platform.exceptions import (
    LtiDeepLinkingResponseException,
    LtiException,
    LtiServiceException,
)
from lti1p3platform.ltiplatform import LTI1P3PlatformConfAbstract
from lti1p3platform.membership import Context
from lti1p3platform.message_launch import LTIAdvantageMessageLaunchAbstract
from lti1p3platform.oidc_login import OIDCLoginAbstract
from lti1p3platform.registration import Registration
from lti1p3platform.request import Request as LtiRequest
from lti1p3platform.request import TRequest
from lti1p3platform.score import UpdateScoreStatus
from lti1p3platform.service_connector import (
    AssignmentsGradesService,
    NamesRoleProvisioningService,
    TPage,
)

CLIENT_ID = "tagwall-client"
DEPLOYMENT = "deployment-1"
COURSE = "bio101"
COURSE_TITLE = "Biology 101"
INSTRUCTOR = "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor"
LEARNER = "http://purl.imsglobal.org/vocab/lis/v2/membership#Learner"
USERS = {
    "teacher": ("Ines Teacher", INSTRUCTOR),
    "sam": ("Sam Student", LEARNER),
    "ada": ("Ada Lovelace", LEARNER),
    "ben": ("Ben Absent", LEARNER),
}
SCORE_SCOPE = "https://purl.imsglobal.org/spec/lti-ags/scope/score"

_private = rsa.generate_private_key(public_exponent=65537, key_size=2048)
PRIVATE_PEM = _private.private_bytes(
    serialization.Encoding.PEM,
    serialization.PrivateFormat.PKCS8,
    serialization.NoEncryption(),
).decode()
PUBLIC_PEM = (
    _private.public_key()
    .public_bytes(serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo)
    .decode()
)


class State:
    """What the LMS holds: the tool's registration, the links the course has (each with
    its line item), the scores it was sent, and failures asked for by a test."""

    def __init__(self) -> None:
        self.base = ""
        self.tool: dict[str, str] = {}
        self.links: dict[str, dict[str, t.Any]] = {}
        self.scores: dict[str, dict[str, dict[str, t.Any]]] = {}
        self.misbehave()

    def misbehave(
        self,
        refuse_scores: int = 0,
        jwks_down: bool = False,
        token_lifetime: int = 300,
        audience: str | None = None,
        drop_claims: tuple[str, ...] = (),
        refuse_links: bool = False,
    ) -> None:
        """What a test makes go wrong, as platforms do: score posts refused (503) the
        next N times, the key set down, id_tokens that expire (a negative lifetime: in
        the past), another audience, claims left out, deep links refused."""
        self.refuse_scores = refuse_scores
        self.jwks_down = jwks_down
        self.token_lifetime = token_lifetime
        self.audience = audience
        self.drop_claims = drop_claims
        self.refuse_links = refuse_links


state = State()


class KeyedRegistration(Registration):
    """PATCH 1: a kid for the platform's key, in its tokens and its key set."""

    def get_kid(self) -> str | None:
        key = self.get_platform_public_key()
        return JWK.from_pem(key.encode()).thumbprint() if key else None

    def get_jwks(self) -> list[dict[str, t.Any]]:
        keys = super().get_jwks()
        for key in keys:
            key["kid"] = self.get_kid()
        return keys


class Platform(LTI1P3PlatformConfAbstract):
    def init_platform_config(self, **kwargs: t.Any) -> None:
        self._registration = (
            KeyedRegistration()
            .set_iss(state.base)
            .set_client_id(CLIENT_ID)
            .set_deployment_id(DEPLOYMENT)
            .set_oidc_login_url(state.tool["login_url"])
            .set_launch_url(state.tool["launch_url"])
            .set_deeplink_launch_url(state.tool["launch_url"])
            .set_tool_key_set_url(state.tool["jwks_url"])
            .set_platform_public_key(PUBLIC_PEM)
            .set_platform_private_key(PRIVATE_PEM)
        )

    def get_registration_by_params(self, **kwargs: t.Any) -> Registration:
        assert self._registration is not None
        return self._registration

    audience = ""  # whom the tool's JWTs are for: the platform, else its token endpoint

    def decode_from_tool(self, token: str, audience: str) -> dict[str, t.Any]:
        """PATCH 3: the tool's JWT with its audience and issuer checked."""
        self.validate_jwt_format(token)
        claims: dict[str, t.Any] = pyjwt.decode(
            token,
            self.get_tool_public_key(),
            algorithms=["RS256"],
            audience=audience,
            issuer=CLIENT_ID,
        )
        return claims

    def tool_validate_and_decode(self, jwt_token_string: str) -> dict[str, t.Any]:
        return self.decode_from_tool(jwt_token_string, self.audience or state.base)


class Login(OIDCLoginAbstract):
    def set_lti_message_hint(self, **kwargs: t.Any) -> None:
        self._lti_message_hint = kwargs["hint"]

    def get_redirect(self, url: str) -> RedirectResponse:
        return RedirectResponse(url)


class Launch(LTIAdvantageMessageLaunchAbstract):
    """Its own FastAPI binding: lti1p3platform's imports ``pkg_resources`` for its
    template, which current setuptools no longer has."""

    def get_preflight_response(self) -> dict[str, t.Any]:
        return dict(self._request.query_params)

    def render_launch_form(self, launch_data: dict[str, t.Any], **kwargs: t.Any) -> Response:
        fields = "".join(
            f"<input type='hidden' name='{name}' value='{html.escape(launch_data[name])}'>"
            for name in ("id_token", "state")
        )
        return page(
            "Opening the tool",
            f"<form method='post' action='{html.escape(launch_data['launch_url'])}' id='form'>"
            f"{fields}<button type='submit'>Open</button></form>"
            "<script>document.getElementById('form').submit()</script>",
        )

    def validate_preflight_response(self, preflight_response: dict[str, t.Any]) -> None:
        """PATCH 2: the authentication request checked as the Security Framework says."""
        super().validate_preflight_response(preflight_response)
        problems = {
            "redirect_uri": preflight_response.get("redirect_uri") == state.tool["launch_url"],
            "response_type": preflight_response.get("response_type") == "id_token",
            "scope": preflight_response.get("scope") == "openid",
            "prompt": preflight_response.get("prompt") == "none",
            "response_mode": preflight_response.get("response_mode") == "form_post",
            "login_hint": preflight_response.get("login_hint") in USERS,
        }
        wrong = [name for name, right in problems.items() if not right]
        if wrong:
            raise LtiException(f"authentication request refused: {', '.join(wrong)}")

    def get_launch_message(self, include_extra_claims: bool = True) -> dict[str, t.Any]:
        message = super().get_launch_message(include_extra_claims)
        if state.audience is not None:
            message["aud"] = message["azp"] = state.audience
        for claim in state.drop_claims:
            message.pop(claim, None)
        return message

    def prepare_launch(self, preflight_response: dict[str, t.Any]) -> None:
        self.set_id_token_expiration(state.token_lifetime)
        user = preflight_response["login_hint"]
        name, role = USERS[user]
        self.set_user_data(user, [role], full_name=name)
        self.set_launch_context_claim(
            COURSE,
            context_types=["http://purl.imsglobal.org/vocab/lis/v2/course#CourseOffering"],
            context_title=COURSE_TITLE,
            context_label="BIO 101",
        )
        self.set_nrps(f"{state.base}/nrps/{COURSE}")
        hint = preflight_response.get("lti_message_hint", "")
        if hint == "deep-link":
            self.set_dl(f"{state.base}/deep-link-return", accept_types={"ltiResourceLink"})
            return
        link = state.links[hint]
        self.set_resource_link_claim(hint, title=link["title"])
        self.set_custom_parameters_claim(link["custom"])
        self.set_ags(
            lineitems_url=f"{state.base}/lineitems",
            lineitem_url=f"{state.base}/lineitems/{hint}",
        )


class Plain(LtiRequest):
    """lti1p3platform's request from what FastAPI read."""

    def build_metadata(self, request: t.Any) -> TRequest:
        return t.cast(TRequest, request)


async def plain(request: Request) -> Plain:
    body = await request.body()
    return Plain(
        {
            "method": request.method,
            "form_data": {},
            "get_data": dict(request.query_params),
            "headers": request.headers,
            "content_type": request.headers.get("content-type"),
            "path": request.url.path,
            "json": json.loads(body) if body else None,
        }
    )


class Grades(AssignmentsGradesService):
    def update_score(self, line_item_id: str, score: t.Any) -> UpdateScoreStatus:
        """PATCH 4: a score as AGS 2.0 defines it, from a token with the score scope."""
        bearer = self.request.headers.get("Authorization", "").split()[-1]
        scopes = pyjwt.decode(bearer, PUBLIC_PEM, algorithms=["RS256"])["scopes"].split()
        if SCORE_SCOPE not in scopes:
            raise LtiServiceException("the token has no score scope", 403)
        needed = ("userId", "activityProgress", "gradingProgress", "timestamp")
        if not isinstance(score, dict) or any(key not in score for key in needed):
            raise LtiServiceException(f"a score needs {', '.join(needed)}", 400)
        if state.refuse_scores > 0:
            state.refuse_scores -= 1
            raise LtiServiceException("gradebook unavailable", 503)
        state.scores.setdefault(line_item_id, {})[score["userId"]] = score
        return UpdateScoreStatus.SUCCESS

    def find_lineitems(self, **kwargs: t.Any) -> TPage:
        raise NotImplementedError

    def find_lineitem(self, line_item_id: str) -> t.Any:
        raise NotImplementedError

    def create_lineitem(self, creation_data: t.Any) -> t.Any:
        raise NotImplementedError

    def update_lineitem(self, update_data: t.Any) -> t.Any:
        raise NotImplementedError

    def delete_lineitem(self, line_item_id: str) -> None:
        raise NotImplementedError

    def get_results(self, line_item_id: str, **kwargs: t.Any) -> TPage:
        raise NotImplementedError


class Roster(NamesRoleProvisioningService):
    def get_member_data_page(self, **kwargs: t.Any) -> TPage:
        members = [
            {"user_id": user, "roles": [role], "name": name, "status": "Active"}
            for user, (name, role) in USERS.items()
        ]
        return {"content": members, "has_next": False, "next": None}

    def get_context_by_id(self) -> Context:
        return Context(id=COURSE, label="BIO 101", title=COURSE_TITLE)


app = FastAPI()


def page(title: str, body: str, status: int = 200) -> HTMLResponse:
    return HTMLResponse(
        f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{title}</title>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'></head>"
        f"<body><h1>{title}</h1>{body}</body></html>",
        status,
    )


def answer(result: t.Any) -> Response:
    if result.code >= 400:
        return JSONResponse({"error": result.message}, result.code)
    return JSONResponse(result.result, result.code, media_type=result.media_type)


@app.post("/admin/tool")
async def set_tool(request: Request) -> dict[str, str]:
    """A test points the LMS at its tagwall server: a new course, no links, no scores."""
    given = await request.json()
    state.base = given["base"]
    state.tool = given["tool"]
    state.links, state.scores = {}, {}
    state.misbehave()
    return {"issuer": state.base, "client_id": CLIENT_ID, "deployment_id": DEPLOYMENT}


@app.post("/admin/failures")
async def failures(request: Request) -> dict[str, str]:
    state.misbehave(**await request.json())
    return {}


@app.get("/admin/gradebook")
async def gradebook() -> dict[str, t.Any]:
    return {"links": state.links, "scores": state.scores}


@app.get("/jwks")
async def jwks() -> Response:
    if state.jwks_down:
        return JSONResponse({"error": "down"}, 500)
    return JSONResponse(Platform().get_jwks())


@app.get("/course/{course}/{what}")
async def course_page(course: str, what: str, user: str) -> HTMLResponse:
    """The course's page with the tool in its frame, as Canvas and Moodle show it."""
    source = f"/start?{urlencode({'user': user, 'hint': what})}"
    return page(
        COURSE_TITLE,
        f"<p>Signed in as {html.escape(USERS[user][0])}</p>"
        f"<iframe id='tool' title='tagwall' src='{html.escape(source)}' width='1000' "
        "height='700'></iframe>",
    )


@app.get("/start")
async def start(request: Request, user: str, hint: str) -> Response:
    """Third-party login initiation: to the tool's login URL."""
    login = Login(request, Platform())
    login.set_lti_message_hint(hint=hint)
    return t.cast(Response, login.initiate_login(user))


@app.get("/auth")
async def auth(request: Request) -> Response:
    try:
        return t.cast(Response, Launch(request, Platform()).lti_launch())
    except Exception as error:  # whatever stops it, the LMS says so
        return page("Launch refused", f"<p>{html.escape(str(error))}</p>", 400)


@app.post("/deep-link-return")
async def deep_link_return(request: Request) -> HTMLResponse:
    token = str((await request.form()).get("JWT", ""))
    platform = Platform()
    if state.refuse_links:  # a platform that takes plain links only, whatever it asked
        platform.set_accepted_deeplinking_types(["link"])
    try:
        items = platform.validate_deeplinking_resp({"JWT": token})
        claims = platform.tool_validate_and_decode(token)
        deployment = claims.get("https://purl.imsglobal.org/spec/lti/claim/deployment_id")
        if deployment != DEPLOYMENT:
            raise LtiException(f"deployment {deployment!r} is not this course's")
    except (
        LtiException,
        LtiDeepLinkingResponseException,
        pyjwt.PyJWTError,
        requests.RequestException,
    ) as error:
        return page("The tool's link was refused", f"<p>{html.escape(str(error))}</p>", 400)
    for item in items:
        link = f"link-{len(state.links) + 1}"
        state.links[link] = item
    titles = ", ".join(html.escape(item["title"]) for item in items)
    return page("Added to the course", f"<p id='added'>{titles}</p>")


@app.post("/token")
async def token(request: Request) -> Response:
    form = {k: str(v) for k, v in (await request.form()).items()}
    platform = Platform()
    try:
        platform.audience = f"{state.base}/token"  # PATCH 3
        claims = platform.decode_from_tool(form.get("client_assertion", ""), platform.audience)
        if claims.get("sub") != CLIENT_ID:
            raise LtiException("the assertion's sub is not the client id")
        return JSONResponse(platform.get_access_token(t.cast(t.Any, form)))
    except Exception as error:  # a token refused, whatever the reason
        return JSONResponse({"error": "invalid_client", "detail": str(error)}, 401)


@app.get("/nrps/{course}")
async def nrps(course: str, request: Request) -> Response:
    service = Roster(await plain(request), Platform(), f"{state.base}/nrps/{course}")
    return answer(service.handle_resp(service.handle_get_members))


@app.post("/lineitems/{item}/scores")
async def scores(item: str, request: Request) -> Response:
    service = Grades(
        await plain(request),
        Platform(),
        f"{state.base}/lineitems",
        f"{state.base}/lineitems/{item}",
    )
    return answer(service.handle_resp(service.handle_update_score, line_item_id=item))
