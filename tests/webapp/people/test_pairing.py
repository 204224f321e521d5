"""Pairing codes: single use, short lived, stored only as a hash."""

from __future__ import annotations

import hashlib
import re
import threading
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta

import pytest
from sqlalchemy import select, update

from webapp.database.connection import Database
from webapp.database.models import PairingRecord
from webapp.people.pairing import TOKEN_LENGTH, PairingError, check_pairing, redeem, start_pairing


def rows(db: Database) -> list[PairingRecord]:
    with db.session() as session:
        return list(session.scalars(select(PairingRecord)))


def test_a_started_code_is_26_alphanumeric_characters_and_checks_valid(db: Database) -> None:
    before = datetime.now(UTC)
    token, expires_at = start_pairing(db, "ines", ttl_s=120)
    assert TOKEN_LENGTH == 26
    assert re.fullmatch(r"[0-9A-Z]{26}", token)
    assert (
        before + timedelta(seconds=119) < expires_at <= datetime.now(UTC) + timedelta(seconds=120)
    )
    assert check_pairing(db, token) == "ines"
    assert check_pairing(db, token) == "ines", "checking does not use the code up"


def test_codes_differ(db: Database) -> None:
    tokens = {start_pairing(db, "ines", ttl_s=120)[0] for _ in range(5)}
    assert len(tokens) == 5


def test_redeeming_says_who_granted_it_and_works_once(db: Database) -> None:
    token, _ = start_pairing(db, "operator", ttl_s=120)
    assert redeem(db, token, "visitor-1") == "operator"
    with pytest.raises(PairingError) as error:
        redeem(db, token, "visitor-2")
    assert error.value.status == 410
    assert "already used" in str(error.value)
    with pytest.raises(PairingError) as checked:
        check_pairing(db, token)
    assert checked.value.status == 410 and "already used" in str(checked.value)
    [record] = rows(db)
    assert record.used_by == "visitor-1" and record.used_at is not None


def test_codes_are_case_insensitive(db: Database) -> None:
    token, _ = start_pairing(db, "ines", ttl_s=120)
    assert check_pairing(db, token.lower()) == "ines"
    assert redeem(db, token.lower(), "visitor-1") == "ines"
    with pytest.raises(PairingError) as error:
        redeem(db, token, "visitor-2")
    assert error.value.status == 410


def test_an_unknown_code_is_404(db: Database) -> None:
    start_pairing(db, "ines", ttl_s=120)
    for attempt in (check_pairing, lambda d, t: redeem(d, t, "visitor-1")):
        with pytest.raises(PairingError) as error:
            attempt(db, "0" * TOKEN_LENGTH)
        assert error.value.status == 404
        assert "not a pairing code" in str(error.value)


def test_an_expired_code_is_410(db: Database) -> None:
    token, _ = start_pairing(db, "ines", ttl_s=120)
    with db.session() as session:
        session.execute(
            update(PairingRecord).values(expires_at=datetime.now(UTC) - timedelta(seconds=1))
        )
    for attempt in (check_pairing, lambda d, t: redeem(d, t, "visitor-1")):
        with pytest.raises(PairingError) as error:
            attempt(db, token)
        assert error.value.status == 410
        assert "expired" in str(error.value)
    [record] = rows(db)
    assert record.used_at is None and record.used_by is None, "an expired code is not used up"


def test_only_the_hash_of_the_code_is_stored(db: Database) -> None:
    token, _ = start_pairing(db, "ines", ttl_s=120)
    [record] = rows(db)
    assert record.token_hash == hashlib.sha256(token.encode()).hexdigest()
    stored = [
        record.token_hash,
        record.granted_by,
        str(record.expires_at),
        str(record.used_at),
        str(record.used_by),
        str(record.created_at),
    ]
    assert not any(token in value or token.lower() in value for value in stored)


def test_two_phones_racing_for_one_code_cannot_both_win(db: Database) -> None:
    for _ in range(5):
        token, _ = start_pairing(db, "ines", ttl_s=120)
        barrier = threading.Barrier(2)

        def attempt(
            visitor_id: str, token: str = token, barrier: threading.Barrier = barrier
        ) -> str:
            barrier.wait()
            try:
                return redeem(db, token, visitor_id)
            except PairingError as error:
                return f"refused {error.status}"

        with ThreadPoolExecutor(max_workers=2) as pool:
            results = list(pool.map(attempt, ["phone-a", "phone-b"]))
        assert sorted(results) == ["ines", "refused 410"], results
        winner = ["phone-a", "phone-b"][results.index("ines")]
        with db.session() as session:
            record = session.get(PairingRecord, hashlib.sha256(token.encode()).hexdigest())
            assert record is not None and record.used_by == winner
