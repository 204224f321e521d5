"""The names downloads get."""

from __future__ import annotations

from webapp.web.downloads import attachment, file_slug


def test_a_file_name_keeps_only_letters_digits_and_dashes() -> None:
    assert file_slug("Anatomie für Ärzte, Gruppe B") == "anatomie-fur-arzte-gruppe-b"
    assert file_slug('../"; rm -rf /') == "rm-rf"
    assert file_slug("日本語") == ""


def test_an_attachment_names_its_parts_and_never_breaks_the_header() -> None:
    assert attachment(["demo", "", "Anatomy B", "round-3", "2026-11-27"], ".csv") == (
        'attachment; filename="demo-anatomy-b-round-3-2026-11-27.csv"'
    )
    assert attachment(['"\r\nSet-Cookie: x=1'], ".csv") == (
        'attachment; filename="set-cookie-x-1.csv"'
    )
    assert attachment(["日本語"], ".csv") == 'attachment; filename="download.csv"'
    assert len(attachment(["x" * 500], ".csv")) < 160


def test_an_attachment_says_each_thing_once() -> None:
    """Issue 41: a class titled after its wall gave ``demo-demo-lab-...``."""
    assert attachment(["demo", "Demo lab", "round-3", "2026-11-27"], ".csv") == (
        'attachment; filename="demo-lab-round-3-2026-11-27.csv"'
    )
    untitled = ["demo", "Class of 2026-11-27 09:30", "round-3", "2026-11-27"]
    assert attachment(untitled, ".csv") == (
        'attachment; filename="demo-class-of-2026-11-27-09-30-round-3.csv"'
    )
    assert attachment(["demo", "Demo"], ".csv") == 'attachment; filename="demo.csv"'
    assert attachment(["demo", "Democracy"], ".csv") == (  # a word, not a part of one
        'attachment; filename="demo-democracy.csv"'
    )
