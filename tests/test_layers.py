"""The layer table of docs/architecture.md holds for every import of the package.

Every module of ``analysis`` is read with the standard library's ``ast``; every import is
counted, the lazy ones inside functions included. The test fails on

* a module the table does not place in a layer;
* an import that climbs a layer (a module importing one of a later row of the table);
* a circle of imports between modules (within one layer too);
* an underscored name taken from another module (``from analysis.x import _helper``), or
  reached by attribute from another module (``module._helper``, ``functions._derivative``:
  an underscored attribute a module uses but does not define, defined in another module of
  the package or of ``generated``).

The table is read from the page itself, so the page and the code cannot drift apart.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
PACKAGES = ("analysis",)
GENERATED = ROOT / "generated"


def layer_table() -> list[tuple[str, tuple[str, ...]]]:
    """(layer, module prefixes) per row of the page's layer table, first row first."""
    text = PAGE.read_text(encoding="utf-8")
    section = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not line.lstrip().startswith("|"):
            continue
        names = tuple(re.findall(r"`(analysis(?:\.\w+)*)`", cells[1]))
        if names:
            rows.append((cells[0], names))
    return rows


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for package in PACKAGES
            for p in sorted((ROOT / package).rglob("*.py"))}


def imports(name: str, path: Path) -> list[tuple[str, list[str], int]]:
    """(imported module, names taken from it, line) of every import in the module, lazy
    ones included; relative imports resolved."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name, [], node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append((target, [a.name for a in node.names], node.lineno))
    return found


def internal(target: str, names: list[str], known: dict[str, Path]) -> list[str]:
    """The package modules an import statement loads: the module itself, and each name of a
    ``from package import module`` that is a module."""
    out = []
    if target in known:
        out.append(target)
    out += [f"{target}.{n}" for n in names if f"{target}.{n}" in known]
    return out


def layer_of(module: str, table) -> int | None:
    best, index = -1, None
    for i, (_, prefixes) in enumerate(table):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, index = len(prefix), i
    return index


KNOWN = modules()
TABLE = layer_table()


def graph() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {m: set() for m in KNOWN}
    for name, path in KNOWN.items():
        for target, names, _ in imports(name, path):
            for other in internal(target, names, KNOWN):
                if other != name and not name.startswith(other + "."):
                    edges[name].add(other)
    return edges


def test_the_page_has_a_layer_table():
    assert len(TABLE) >= 5, TABLE


def test_every_module_has_a_layer():
    missing = [m for m in KNOWN if m not in PACKAGES and layer_of(m, TABLE) is None]
    assert not missing, f"modules the layer table of {PAGE.name} does not place: {missing}"


def test_no_import_climbs_a_layer():
    climbs = []
    for name, path in KNOWN.items():
        mine = layer_of(name, TABLE)
        if mine is None:
            continue
        for target, names, line in imports(name, path):
            for other in internal(target, names, KNOWN):
                theirs = layer_of(other, TABLE)
                if theirs is not None and theirs > mine:
                    climbs.append(f"{path.relative_to(ROOT)}:{line} {name} "
                                  f"({TABLE[mine][0]}) imports {other} ({TABLE[theirs][0]})")
    assert not climbs, "imports that climb a layer:\n" + "\n".join(climbs)


def find_circle(edges: dict[str, set[str]]) -> list[str] | None:
    """One circle of the graph, as a path that ends where it starts, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_no_import_circle():
    circle = find_circle(graph())
    assert circle is None, "import circle: " + " -> ".join(circle or [])


def test_the_circle_finder_finds_a_circle():
    assert find_circle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_circle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_no_underscored_name_crosses_a_module():
    taken = []
    for name, path in KNOWN.items():
        for target, names, line in imports(name, path):
            if not target.startswith(PACKAGES) or target == name:
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            private += [p for p in target.split(".") if p.startswith("_")
                        and not p.startswith("__")]
            if private:
                taken.append(f"{path.relative_to(ROOT)}:{line} takes {', '.join(private)} "
                             f"from {target}")
    assert not taken, "underscored names taken across modules:\n" + "\n".join(taken)


def underscored_defined(tree: ast.AST) -> set[str]:
    """The underscored names a module defines: functions, classes, assigned names and
    attributes, arguments."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
    return {n for n in names if n.startswith("_") and not n.startswith("__")}


def foreign_attributes(tree: ast.AST, elsewhere: set[str]) -> list[tuple[int, str]]:
    """(line, text) of each attribute access ``x._name`` whose name the module does not
    define but another module of ours (``elsewhere``) does."""
    own = underscored_defined(tree)
    return [(node.lineno, ast.unparse(node)) for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and node.attr in elsewhere - own]


def test_no_underscored_attribute_crosses_a_module():
    trees = {path: ast.parse(path.read_text(encoding="utf-8")) for path in
             [*KNOWN.values(), *sorted(GENERATED.rglob("*.py"))]}
    defined = {path: underscored_defined(tree) for path, tree in trees.items()}
    reached = []
    for path in KNOWN.values():
        elsewhere = set().union(*(d for p, d in defined.items() if p != path))
        reached += [f"{path.relative_to(ROOT)}:{line} reaches {text}"
                    for line, text in foreign_attributes(trees[path], elsewhere)]
    assert not reached, "underscored attributes reached across modules:\n" + \
        "\n".join(reached)


def test_the_attribute_check_sees_a_foreign_attribute():
    tree = ast.parse("def f(functions):\n    return functions._derivative(1)\n")
    assert foreign_attributes(tree, {"_derivative"}) == [(2, "functions._derivative")]
    own = ast.parse("class A:\n    def __init__(self):\n        self._x = 1\n"
                    "    def y(self):\n        return self._x\n")
    assert foreign_attributes(own, {"_x"}) == []


@pytest.mark.parametrize("source, expected", [
    ("from analysis.integrate.simulate import simulate\n", ["analysis.integrate.simulate"]),
    ("def f():\n    from ..signal import poincare\n",
     ["analysis.signal", "analysis.signal.poincare"]),
    ("import analysis.model as m\n", ["analysis.model"]),
])
def test_imports_are_read_lazy_and_relative_alike(tmp_path, source, expected):
    path = tmp_path / "probe.py"
    path.write_text(source)
    found = [m for target, names, _ in imports("analysis.stability.probe", path)
             for m in internal(target, names, KNOWN)]
    assert found == expected
