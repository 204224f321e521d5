"""The research group's literature search: PubMed through NCBI's E-utilities, and the
region's curated reading list (``references.yaml``), labelled offline, when PubMed
cannot be reached.

:class:`PubMed` asks ``esearch.fcgi`` for the most relevant PMIDs of a query, then
``esummary.fcgi`` for their titles, authors, journals and years, and keeps each
query's articles for ``TAGWALL_PUBMED_CACHE_SECONDS``. Whoever creates a
:class:`PubMed` owns it (and its cache); nothing here holds state at module level.
:func:`literature_for` is what a page calls: it never fails because of the network.

E-utilities: https://www.ncbi.nlm.nih.gov/books/NBK25499/
"""

from __future__ import annotations

import asyncio
import html
import logging
import re
import time
from collections.abc import Callable, Mapping
from http import HTTPStatus
from typing import Literal

import httpx
from pydantic import BaseModel, ConfigDict, Field

from webapp.apps.brain_atlas.content import AtlasContent, Reference
from webapp.core.settings import Settings

log = logging.getLogger(__name__)

TOOL = "tagwall"  # the `tool` parameter NCBI asks every E-utilities client to send
MAX_CACHED_QUERIES = 256
AUTHORS_SHOWN = 3
AUTHOR_TYPES = ("Author", "CollectiveName")  # not e.g. a book's editors
PMID = r"^[0-9]{1,12}$"
_TAG = re.compile(r"<[^>]*>")
_YEAR = re.compile(r"^\s*([0-9]{4})\b")


RETRY_AFTER_FAILURE_S = 60.0
"""After PubMed failed, how long searches answer offline at once before trying again."""


class LiteratureUnavailable(Exception):
    """PubMed could not give an answer; ``reason`` says why, in plain words (shown to
    readers), ``detail`` what exactly failed (logged)."""

    def __init__(self, reason: str, detail: str | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.detail = detail


class Article(BaseModel):
    """One PubMed record, ready to show (frozen: cached ones are shared)."""

    model_config = ConfigDict(frozen=True)

    pmid: str = Field(pattern=PMID)
    title: str
    authors: str  # "Scoville WB, Milner B"; past three authors, "A, B, C, et al."
    journal: str
    year: int | None
    url: str  # https://pubmed.ncbi.nlm.nih.gov/<pmid>/


class Literature(BaseModel):
    """What the research page lists for a region: PubMed's articles, or (``offline``)
    the curated reading list with the ``reason`` PubMed could not be asked."""

    source: Literal["pubmed", "offline"]
    query: str
    articles: list[Article] = Field(default_factory=list)  # source "pubmed"
    offline: list[Reference] = Field(default_factory=list)  # source "offline"
    reason: str | None = None  # source "offline": why, e.g. "PubMed did not answer within 5 s"


def article_url(pmid: str) -> str:
    return f"https://pubmed.ncbi.nlm.nih.gov/{pmid}/"


def format_authors(names: list[str]) -> str:
    """Names as PubMed gives them (surname and initials), the first three then et al."""
    if len(names) <= AUTHORS_SHOWN:
        return ", ".join(names)
    return ", ".join(names[:AUTHORS_SHOWN]) + ", et al."


class PubMed:
    """A PubMed client with a per-query cache, configured by ``TAGWALL_PUBMED_*``.

    ``transport`` replaces the network (tests: ``httpx.MockTransport``); ``clock``
    (seconds, monotonic) decides when cached results expire.
    """

    def __init__(
        self,
        settings: Settings,
        *,
        transport: httpx.AsyncBaseTransport | None = None,
        clock: Callable[[], float] = time.monotonic,
        max_cached: int = MAX_CACHED_QUERIES,
    ) -> None:
        self.base_url = settings.pubmed_url.rstrip("/") + "/"
        self.timeout = settings.pubmed_timeout
        self.results = settings.pubmed_results
        self.cache_seconds = settings.pubmed_cache_seconds
        self.email = settings.pubmed_email or None
        self.max_cached = max_cached
        self._transport = transport
        self._clock = clock
        # after a failure, (until when, why): pages answer offline at once meanwhile
        # instead of each waiting the whole timeout for a network that is not there
        self._down: tuple[float, str] | None = None
        # query -> (when fetched, articles); insertion order is age order. Reads and
        # writes happen between awaits, so concurrent searches need no lock (two
        # concurrent misses for one query both ask PubMed; the later answer is kept).
        self._cache: dict[str, tuple[float, list[Article]]] = {}

    async def search(self, query: str) -> list[Article]:
        """The most relevant articles for ``query``, in PubMed's order (none: ``[]``).

        LiteratureUnavailable when PubMed cannot be reached or its answer is unusable.
        """
        cached = self._cached(query)
        if cached is not None:
            return cached
        if self._down is not None and self._clock() < self._down[0]:
            raise LiteratureUnavailable(self._down[1])  # still resting: answer at once
        try:
            try:
                async with asyncio.timeout(self.timeout):
                    articles = await self._ask(query)
            except TimeoutError:  # the overall limit, covering both requests
                raise LiteratureUnavailable(self._too_slow()) from None
        except LiteratureUnavailable as error:
            log.warning(
                "PubMed search %r failed: %s%s",
                query,
                error.reason,
                f" ({error.detail})" if error.detail else "",
            )
            self._down = (self._clock() + RETRY_AFTER_FAILURE_S, error.reason)
            raise
        self._down = None
        self._store(query, articles)
        return list(articles)

    def clear_cache(self) -> None:
        self._cache.clear()

    # ------------------------------------------------------------------ requests

    async def _ask(self, query: str) -> list[Article]:
        async with httpx.AsyncClient(
            base_url=self.base_url, timeout=self.timeout, transport=self._transport
        ) as client:
            found = await self._get(
                client,
                "esearch.fcgi",
                {
                    "db": "pubmed",
                    "term": query,
                    "retmax": str(self.results),
                    "sort": "relevance",
                    "retmode": "json",
                },
            )
            pmids = _pmids(found)[: self.results]
            if not pmids:
                return []
            summaries = await self._get(
                client,
                "esummary.fcgi",
                {"db": "pubmed", "id": ",".join(pmids), "retmode": "json"},
            )
        return _articles(pmids, summaries)

    async def _get(
        self, client: httpx.AsyncClient, endpoint: str, params: dict[str, str]
    ) -> object:
        params = {**params, "tool": TOOL}
        if self.email:
            params["email"] = self.email
        try:
            response = await client.get(endpoint, params=params)
        except httpx.TimeoutException as error:
            raise LiteratureUnavailable(self._too_slow(), _describe(error)) from None
        except httpx.ConnectError as error:  # refused, unreachable, no DNS
            raise LiteratureUnavailable("PubMed could not be reached", _describe(error)) from None
        except httpx.HTTPError as error:  # the connection dropped, a bad URL ...
            raise LiteratureUnavailable(
                "The connection to PubMed failed", _describe(error)
            ) from None
        if response.status_code != HTTPStatus.OK:
            raise LiteratureUnavailable(f"PubMed answered {_status(response.status_code)}")
        try:
            return response.json()
        except ValueError:  # not JSON, or not UTF-8
            raise LiteratureUnavailable(
                f"PubMed's answer to {endpoint.removesuffix('.fcgi')} was not valid JSON"
            ) from None

    def _too_slow(self) -> str:
        return f"PubMed did not answer within {self.timeout:g} s"

    # ------------------------------------------------------------------ cache

    def _cached(self, query: str) -> list[Article] | None:
        entry = self._cache.get(query)
        if entry is None:
            return None
        fetched, articles = entry
        if self._clock() - fetched >= self.cache_seconds:
            del self._cache[query]
            return None
        return list(articles)

    def _store(self, query: str, articles: list[Article]) -> None:
        if self.cache_seconds <= 0 or self.max_cached <= 0:
            return
        self._cache.pop(query, None)
        self._cache[query] = (self._clock(), list(articles))
        while len(self._cache) > self.max_cached:
            del self._cache[next(iter(self._cache))]  # the oldest


async def literature_for(region_id: str, content: AtlasContent, pubmed: PubMed) -> Literature:
    """The research page's literature for ``region_id``: PubMed's articles for the
    region's query, else its curated reading list, labelled offline, with the reason.

    ValueError when the region has no research text (the caller should not ask).
    """
    tutor = content.tutors.get(region_id)
    research = tutor.research if tutor is not None else None
    if research is None:
        raise ValueError(f"region {region_id!r} has no research text")
    try:
        articles = await pubmed.search(research.search)
    except LiteratureUnavailable as error:
        reading = [content.references[r] for r in research.references if r in content.references]
        return Literature(
            source="offline", query=research.search, offline=reading, reason=error.reason
        )
    return Literature(source="pubmed", query=research.search, articles=articles)


# ---------------------------------------------------------------------- parsing


def _pmids(answer: object) -> list[str]:
    """esearch's idlist, checked."""
    result = answer.get("esearchresult") if isinstance(answer, Mapping) else None
    if not isinstance(result, Mapping):
        raise LiteratureUnavailable("PubMed's search answer had no esearchresult")
    if "ERROR" in result:  # e.g. a query PubMed cannot parse
        raise LiteratureUnavailable(f"PubMed refused the search: {result['ERROR']}")
    idlist = result.get("idlist")
    if not isinstance(idlist, list) or not all(
        isinstance(pmid, str) and re.match(PMID, pmid) for pmid in idlist
    ):
        raise LiteratureUnavailable("PubMed's search answer had no valid idlist")
    return list(dict.fromkeys(idlist))  # without repeats, in PubMed's order


def _articles(pmids: list[str], answer: object) -> list[Article]:
    """The esummary records of ``pmids``, in that order."""
    result = answer.get("result") if isinstance(answer, Mapping) else None
    if not isinstance(result, Mapping):
        raise LiteratureUnavailable("PubMed's summary answer had no result")
    articles = []
    for pmid in pmids:
        record = result.get(pmid)
        if not isinstance(record, Mapping):
            raise LiteratureUnavailable(f"PubMed's summary answer lacked PMID {pmid}")
        if "error" in record:  # a PMID esummary cannot summarise (withdrawn, merged)
            continue
        articles.append(_article(pmid, record))
    return articles


def _article(pmid: str, record: Mapping[str, object]) -> Article:
    title = record.get("title")
    authors = record.get("authors", [])
    journal = record.get("fulljournalname") or record.get("source") or ""
    if not isinstance(title, str) or not title.strip():
        raise LiteratureUnavailable(f"PubMed's summary of PMID {pmid} had no title")
    if not isinstance(authors, list) or not isinstance(journal, str):
        raise LiteratureUnavailable(f"PubMed's summary of PMID {pmid} was malformed")
    names = [
        author["name"]
        for author in authors
        if isinstance(author, Mapping)
        and isinstance(author.get("name"), str)
        and author.get("authtype", "Author") in AUTHOR_TYPES
    ]
    return Article(
        pmid=pmid,
        title=_plain(title),
        authors=format_authors(names),
        journal=_plain(journal),
        year=_year(record.get("pubdate")) or _year(record.get("sortpubdate")),
        url=article_url(pmid),
    )


def _plain(text: str) -> str:
    """esummary's text with its escaped markup (``&lt;i&gt;``) removed."""
    return " ".join(_TAG.sub("", html.unescape(text)).split())


def _year(date: object) -> int | None:
    """The year of "1957 Feb", "1998 Nov-Dec" or "1957/02/01 00:00"."""
    match = _YEAR.match(date) if isinstance(date, str) else None
    return int(match.group(1)) if match else None


def _status(code: int) -> str:
    try:
        return f"HTTP {code} ({HTTPStatus(code).phrase})"
    except ValueError:
        return f"HTTP {code}"


def _describe(error: httpx.HTTPError) -> str:
    detail = str(error).strip()
    name = type(error).__name__
    return f"{name}: {detail}" if detail else name
