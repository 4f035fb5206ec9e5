"""The command line stays a thin layer: it parses, looks up a method, calls the API and
prints (docs/architecture.md, "cli"). Measured on the sources, so it holds for new commands:

* no function of ``analysis/cli`` has a cyclomatic complexity above ``MAX_COMPLEXITY``
  (radon; a command that branches over methods belongs in a method table of the API, as
  ``hb`` and ``torus`` look up ``analysis.frequency.methods``);
* ``hb`` and ``torus``, the commands of issue 31, are under ``MAX_LINES`` lines;
* a method table refuses an unknown method in one line naming the choices.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from analysis.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
CLI = ROOT / "analysis" / "cli"
MAX_COMPLEXITY = 15
MAX_LINES = 60


def test_no_cli_function_is_too_complex():
    radon = pytest.importorskip("radon.complexity")
    found = []
    for path in sorted(CLI.glob("*.py")):
        for block in radon.cc_visit(path.read_text(encoding="utf-8")):
            if block.complexity > MAX_COMPLEXITY:
                found.append(f"{path.name}:{block.lineno} {block.name} {block.complexity}")
    assert not found, f"cyclomatic complexity above {MAX_COMPLEXITY}: {found}"


@pytest.mark.parametrize("command", ["hb", "torus"])
def test_hb_and_torus_only_parse_and_print(command):
    tree = ast.parse((CLI / "frequency.py").read_text(encoding="utf-8"))
    node = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == command)
    lines = node.end_lineno - node.lineno + 1 + len(node.decorator_list)
    assert lines < MAX_LINES, f"{command}: {lines} lines"
    branches = [ast.unparse(n.test) for n in ast.walk(node) if isinstance(n, ast.If)]
    assert not any("method" in test for test in branches), f"{command} branches on the " \
        f"method instead of looking it up: {branches}"


def test_a_method_table_names_its_choices():
    from analysis.frequency.methods import PERIODIC, TORUS, method_of

    assert method_of(TORUS, "shooting").resolution == "points"
    assert method_of(PERIODIC, "hb").resolution == "harmonics"
    with pytest.raises(InputError, match=r"^--method: must be hb or shooting, got 'x'$"):
        method_of(TORUS, "x", "--method")
