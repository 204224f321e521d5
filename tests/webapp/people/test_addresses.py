"""Where a request comes from (behind trusted proxies) and which address rule covers it."""

from __future__ import annotations

from ipaddress import IPv4Network, IPv6Network

import pytest

from webapp.database.models import AddressRuleRecord
from webapp.people.addresses import Network, client_address, matching_rule, parse_network

PROXIES: list[Network] = [parse_network("10.0.0.0/8")]


def rule(network: str) -> AddressRuleRecord:
    return AddressRuleRecord(network=network, role=None, user_group=None, info_class=None, note="")


# --- client_address -------------------------------------------------------------


def test_without_trusted_proxies_the_peer_is_the_client_whatever_the_header_says() -> None:
    assert client_address("203.0.113.5", "198.51.100.7", []) == "203.0.113.5"
    assert client_address("10.0.0.1", "198.51.100.7, 10.0.0.2", []) == "10.0.0.1"


def test_an_untrusted_peer_is_the_client_even_with_a_forwarded_header() -> None:
    assert client_address("203.0.113.5", "198.51.100.7", PROXIES) == "203.0.113.5"


def test_behind_a_trusted_peer_the_rightmost_untrusted_hop_is_the_client() -> None:
    assert client_address("10.0.0.1", "198.51.100.7", PROXIES) == "198.51.100.7"
    assert client_address("10.0.0.1", "198.51.100.7, 10.0.0.2", PROXIES) == "198.51.100.7"
    assert client_address("10.0.0.1", " 198.51.100.7 ,10.0.0.2 ", PROXIES) == "198.51.100.7"


def test_when_every_hop_is_trusted_the_peer_is_the_client() -> None:
    assert client_address("10.0.0.1", "10.0.0.3, 10.0.0.2", PROXIES) == "10.0.0.1"
    assert client_address("10.0.0.1", None, PROXIES) == "10.0.0.1"
    assert client_address("10.0.0.1", "", PROXIES) == "10.0.0.1"
    assert client_address("10.0.0.1", " , ,", PROXIES) == "10.0.0.1"


def test_a_garbled_header_falls_back_to_the_peer() -> None:
    assert client_address("10.0.0.1", "198.51.100.7, not-an-address", PROXIES) == "10.0.0.1"
    assert client_address("10.0.0.1", "unknown", PROXIES) == "10.0.0.1"


def test_a_peer_that_is_not_an_address_is_returned_as_it_is() -> None:
    assert client_address("testclient", "198.51.100.7", PROXIES) == "testclient"


def test_ipv6_proxies_and_clients() -> None:
    proxies = [parse_network("fd00::/8")]
    assert client_address("fd00::1", "2001:DB8::5, fd00::2", proxies) == "2001:db8::5"
    assert client_address("2001:db8::9", "2001:db8::5", proxies) == "2001:db8::9"
    # an IPv4 proxy network does not make an IPv6 peer trusted, nor the reverse
    assert client_address("fd00::1", "198.51.100.7", PROXIES) == "fd00::1"
    assert client_address("10.0.0.1", "2001:db8::5", proxies) == "10.0.0.1"


def test_hops_the_client_wrote_left_of_an_untrusted_one_are_ignored() -> None:
    # The client sends "X-Forwarded-For: 10.9.9.9" (or any address it likes); our
    # proxy appends the address it saw, so the real one is the rightmost untrusted.
    assert client_address("10.0.0.1", "10.9.9.9, 198.51.100.7", PROXIES) == "198.51.100.7"
    assert client_address("10.0.0.1", "1.2.3.4, 198.51.100.7, 10.0.0.2", PROXIES) == "198.51.100.7"
    assert client_address("10.0.0.1", "junk, 198.51.100.7", PROXIES) == "198.51.100.7"


# --- parse_network ---------------------------------------------------------------


def test_a_bare_address_is_a_single_host_network() -> None:
    assert parse_network("10.1.2.3") == IPv4Network("10.1.2.3/32")
    assert parse_network(" 2001:db8::1 ") == IPv6Network("2001:db8::1/128")


def test_networks_parse_and_host_bits_are_dropped() -> None:
    assert parse_network("10.1.0.0/16") == IPv4Network("10.1.0.0/16")
    assert parse_network("10.1.2.3/16") == IPv4Network("10.1.0.0/16")
    assert parse_network("2001:db8::/32") == IPv6Network("2001:db8::/32")


@pytest.mark.parametrize("text", ["", "nonsense", "10.0.0.0/33", "10.0.0.256", "10.0.0.0/x"])
def test_junk_is_a_value_error_that_says_what_is_expected(text: str) -> None:
    with pytest.raises(ValueError) as error:
        parse_network(text)
    assert str(error.value) == f"{text!r} is not an address or network like 10.1.0.0/16"


# --- matching_rule ---------------------------------------------------------------


def test_the_most_specific_rule_wins_in_any_order() -> None:
    wide, middle, narrow = rule("10.0.0.0/8"), rule("10.9.0.0/16"), rule("10.9.8.0/24")
    for rules in ([wide, middle, narrow], [narrow, middle, wide], [middle, narrow, wide]):
        assert matching_rule("10.9.8.7", rules) is narrow
        assert matching_rule("10.9.1.1", rules) is middle
        assert matching_rule("10.200.0.1", rules) is wide


def test_a_single_host_rule_beats_its_network() -> None:
    host, network = rule("10.9.8.7"), rule("10.9.0.0/16")
    assert matching_rule("10.9.8.7", [network, host]) is host
    assert matching_rule("10.9.8.6", [network, host]) is network


def test_no_matching_rule_is_none() -> None:
    assert matching_rule("192.168.1.1", [rule("10.0.0.0/8")]) is None
    assert matching_rule("10.0.0.1", []) is None


def test_an_ipv4_rule_never_matches_an_ipv6_address() -> None:
    everything_v4 = rule("0.0.0.0/0")
    assert matching_rule("2001:db8::1", [everything_v4]) is None
    assert matching_rule("::ffff:10.0.0.1", [rule("10.0.0.0/8")]) is None
    v6 = rule("2001:db8::/32")
    assert matching_rule("2001:db8::1", [everything_v4, v6]) is v6
    assert matching_rule("10.0.0.1", [v6]) is None


def test_a_client_that_is_not_an_address_matches_nothing() -> None:
    assert matching_rule("testclient", [rule("0.0.0.0/0"), rule("::/0")]) is None
    assert matching_rule("", [rule("0.0.0.0/0")]) is None
