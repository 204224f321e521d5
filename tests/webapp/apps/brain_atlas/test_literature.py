"""The research group's literature search: PubMed through E-utilities (answered here by
``httpx.MockTransport`` from the files in ``eutils/``), and the curated reading list,
labelled offline, whenever PubMed cannot give an answer."""

from __future__ import annotations

import asyncio
import copy
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
import pytest

from webapp.apps.brain_atlas.content import AtlasContent, load_content
from webapp.apps.brain_atlas.literature import (
    RETRY_AFTER_FAILURE_S,
    LiteratureUnavailable,
    PubMed,
    format_authors,
    literature_for,
)
from webapp.core.settings import Settings

EUTILS = Path(__file__).parent / "eutils"
HIPPOCAMPUS_PMIDS = ["13406589", "5124915", "4727084", "9809557"]
QUERY = '"hippocampus"[tiab] OR "hippocampal"[tiab]'
Handler = Callable[[httpx.Request], httpx.Response]


def fixture(name: str) -> Any:
    return json.loads((EUTILS / name).read_text(encoding="utf-8"))


class Recorder:
    """A stand-in for E-utilities: answers esearch and esummary, records requests."""

    def __init__(
        self, esearch: object = None, esummary: object = None, fail: Handler | None = None
    ) -> None:
        self.esearch = fixture("esearch_hippocampus.json") if esearch is None else esearch
        self.esummary = fixture("esummary_hippocampus.json") if esummary is None else esummary
        self.fail = fail
        self.requests: list[httpx.Request] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append(request)
        if self.fail is not None:
            return self.fail(request)
        if request.url.path.endswith("/esearch.fcgi"):
            return httpx.Response(200, json=self.esearch)
        if request.url.path.endswith("/esummary.fcgi"):
            return httpx.Response(200, json=self.esummary)
        return httpx.Response(404, text="no such E-utility")

    def params(self, index: int) -> dict[str, str]:
        return dict(self.requests[index].url.params)


class Clock:
    def __init__(self) -> None:
        self.now = 1_000.0

    def __call__(self) -> float:
        return self.now


def pubmed(recorder: Recorder, clock: Clock | None = None, **settings: Any) -> PubMed:
    return PubMed(
        Settings(**settings),
        transport=httpx.MockTransport(recorder),
        clock=clock or Clock(),
    )


@pytest.fixture(scope="module")
def content() -> AtlasContent:
    return load_content()


# ---------------------------------------------------------------------- requests


async def test_search_sends_what_e_utilities_documents() -> None:
    recorder = Recorder()
    await pubmed(recorder, pubmed_email="atlas@example.org").search(QUERY)
    assert [r.url.path for r in recorder.requests] == [
        "/entrez/eutils/esearch.fcgi",
        "/entrez/eutils/esummary.fcgi",
    ]
    assert all(r.url.host == "eutils.ncbi.nlm.nih.gov" for r in recorder.requests)
    assert all(r.url.scheme == "https" and r.method == "GET" for r in recorder.requests)
    assert recorder.params(0) == {
        "db": "pubmed",
        "term": QUERY,
        "retmax": "8",
        "sort": "relevance",
        "retmode": "json",
        "tool": "tagwall",
        "email": "atlas@example.org",
    }
    assert recorder.params(1) == {
        "db": "pubmed",
        "id": ",".join(HIPPOCAMPUS_PMIDS),
        "retmode": "json",
        "tool": "tagwall",
        "email": "atlas@example.org",
    }


@pytest.mark.parametrize("email", [None, ""])
async def test_email_is_sent_only_when_configured(email: str | None) -> None:
    recorder = Recorder()
    await pubmed(recorder, pubmed_email=email).search(QUERY)
    for index in (0, 1):
        assert "email" not in recorder.params(index)
        assert recorder.params(index)["tool"] == "tagwall"


async def test_retmax_follows_the_setting() -> None:
    recorder = Recorder()
    articles = await pubmed(recorder, pubmed_results=2).search(QUERY)
    assert recorder.params(0)["retmax"] == "2"
    # Even if E-utilities sent more than asked for, only that many are asked about.
    assert recorder.params(1)["id"] == "13406589,5124915"
    assert [a.pmid for a in articles] == ["13406589", "5124915"]


@pytest.mark.parametrize(
    "base",
    [
        "http://eutils-mirror.example.org/proxy/eutils",
        "http://eutils-mirror.example.org/proxy/eutils/",
    ],
)
async def test_base_url_is_configurable(base: str) -> None:
    recorder = Recorder()
    await pubmed(recorder, pubmed_url=base).search(QUERY)
    assert [str(r.url).split("?")[0] for r in recorder.requests] == [
        "http://eutils-mirror.example.org/proxy/eutils/esearch.fcgi",
        "http://eutils-mirror.example.org/proxy/eutils/esummary.fcgi",
    ]


# ---------------------------------------------------------------------- answers


async def test_articles_are_read_from_esummary() -> None:
    articles = await pubmed(Recorder()).search(QUERY)
    assert [a.pmid for a in articles] == HIPPOCAMPUS_PMIDS
    first = articles[0]
    assert first.title == "Loss of recent memory after bilateral hippocampal lesions."
    assert first.authors == "Scoville WB, Milner B"
    assert first.journal == "Journal of neurology, neurosurgery, and psychiatry"
    assert first.year == 1957
    assert first.url == "https://pubmed.ncbi.nlm.nih.gov/13406589/"
    assert [a.year for a in articles] == [1957, 1971, 1973, 1998]
    assert articles[2].authors == "Bliss TV, Lomo T"


async def test_esearch_order_is_kept() -> None:
    esearch = fixture("esearch_hippocampus.json")
    esearch["esearchresult"]["idlist"] = ["9809557", "4727084", "13406589", "5124915"]
    articles = await pubmed(Recorder(esearch=esearch)).search(QUERY)
    assert [a.pmid for a in articles] == ["9809557", "4727084", "13406589", "5124915"]


@pytest.mark.parametrize(
    "names,shown",
    [
        ([], ""),
        (["Milner B"], "Milner B"),
        (["Scoville WB", "Milner B"], "Scoville WB, Milner B"),
        (["A A", "B B", "C C"], "A A, B B, C C"),
        (["A A", "B B", "C C", "D D"], "A A, B B, C C, et al."),
    ],
)
def test_authors_are_the_first_three_then_et_al(names: list[str], shown: str) -> None:
    assert format_authors(names) == shown


async def test_seven_authors_read_as_three_et_al() -> None:
    articles = await pubmed(Recorder()).search(QUERY)
    assert articles[3].authors == "Eriksson PS, Perfilieva E, Björk-Eriksson T, et al."


async def test_record_details_are_read_tolerantly() -> None:
    esummary = fixture("esummary_hippocampus.json")
    record = esummary["result"]["13406589"]
    record["title"] = "&lt;i&gt;Fmr1&lt;/i&gt;  knockout   mice."
    record["authors"] = [
        {"name": "ENIGMA Consortium", "authtype": "CollectiveName"},
        {"name": "Editor E", "authtype": "Editor"},
    ]
    record["pubdate"] = ""  # the year then comes from sortpubdate
    del record["fulljournalname"]  # the abbreviation stands in
    other = esummary["result"]["5124915"]
    other["pubdate"] = other["sortpubdate"] = "unknown"
    articles = await pubmed(Recorder(esummary=esummary)).search(QUERY)
    assert articles[0].title == "Fmr1 knockout mice."
    assert articles[0].authors == "ENIGMA Consortium"
    assert articles[0].year == 1957
    assert articles[0].journal == "J Neurol Neurosurg Psychiatry"
    assert articles[1].year is None


async def test_a_record_esummary_cannot_summarise_is_left_out() -> None:
    esummary = fixture("esummary_hippocampus.json")
    esummary["result"]["5124915"] = {"uid": "5124915", "error": "cannot get document summary"}
    articles = await pubmed(Recorder(esummary=esummary)).search(QUERY)
    assert [a.pmid for a in articles] == ["13406589", "4727084", "9809557"]


async def test_zero_hits_is_an_empty_list_without_esummary() -> None:
    recorder = Recorder(esearch=fixture("esearch_empty.json"))
    assert await pubmed(recorder).search("qqxyzzyhippo") == []
    assert len(recorder.requests) == 1


# ---------------------------------------------------------------------- cache


async def test_second_search_is_answered_from_the_cache() -> None:
    recorder = Recorder()
    client = pubmed(recorder)
    first = await client.search(QUERY)
    second = await client.search(QUERY)
    assert first == second
    assert len(recorder.requests) == 2  # esearch and esummary, once
    await client.search("amygdala[tiab]")
    assert len(recorder.requests) == 4  # another query is asked


async def test_cached_results_expire_after_cache_seconds() -> None:
    recorder, clock = Recorder(), Clock()
    client = pubmed(recorder, clock, pubmed_cache_seconds=60)
    await client.search(QUERY)
    clock.now += 59.9
    await client.search(QUERY)
    assert len(recorder.requests) == 2
    clock.now += 0.1
    await client.search(QUERY)
    assert len(recorder.requests) == 4
    clock.now += 30
    await client.search(QUERY)  # fetched anew, so fresh again
    assert len(recorder.requests) == 4


async def test_cache_seconds_zero_asks_every_time() -> None:
    recorder = Recorder()
    client = pubmed(recorder, pubmed_cache_seconds=0)
    await client.search(QUERY)
    await client.search(QUERY)
    assert len(recorder.requests) == 4


async def test_zero_hits_are_cached_too() -> None:
    recorder = Recorder(esearch=fixture("esearch_empty.json"))
    client = pubmed(recorder)
    await client.search("qqxyzzyhippo")
    await client.search("qqxyzzyhippo")
    assert len(recorder.requests) == 1


async def test_cache_keeps_a_bounded_number_of_queries_dropping_the_oldest() -> None:
    recorder = Recorder()
    client = PubMed(Settings(), transport=httpx.MockTransport(recorder), max_cached=2)
    for query in ("a[tiab]", "b[tiab]", "c[tiab]"):
        await client.search(query)
    assert len(recorder.requests) == 6
    await client.search("c[tiab]")
    await client.search("b[tiab]")
    assert len(recorder.requests) == 6  # still cached
    await client.search("a[tiab]")
    assert len(recorder.requests) == 8  # dropped as the oldest


async def test_after_a_failure_searches_answer_offline_at_once_for_a_while() -> None:
    broken = True
    asked: list[str] = []

    def flaky(request: httpx.Request) -> httpx.Response:
        asked.append(request.url.path)
        if broken:
            return httpx.Response(503)
        return Recorder()(request)

    clock = Clock()
    client = PubMed(Settings(), transport=httpx.MockTransport(flaky), clock=clock)
    with pytest.raises(LiteratureUnavailable, match="503"):
        await client.search(QUERY)
    broken = False
    clock.now += RETRY_AFTER_FAILURE_S - 1
    with pytest.raises(LiteratureUnavailable, match="503"):
        await client.search(QUERY)  # resting: no request, the same reason
    assert len(asked) == 1
    clock.now += 1
    assert len(await client.search(QUERY)) == 4  # the failure was not cached


async def test_each_instance_has_its_own_cache() -> None:
    recorder = Recorder()
    await pubmed(recorder).search(QUERY)
    await pubmed(recorder).search(QUERY)
    assert len(recorder.requests) == 4


# ---------------------------------------------------------------------- failures


def raising(error: type[httpx.TransportError]) -> Handler:
    def handler(request: httpx.Request) -> httpx.Response:
        raise error("simulated", request=request)

    return handler


def on_esummary(answer: Handler) -> Handler:
    """esearch answers from the fixture; esummary with ``answer``."""

    def handler(request: httpx.Request) -> httpx.Response:
        if request.url.path.endswith("/esummary.fcgi"):
            return answer(request)
        return httpx.Response(200, json=fixture("esearch_hippocampus.json"))

    return handler


def answering(status: int = 200, **kwargs: Any) -> Handler:
    return lambda request: httpx.Response(status, **kwargs)


def without_result(request: httpx.Request) -> httpx.Response:
    return httpx.Response(200, json={"header": {"type": "esummary", "version": "0.3"}})


def missing_a_record(request: httpx.Request) -> httpx.Response:
    esummary = fixture("esummary_hippocampus.json")
    del esummary["result"]["4727084"]
    return httpx.Response(200, json=esummary)


def untitled(request: httpx.Request) -> httpx.Response:
    esummary = fixture("esummary_hippocampus.json")
    del esummary["result"]["4727084"]["title"]
    return httpx.Response(200, json=esummary)


HTML_PAGE = "<html><body>Service unavailable, try later</body></html>"
FAILURES: dict[str, tuple[Handler, str]] = {
    "timeout": (raising(httpx.ReadTimeout), "PubMed did not answer within 5 s"),
    "connect timeout": (raising(httpx.ConnectTimeout), "PubMed did not answer within 5 s"),
    "refused": (raising(httpx.ConnectError), "PubMed could not be reached"),
    "dropped": (raising(httpx.RemoteProtocolError), "The connection to PubMed failed"),
    "unavailable": (answering(503), "PubMed answered HTTP 503 (Service Unavailable)"),
    "rate limited": (answering(429), "PubMed answered HTTP 429 (Too Many Requests)"),
    "redirect": (answering(302), "PubMed answered HTTP 302 (Found)"),
    "html, not json": (
        answering(200, text=HTML_PAGE),
        "PubMed's answer to esearch was not valid JSON",
    ),
    "no esearchresult": (
        answering(200, json={"header": {"type": "esearch", "version": "0.3"}}),
        "PubMed's search answer had no esearchresult",
    ),
    "not an object": (answering(200, json=[1, 2]), "PubMed's search answer had no esearchresult"),
    "no idlist": (
        answering(200, json={"esearchresult": {"count": "1"}}),
        "PubMed's search answer had no valid idlist",
    ),
    "idlist of numbers": (
        answering(200, json={"esearchresult": {"idlist": [13406589]}}),
        "PubMed's search answer had no valid idlist",
    ),
    "esearch error": (
        answering(200, json={"esearchresult": {"ERROR": "Invalid query"}}),
        "PubMed refused the search: Invalid query",
    ),
    "esummary timeout": (
        on_esummary(raising(httpx.ReadTimeout)),
        "PubMed did not answer within 5 s",
    ),
    "esummary 500": (
        on_esummary(answering(500)),
        "PubMed answered HTTP 500 (Internal Server Error)",
    ),
    "esummary truncated": (
        on_esummary(answering(200, text='{"result": {"uids": ["1340')),
        "PubMed's answer to esummary was not valid JSON",
    ),
    "esummary without result": (
        on_esummary(without_result),
        "PubMed's summary answer had no result",
    ),
    "esummary missing a record": (
        on_esummary(missing_a_record),
        "PubMed's summary answer lacked PMID 4727084",
    ),
    "esummary without title": (
        on_esummary(untitled),
        "PubMed's summary of PMID 4727084 had no title",
    ),
}


@pytest.mark.parametrize("kind", list(FAILURES))
async def test_each_failure_is_unavailable_with_a_reason(kind: str) -> None:
    handler, reason = FAILURES[kind]
    client = pubmed(Recorder(fail=handler))
    with pytest.raises(LiteratureUnavailable) as raised:
        await client.search(QUERY)
    assert raised.value.reason == reason


@pytest.mark.parametrize("kind", list(FAILURES))
async def test_each_failure_shows_the_curated_list_offline(
    kind: str, content: AtlasContent
) -> None:
    handler, reason = FAILURES[kind]
    literature = await literature_for("hippocampus", content, pubmed(Recorder(fail=handler)))
    assert literature.source == "offline"
    assert literature.reason == reason
    assert literature.query == QUERY
    assert literature.articles == []
    research = content.tutors["hippocampus"].research
    assert research is not None
    assert literature.offline == [content.references[r] for r in research.references]
    assert literature.offline[0].citation.startswith("Scoville WB, Milner B (1957)")
    assert literature.offline[0].url == "https://doi.org/10.1136/jnnp.20.1.11"


async def test_the_timeout_bounds_the_whole_search() -> None:
    async def slow(request: httpx.Request) -> httpx.Response:
        await asyncio.sleep(5)
        return httpx.Response(200, json={})

    client = PubMed(Settings(pubmed_timeout=0.05), transport=httpx.MockTransport(slow))
    with pytest.raises(LiteratureUnavailable, match=r"did not answer within 0\.05 s"):
        await client.search(QUERY)


# ---------------------------------------------------------------------- literature_for


async def test_literature_for_a_region_lists_pubmed_articles(content: AtlasContent) -> None:
    recorder = Recorder()
    literature = await literature_for("hippocampus", content, pubmed(recorder))
    assert literature.source == "pubmed"
    assert literature.query == QUERY
    assert recorder.params(0)["term"] == QUERY  # the tutor file's research.search
    assert [a.pmid for a in literature.articles] == HIPPOCAMPUS_PMIDS
    assert literature.offline == [] and literature.reason is None


async def test_literature_for_zero_hits_is_an_empty_pubmed_list(content: AtlasContent) -> None:
    client = pubmed(Recorder(esearch=fixture("esearch_empty.json")))
    literature = await literature_for("hippocampus", content, client)
    assert literature.source == "pubmed" and literature.articles == []


@pytest.mark.parametrize("region", ["memory-seahorse", "no-such-region"])
async def test_a_region_without_research_text_is_a_caller_error(
    region: str, content: AtlasContent
) -> None:
    recorder = Recorder()
    with pytest.raises(ValueError, match=region):
        await literature_for(region, content, pubmed(recorder))
    assert recorder.requests == []


async def test_every_research_region_falls_back_to_its_own_list(content: AtlasContent) -> None:
    offline = pubmed(Recorder(fail=answering(503)))
    for region_id, tutor in content.tutors.items():
        if tutor.research is None:
            continue
        literature = await literature_for(region_id, content, offline)
        assert literature.source == "offline", region_id
        assert len(literature.offline) == len(tutor.research.references), region_id


def test_the_fixtures_keep_the_documented_shape() -> None:
    esearch = fixture("esearch_hippocampus.json")
    assert esearch["header"] == {"type": "esearch", "version": "0.3"}
    assert {"count", "retmax", "retstart", "idlist"} <= esearch["esearchresult"].keys()
    esummary = copy.deepcopy(fixture("esummary_hippocampus.json"))
    uids = esummary["result"].pop("uids")
    assert uids == HIPPOCAMPUS_PMIDS == list(esummary["result"])
    for uid, record in esummary["result"].items():
        assert record["uid"] == uid
        assert {"pubdate", "source", "authors", "title", "fulljournalname"} <= record.keys()
