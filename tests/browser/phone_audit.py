"""What a person holding a phone meets on a page, measured in Chromium: does it fit the
screen without sideways scrolling, is every control big enough for a thumb, is the type
readable without zooming, and what does axe-core (the npm package, injected into the
page) find for people using assistive technology.

The limits: WCAG 2.5.5's 44 x 44 CSS px targets, 16 px text (below it phones zoom into
form fields and people zoom to read), the content inside the layout viewport.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

from playwright.sync_api import Page

from webapp.core.settings import PROJECT_ROOT

PHONE_WIDTHS = (360, 390, 430)
MIN_TARGET_PX = 44
MIN_TEXT_PX = 16
SERIOUS = ("serious", "critical")
AXE = PROJECT_ROOT / "node_modules" / "axe-core" / "axe.min.js"

# One pass over the page: elements sticking out of the viewport, controls smaller than a
# fingertip, text smaller than the limit (SVG text counted at its drawn size).
MEASURE = """([minTarget, minText, tablesScroll]) => {
  const root = document.documentElement;
  const viewport = root.clientWidth;
  const shown = (el) => {
    const box = el.getBoundingClientRect();
    const style = getComputedStyle(el);
    return box.width > 0 && box.height > 0 && style.visibility !== "hidden";
  };
  const name = (el) => {
    const text = (el.innerText || el.textContent || el.value || "").trim().replace(/\\s+/g, " ");
    return el.tagName.toLowerCase() + (el.id ? "#" + el.id : "") + ` "${text.slice(0, 40)}"`;
  };
  // A data table too wide for the screen may scroll inside its own box (WCAG 1.4.10's
  // two-dimensional exception) where the caller allows it: the page still does not.
  const inScroller = (el) => {
    for (let up = el.parentElement; up && up !== document.body; up = up.parentElement) {
      if (["auto", "scroll"].includes(getComputedStyle(up).overflowX)) return true;
    }
    return false;
  };
  const outside = [];
  for (const el of document.body.querySelectorAll("*")) {
    if (!shown(el) || (tablesScroll && inScroller(el))) continue;
    const box = el.getBoundingClientRect();
    if (box.right > viewport + 0.5 || box.left < -0.5) {
      outside.push(`${name(el)} ${Math.round(box.left)}..${Math.round(box.right)} px`);
    }
  }
  // text sticking out of its element (a long word that does not wrap)
  const range = document.createRange();
  const texts = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let node = texts.nextNode(); node; node = texts.nextNode()) {
    const el = node.parentElement;
    if (!node.textContent.trim() || !el || !shown(el) || (tablesScroll && inScroller(el))) {
      continue;
    }
    range.selectNodeContents(node);
    const box = range.getBoundingClientRect();
    if (box.right > viewport + 0.5) {
      outside.push(`text in ${name(el)} ..${Math.round(box.right)} px`);
    }
  }
  const controls = "a[href], button, input:not([type=hidden]), select, textarea, summary, "
    + "[role=button]";
  const small = [];
  // a checkbox's target is the label around it (a tap on the text ticks it)
  const targets = new Set([...document.querySelectorAll(controls)].map((el) =>
    (el.matches("input[type=checkbox], input[type=radio]") && el.closest("label")) || el));
  for (const el of targets) {
    if (!shown(el)) continue;
    const box = el.getBoundingClientRect();
    if (box.width < minTarget - 0.01 || box.height < minTarget - 0.01) {
      small.push(`${name(el)} ${Math.round(box.width)}x${Math.round(box.height)} px`);
    }
  }
  const tiny = new Set();
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (let node = walker.nextNode(); node; node = walker.nextNode()) {
    const el = node.parentElement;
    if (!node.textContent.trim() || !el || !shown(el)) continue;
    let size = parseFloat(getComputedStyle(el).fontSize);
    if (el instanceof SVGElement && el.ownerSVGElement) {
      size *= el.ownerSVGElement.getScreenCTM().a;
    }
    if (size < minText - 0.01) tiny.add(`${name(el)} ${size.toFixed(1)} px`);
  }
  return {width: root.scrollWidth, viewport, outside, small, tiny: [...tiny]};
}"""

AXE_RUN = """async () => {
  const result = await axe.run(document, {resultTypes: ["violations"]});
  return result.violations.map((v) => ({
    id: v.id, impact: v.impact, help: v.help,
    nodes: v.nodes.slice(0, 3).map((n) => n.target.join(" ")),
  }));
}"""


@dataclass
class Fit:
    """How a page sits on one phone width."""

    width: int  # the page's scroll width, CSS px
    viewport: int
    outside: list[str] = field(default_factory=list)
    small: list[str] = field(default_factory=list)
    tiny: list[str] = field(default_factory=list)

    @property
    def problems(self) -> list[str]:
        found = [f"{self.width} px wide on a {self.viewport} px screen"] * (
            self.width > self.viewport
        )
        found += [f"outside the screen: {item}" for item in self.outside[:4]]
        found += [f"smaller than {MIN_TARGET_PX} px: {item}" for item in self.small[:6]]
        found += [f"text under {MIN_TEXT_PX} px: {item}" for item in self.tiny[:4]]
        return found


def measure(page: Page, *, tables_scroll: bool = False) -> Fit:
    result: dict[str, Any] = page.evaluate(MEASURE, [MIN_TARGET_PX, MIN_TEXT_PX, tables_scroll])
    return Fit(**result)


def fits(
    page: Page, widths: tuple[int, ...] = PHONE_WIDTHS, *, tables_scroll: bool = False
) -> dict[int, Fit]:
    """The page measured at each phone width (the layout reflows; nothing is reloaded).
    ``tables_scroll``: data tables may scroll sideways in their own box (the dashboard)."""
    height = page.viewport_size["height"] if page.viewport_size else 800
    measured = {}
    for width in widths:
        page.set_viewport_size({"width": width, "height": height})
        measured[width] = measure(page, tables_scroll=tables_scroll)
    return measured


@cache
def axe_source(path: Path = AXE) -> str:
    if not path.exists():
        raise FileNotFoundError(f"{path} is missing: `make test` installs axe-core (npm ci)")
    return path.read_text()


def axe_violations(page: Page) -> list[dict[str, Any]]:
    """axe-core's violations on the page as it stands. Evaluated through the DevTools
    protocol, so the page's Content-Security-Policy (no inline script) stays on."""
    if not page.evaluate("typeof window.axe !== 'undefined'"):
        page.evaluate(axe_source())
    violations: list[dict[str, Any]] = page.evaluate(AXE_RUN)
    return violations
