"""Markdown from content files: formatting yes, markup and script links never."""

from __future__ import annotations

from webapp.core.markdown import markdown_html


def test_formatting_becomes_html() -> None:
    html = markdown_html("**Circuit.** In\n\n- one\n- two\n\n[a](https://example.org/)")
    assert "<strong>Circuit.</strong>" in html
    assert "<li>one</li>" in html
    assert '<a href="https://example.org/">a</a>' in html


def test_raw_html_is_escaped_not_rendered() -> None:
    html = markdown_html('<script>alert(1)</script> <img src=x onerror="alert(2)">')
    assert "<script" not in html and "<img" not in html
    assert "&lt;script&gt;" in html


def test_script_links_are_refused() -> None:
    html = markdown_html("[click](javascript:alert(1)) [data](data:text/html;base64,AAAA)")
    assert 'href="javascript' not in html and 'href="data' not in html
