"""The layout of docs/architecture.md names every package and module of the code, and
nothing that is not there.

The layout is a tree drawn in a ``text`` block: a line whose first word ends in ``/`` (a
package) or ``.py`` (a module) names an entry at the depth of its indentation (two spaces
per level); the other lines continue a description. The tree is read back into paths and
compared with the packages ``modelgen`` and ``analysis`` on disk (``__init__.py`` and
``__main__.py`` stand for their package), so a module added without a line, or a line
left for a module that was removed, fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
PACKAGES = ("modelgen", "analysis")
ENTRY = re.compile(r"^( *)([\w<>.-]+(?:/|\.py))(?:\s|$)")


def layout_block(text: str) -> str:
    """The ``text`` block under the page's ``## Layout`` heading."""
    section = text.split("## Layout", 1)[1].split("\n## ", 1)[0]
    return section.split("```text", 1)[1].split("```", 1)[0]


def drawn_paths(block: str) -> set[str]:
    """The paths the tree draws (``analysis/integrate/cost.py``, ``analysis/inference/``)."""
    stack: list[str] = []
    paths = set()
    for line in block.splitlines():
        match = ENTRY.match(line)
        if match is None:
            continue
        indent, name = len(match.group(1)), match.group(2)
        assert indent % 2 == 0, f"odd indentation in the layout: {line!r}"
        depth = indent // 2
        assert depth <= len(stack), f"a line deeper than its package: {line!r}"
        del stack[depth:]
        path = "".join(stack) + name
        paths.add(path)
        if name.endswith("/"):
            stack.append(name)
    return paths


def code_paths() -> set[str]:
    """The packages and modules of ``PACKAGES`` on disk, as the layout draws them."""
    paths = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            rel = path.relative_to(ROOT)
            if "__pycache__" in rel.parts:
                continue
            for depth in range(1, len(rel.parts)):
                paths.add("/".join(rel.parts[:depth]) + "/")
            if path.name not in ("__init__.py", "__main__.py"):
                paths.add(rel.as_posix())
    return paths


def test_the_tree_reader_follows_indentation() -> None:
    block = """
pkg/            a package
  sub/          its sub-package
    leaf.py     a module, with a description that
                goes on over a second line
  top.py        back at the first level
other/
"""
    assert drawn_paths(block) == {"pkg/", "pkg/sub/", "pkg/sub/leaf.py", "pkg/top.py",
                                  "other/"}


def test_the_layout_names_every_package_and_module() -> None:
    drawn = {p for p in drawn_paths(layout_block(PAGE.read_text(encoding="utf-8")))
             if p.split("/", 1)[0] in PACKAGES}
    code = code_paths()
    assert not code - drawn, f"not in docs/architecture.md's layout: {sorted(code - drawn)}"
    assert not drawn - code, f"in the layout but not in the code: {sorted(drawn - code)}"
