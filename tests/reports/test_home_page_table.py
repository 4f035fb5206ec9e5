"""The home page's table of pages is current (issue 32, section 4): every top-level page of
docs/ that the repository holds has a row, and every row links a page that exists."""

from __future__ import annotations

import re
import subprocess

from tests.conftest import ROOT

DOCS = ROOT / "docs"


def _pages() -> set[str]:
    """Top-level pages of docs/ known to git (a page being written is not yet due)."""
    try:
        out = subprocess.run(["git", "ls-files", "docs/*.md"], cwd=ROOT, capture_output=True,
                             text=True, timeout=60, check=True).stdout.split()
        names = {p.removeprefix("docs/") for p in out if p.count("/") == 1}
    except (OSError, subprocess.CalledProcessError):
        names = set()
    return names or {p.name for p in DOCS.glob("*.md")}


def _rows() -> list[str]:
    text = (DOCS / "index.md").read_text(encoding="utf-8")
    table = text.split("| page | what it holds |", 1)[1].split("\n\n", 1)[0]
    return re.findall(r"^\| \[([\w.-]+\.md)\]\(\1\) \| (.+) \|$", table, re.M)


def test_every_page_has_a_row_and_every_row_a_page():
    rows = _rows()
    linked = [name for name, _ in rows]
    assert len(linked) == len(set(linked)), "a page listed twice"
    missing = sorted(_pages() - {"index.md"} - set(linked))
    assert not missing, f"docs/index.md's table lacks {missing}"
    for name, what in rows:
        assert (DOCS / name).is_file(), name
        assert len(what.split()) >= 3, (name, what)  # a few words, not a blank cell
