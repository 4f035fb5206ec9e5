"""The examples of docs/architecture.md that are not tested elsewhere run from the page.

A ``python`` block under a heading named here is executed as it stands; its last comment
line (``# …``) is what it prints. The page and the test cannot drift apart: a renamed
function, a changed signature or a different result fails here.
"""

from __future__ import annotations

import contextlib
import io
import re
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
EXAMPLES = ("Adding a device", "Adding a study")


def example(heading: str) -> tuple[str, str]:
    """(code, expected output) of the first python block under ``### heading``."""
    text = PAGE.read_text(encoding="utf-8")
    section = text.split(f"### {heading}\n", 1)[1].split("\n## ", 1)[0]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    expected = [line[2:] for line in code.rstrip().splitlines() if line.startswith("# ")]
    return code, expected[-1]


@pytest.mark.parametrize("heading", EXAMPLES)
def test_the_page_example_runs_and_prints_what_it_says(heading):
    code, expected = example(heading)
    out = io.StringIO()
    module = types.ModuleType("example")  # a real module: a dataclass looks itself up there
    sys.modules["example"] = module
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(code, f"{PAGE.name}: {heading}", "exec"), module.__dict__)
    finally:
        del sys.modules["example"]
    assert out.getvalue().strip() == expected
