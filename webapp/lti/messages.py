"""Every LTI message tagwall reads or writes, as pydantic models (1EdTech LTI Core 1.3,
Deep Linking 2.0, NRPS 2.0, AGS 2.0). Claims arrive under their URIs; the models name
them by alias, so the code reads ``launch.context.title``. The services' JSON fields keep
the specs' own (camelCase) names."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, HttpUrl, StringConstraints

LTI = "https://purl.imsglobal.org/spec/lti/claim/"
DL = "https://purl.imsglobal.org/spec/lti-dl/claim/"
SCORE_SCOPE = "https://purl.imsglobal.org/spec/lti-ags/scope/score"
MEMBERSHIP_SCOPE = "https://purl.imsglobal.org/spec/lti-nrps/scope/contextmembership.readonly"

Text = Annotated[str, StringConstraints(min_length=1, max_length=1_000)]


class Claims(BaseModel):
    model_config = ConfigDict(populate_by_name=True, extra="ignore")


class Named(Claims):
    """A person as a launch or a roster names them (OpenID Connect's name claims)."""

    name: str = Field(default="", max_length=1_000)
    given_name: str = Field(default="", max_length=1_000)
    family_name: str = Field(default="", max_length=1_000)

    @property
    def full_name(self) -> str:
        """``name``, else the given and family names (platforms send one or the other)."""
        return self.name or f"{self.given_name} {self.family_name}".strip()


class LoginInitiation(BaseModel):
    """The platform's third-party login initiation (OIDC), by GET or POST."""

    iss: Text
    login_hint: Text
    target_link_uri: Text
    lti_message_hint: str | None = Field(default=None, max_length=4_000)
    client_id: str | None = Field(default=None, max_length=255)
    lti_deployment_id: str | None = Field(default=None, max_length=255)


class Context(Claims):
    id: Text
    title: str = Field(default="", max_length=1_000)
    label: str = Field(default="", max_length=1_000)


class ResourceLink(Claims):
    id: Text
    title: str = Field(default="", max_length=1_000)


class AgsEndpoint(Claims):
    scope: list[str] = []
    lineitems: str | None = None
    lineitem: str | None = None


class NrpsEndpoint(Claims):
    context_memberships_url: Text
    service_versions: list[str] = []


class DeepLinkingSettings(Claims):
    deep_link_return_url: Text
    accept_types: list[str]
    accept_presentation_document_targets: list[str] = []
    accept_multiple: bool = False
    data: str | None = None


class Launch(Named):
    """A verified id_token's LTI claims (signature, issuer, audience, times and nonce
    are checked before this model reads it). The aliases are the claims' URIs written
    out: type checkers take only literal aliases."""

    sub: Text
    message_type: Literal["LtiResourceLinkRequest", "LtiDeepLinkingRequest"] = Field(
        alias="https://purl.imsglobal.org/spec/lti/claim/message_type"
    )
    version: Literal["1.3.0"] = Field(alias="https://purl.imsglobal.org/spec/lti/claim/version")
    deployment_id: Text = Field(alias="https://purl.imsglobal.org/spec/lti/claim/deployment_id")
    target_link_uri: str = Field(
        default="", alias="https://purl.imsglobal.org/spec/lti/claim/target_link_uri"
    )
    roles: list[str] = Field(alias="https://purl.imsglobal.org/spec/lti/claim/roles")
    context: Context | None = Field(
        default=None, alias="https://purl.imsglobal.org/spec/lti/claim/context"
    )
    resource_link: ResourceLink | None = Field(
        default=None, alias="https://purl.imsglobal.org/spec/lti/claim/resource_link"
    )
    custom: dict[str, Any] = Field(
        default_factory=dict, alias="https://purl.imsglobal.org/spec/lti/claim/custom"
    )
    ags: AgsEndpoint | None = Field(
        default=None, alias="https://purl.imsglobal.org/spec/lti-ags/claim/endpoint"
    )
    nrps: NrpsEndpoint | None = Field(
        default=None, alias="https://purl.imsglobal.org/spec/lti-nrps/claim/namesroleservice"
    )
    deep_linking: DeepLinkingSettings | None = Field(
        default=None, alias="https://purl.imsglobal.org/spec/lti-dl/claim/deep_linking_settings"
    )


class LineItem(BaseModel):
    """The gradebook column a deep link asks the platform to make (Deep Linking 2.0)."""

    label: str
    scoreMaximum: float = Field(gt=0)
    resourceId: str


class ResourceLinkItem(BaseModel):
    """A deep link's content item: the link the course keeps, with what it starts."""

    type: Literal["ltiResourceLink"] = "ltiResourceLink"
    title: str
    text: str = ""
    url: str
    custom: dict[str, str]
    lineItem: LineItem


class Score(BaseModel):
    """A score posted to a line item's ``/scores`` (AGS 2.0)."""

    userId: str
    scoreGiven: float = Field(ge=0)
    scoreMaximum: float = Field(gt=0)
    activityProgress: Literal["Completed"] = "Completed"
    gradingProgress: Literal["FullyGraded"] = "FullyGraded"
    timestamp: datetime
    comment: str = ""


class Member(Named):
    """One person of a course's roster (NRPS 2.0)."""

    user_id: Text
    roles: list[str]
    status: str = "Active"


class MembershipContainer(BaseModel):
    model_config = ConfigDict(extra="ignore")

    members: list[Member]


class AccessToken(BaseModel):
    """A platform's answer to a client-credentials grant (1EdTech Security Framework)."""

    model_config = ConfigDict(extra="ignore")

    access_token: Text
    token_type: str
    expires_in: int = Field(default=3_600, ge=0)
    scope: str = ""


class Jwks(BaseModel):
    keys: list[dict[str, Any]]


class ToolValues(BaseModel):
    """What an LMS administrator pastes into the platform to register tagwall."""

    login_url: HttpUrl
    redirect_uris: list[HttpUrl]
    jwks_url: HttpUrl
    deep_linking_url: HttpUrl
    target_link_uri: HttpUrl
