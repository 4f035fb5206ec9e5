"""The runnable examples of the package's docstrings are run, as doctests.

Every module of ``analysis`` and ``modelgen`` whose source holds an example (``>>>``) is
found by reading the files, so a new example is tested without being listed here; each
module's examples run with ``doctest`` (``ELLIPSIS`` on; ``# doctest: +SKIP`` for an
example that takes minutes). The test fails on a wrong output, an exception, and on a
module with ``>>>`` in its source where doctest finds no example.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("analysis", "modelgen")


def example_modules() -> list[str]:
    """Dotted names of the modules whose source holds ``>>>``."""
    names = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if ">>> " in path.read_text(encoding="utf-8"):
                parts = list(path.relative_to(ROOT).with_suffix("").parts)
                if parts[-1] == "__init__":
                    parts.pop()
                names.append(".".join(parts))
    return names


def test_examples_are_found():
    found = example_modules()
    assert "analysis.errors" in found and "analysis.model" in found, found


@pytest.mark.parametrize("name", example_modules())
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    examples = sum(len(t.examples) for t in doctest.DocTestFinder().find(module))
    assert examples > 0, f"{name}: '>>>' in its source, but doctest finds no example"
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, report=True)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"
