"""``tagwall oidc``: what the campus identity provider's admin registers for tagwall, and
whether tagwall reaches each provider (documented in docs/campus.md and docs/cli.md)."""

from __future__ import annotations

import asyncio
import logging
import sys

import click

from webapp.campus.oidc import CampusSignIn, Provider
from webapp.cli.console import load_settings

EXIT_UNAVAILABLE = 1


@click.command()
def oidc() -> None:
    """Print what to register at each campus OpenID provider, and ask each whether it
    answers as tagwall needs."""
    settings = load_settings()
    if not settings.oidc_providers:
        click.echo("no OpenID providers configured (TAGWALL_OIDC_PROVIDERS): see docs/campus.md")
        return
    campus = CampusSignIn(settings)
    asyncio.run(_ask(campus))
    for key, provider in campus.providers.items():
        for line in registration(campus, key, provider):
            click.echo(line)
    if any(provider.problem for provider in campus.providers.values()):
        sys.exit(EXIT_UNAVAILABLE)


async def _ask(campus: CampusSignIn) -> None:
    """Each provider asked as the server asks it; what the server would log is said
    below instead (not "asked again every 60 s": this command asks once)."""
    log = logging.getLogger("webapp.campus.oidc")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        await asyncio.gather(*(provider.discover() for provider in campus.providers.values()))
    finally:
        log.setLevel(level)


def registration(campus: CampusSignIn, key: str, provider: Provider) -> list[str]:
    """One provider's block: the values its admin enters, then what it answered."""
    config = provider.config
    rules = [rule.describe() for rule in config.rules]
    lines = [
        f"{key}: {config.name} at {config.issuer}",
        f"  redirect URI:             {campus.redirect_uri(key)}",
        f"  post-logout redirect URI: {campus.post_logout_uri}",
        f"  client id:                {config.client_id}",
        f"  scopes:                   {' '.join(config.scopes)}",
        f"  claims the rules read:    {', '.join(config.claims_read)}",
        f"  rules:                    {rules[0]}",
        *(f"                            {rule}" for rule in rules[1:]),
    ]
    if provider.problem:
        return [*lines, f"  provider:                 UNAVAILABLE: {provider.problem}"]
    metadata = provider.metadata
    pkce = "S256" in (metadata.get("code_challenge_methods_supported") or ["S256"])
    sign_out = config.end_session_url or metadata.get("end_session_endpoint")
    lines.append("  provider:                 answers; its issuer is the one configured")
    if not pkce:
        lines.append("  warning:                  it does not list PKCE S256, which tagwall sends")
    lines.append(
        f"  its sign-out page:        {sign_out}"
        if sign_out
        else "  its sign-out page:        none (sign-out ends the tagwall session only)"
    )
    missing = set(config.scopes) - set(metadata.get("scopes_supported") or config.scopes)
    if missing:
        lines.append(f"  warning:                  it does not list the scopes {sorted(missing)}")
    return lines
