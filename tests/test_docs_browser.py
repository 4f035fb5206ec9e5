"""The documentation site opened from disk (file://, no server, no network) in headless
Chromium: equations are typeset (MathML elements that the browser lays out as math, no TeX
left in the visible text), every navigation link opens a page (an HTML file, never a
directory listing) and search returns results that open pages.

The site is built here with ``mkdocs build --strict`` into a temporary folder. Without the
docs extra they skip with its install line (``needs_extra``: .ci/run's second stage installs
it, and there a skip fails); without Chromium they skip on a developer's machine and fail
under ``CI=true``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import unquote, urlparse

import pytest

from tests.browser import require_chromium, start_chromium
from tests.conftest import ROOT
from tests.extras import require_all

pytestmark = pytest.mark.xdist_group(__name__)
"""This module's tests on one xdist worker (``--dist loadgroup``: tests/conftest.py), so its
module fixtures run once, not once per worker."""
MATH_PAGES = ["model.html", "physics.html", "models/vakharia2015.html"]
TEX_MARKS = ("\\(", "\\)", "\\[", "\\]", "$$", "\\frac", "\\omega")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    require_all(("mkdocs", "material"), "docs")
    require_chromium()
    out = tmp_path_factory.mktemp("site")
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                          str(out)], cwd=ROOT, capture_output=True, text=True, timeout=600,
                         env=dict(os.environ, NO_MKDOCS_2_WARNING="1"))
    assert res.returncode == 0, f"mkdocs build --strict failed:\n{res.stdout}\n{res.stderr}"
    return out


@pytest.fixture(scope="module")
def browser():
    yield from start_chromium()


def _open(browser, path: Path) -> None:
    browser.get(path.as_uri())
    deadline = time.monotonic() + 30
    while browser.execute_script("return document.readyState") != "complete":
        assert time.monotonic() < deadline, f"{path} did not load"
        time.sleep(0.05)


def _local_file(url: str) -> Path:
    parsed = urlparse(url)
    assert parsed.scheme == "file", f"a link leaves the site: {url}"
    return Path(unquote(parsed.path))


@pytest.mark.needs_extra
@pytest.mark.parametrize("page", MATH_PAGES)
def test_equations_are_typeset_as_mathml(site, browser, page):
    _open(browser, site / page)
    found = browser.execute_script("""
        const maths = [...document.querySelectorAll('article math')];
        return {
          count: maths.length,
          mathml: maths.filter(m => m instanceof MathMLElement).length,
          display: [...new Set(maths.map(m => getComputedStyle(m).display))],
          laidOut: maths.filter(m => m.getBoundingClientRect().width > 0).length,
          blocks: maths.filter(m => m.getAttribute('display') === 'block').length,
          fractions: document.querySelectorAll('article math mfrac').length,
          text: document.querySelector('article').innerText,
        };""")
    assert found["count"] >= 5, f"{page}: {found['count']} equations"
    assert found["mathml"] == found["count"]  # the browser's MathML elements, not unknown tags
    assert set(found["display"]) <= {"math", "block math", "inline math"}, found["display"]
    assert found["laidOut"] == found["count"]
    assert found["blocks"] >= 1 and found["fractions"] >= 1
    for mark in TEX_MARKS:
        assert mark not in found["text"], f"{page}: TeX {mark!r} left visible"


@pytest.mark.needs_extra
def test_every_navigation_link_opens_a_page(site, browser):
    _open(browser, site / "index.html")
    links = browser.execute_script(
        "return [...new Set([...document.querySelectorAll('nav.md-nav--primary a.md-nav__link')]"
        ".map(a => a.href).filter(h => h))];")
    pages = sorted({_local_file(h.split("#")[0]) for h in links})
    assert len(pages) >= 40, f"only {len(pages)} pages in the navigation"
    for page in pages:
        assert page.is_file() and page.suffix == ".html", f"nav link to {page}: not a page"
        _open(browser, page)
        title = browser.title
        assert "bearingdyn" in title and not title.startswith("Index of"), (page, title)
        assert browser.execute_script("return !!document.querySelector('article h1')"), page


@pytest.mark.needs_extra
def test_search_finds_pages_from_disk(site, browser):
    _open(browser, site / "stability.html")
    browser.execute_script("document.querySelector('label[for=__search]').click()")
    box = browser.find_element("css selector", "input.md-search__input")
    box.send_keys("Floquet multipliers")
    deadline = time.monotonic() + 30
    hits: list[str] = []
    while time.monotonic() < deadline and not hits:
        hits = browser.execute_script(
            "return [...document.querySelectorAll('.md-search-result__item a')]"
            ".map(a => a.href);")
        time.sleep(0.2)
    assert hits, "search returned nothing (is the index inlined for file://?)"
    meta = browser.find_element("css selector", ".md-search-result__meta").text
    assert "matching" in meta.lower() and not meta.startswith("No"), meta
    first = _local_file(hits[0].split("#")[0])
    assert first.is_file(), first
    _open(browser, first)
    assert "floquet" in browser.find_element("css selector", "article").text.lower()


@pytest.mark.parametrize(("ci", "outcome"), [("true", pytest.fail.Exception),
                                             ("", pytest.skip.Exception)])
def test_without_chromium_ci_fails_and_a_developer_skips(monkeypatch, ci, outcome):
    import tests.browser

    monkeypatch.setenv("CI", ci)
    monkeypatch.setattr(tests.browser.shutil, "which", lambda name: None)
    monkeypatch.setattr(tests.browser, "Path", lambda p: Path("/nonexistent/chromedriver"))
    with pytest.raises(outcome, match="apt-get install -y --no-install-recommends chromium"):
        require_chromium()


def _math_pages(site: Path) -> list[Path]:
    return [p for p in sorted(site.rglob("*.html"))
            if 'class="arithmatex"' in p.read_text(encoding="utf-8", errors="ignore")]


OVERFLOWING = """
    return [...document.querySelectorAll('article .arithmatex')]
      .filter(e => e.scrollWidth > e.clientWidth + 1 ||
                   !['visible', 'clip'].includes(getComputedStyle(e).overflowX))
      .map(e => e.textContent.slice(0, 60));"""


@pytest.mark.needs_extra
def test_no_equation_scrolls_and_wide_ones_wrap(site, browser):
    """At a desktop width no equation on any page is wider than its column (no scroll
    arrows: material's overflow:auto is replaced); on a phone-sized window a wide formula
    breaks over several lines (its pieces at different heights)."""
    pages = _math_pages(site)
    assert len(pages) >= 10
    browser.set_window_size(1280, 900)
    try:
        for page in pages:
            _open(browser, page)
            over = browser.execute_script(OVERFLOWING)
            assert not over, f"{page.relative_to(site)}: equations scroll: {over}"
        browser.set_window_size(420, 900)
        _open(browser, site / "model.html")
        rows = browser.execute_script("""
            return [...document.querySelectorAll('article div.arithmatex')].map(
              d => new Set([...d.querySelectorAll(':scope > math')]
                           .map(m => Math.round(m.getBoundingClientRect().top))).size);""")
        assert max(rows) >= 3, rows  # the equations of motion on three lines or more
        assert not browser.execute_script(OVERFLOWING)
    finally:
        browser.set_window_size(1280, 900)
