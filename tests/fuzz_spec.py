"""Fuzz the spec loader and the expression parser for a time budget (not part of the suite).

    python -m tests.fuzz_spec --minutes 3 [--seed 1]

Hypothesis draws inputs in rounds until the time is up, alternating two targets:

- *spec loader*: a shipped spec with random edits at the data level (values of any TOML
  type, NaN and infinities, keys removed or added, terms added, custom expression terms
  with random text) and, sometimes, random damage to the TOML text itself, written to a file
  and read by ``load_spec``. A spec that loads is assembled and printed as the generated
  module (``modelgen.codegen.module_source``), whose text must compile.
- *expression parser*: random text, hostile and valid expressions (the strategies of
  tests/modelgen/test_properties.py) through ``parse_expression`` with the audit hook that fails on
  anything run; the valid ones are printed as CasADi code and built.

Anything but a result or the clean error (``SpecError``, ``ExpressionError``) is a crash:
hypothesis shrinks it, the example is printed and the exit code is 1. A single input may
take at most ``--deadline`` seconds (a hang is a crash too).
"""

from __future__ import annotations

import argparse
import copy
import math
import sys
import tempfile
import time
import tomllib
import traceback
from pathlib import Path

import casadi as ca
import tomli_w
from hypothesis import HealthCheck, Phase, given, seed, settings
from hypothesis import strategies as st

from modelgen.assemble import assemble
from modelgen.codegen import CasadiPrinter, module_source
from modelgen.expressions import ExpressionError
from modelgen.quantities import QUANTITIES
from modelgen.spec import SpecError, load_spec, shipped_spec_names, spec_hash
from modelgen.terms import TERMS
from tests.conftest import SPECS
from tests.modelgen.test_properties import HOSTILE, SYMBOLS, VALID, _parse_watched

WORDS = [*QUANTITIES, *TERMS, "kind", "value", "unit", "source", "low", "high", "fx", "fy",
         "ball", "n_balls", "dt", "duration", "transient", "x0", "cage", "variant", "model",
         "name", "title", "structure", "simulation", "parameters", "terms", "k3"]
SCALARS = st.one_of(
    st.booleans(), st.integers(-(10**20), 10**20), st.floats(), st.text(max_size=30),
    st.sampled_from(WORDS), HOSTILE, VALID,
    st.sampled_from([0, 1, -1, 2, 3, 64, 65, 1e-5, 1e308, -0.0, float("nan"), float("inf")]))
VALUES = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.sampled_from(WORDS) | st.text(max_size=8), inner,
                                        max_size=3), max_leaves=6)
stats = {"specs": 0, "loaded": 0, "expressions": 0, "parsed": 0}


def _paths(data, prefix=()):
    """Every (path) to a value in nested dicts and lists."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield (*prefix, key)
        if isinstance(value, (dict, list)):
            yield from _paths(value, (*prefix, key))


def _mutate(draw, data: dict) -> None:
    for _ in range(draw(st.integers(0, 3))):
        paths = list(_paths(data))
        if not paths:
            return
        path = draw(st.sampled_from(paths))
        parent = data
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "delete", "add", "term", "expression",
                                       "valid expression"]))
        try:
            if action == "replace":
                parent[path[-1]] = draw(VALUES)
            elif action == "delete":
                del parent[path[-1]]
            elif action == "add" and isinstance(parent, dict):
                parent[draw(st.sampled_from(WORDS) | st.text(max_size=8))] = draw(VALUES)
            elif action == "term" and isinstance(data.get("terms"), list):
                data["terms"].append({"kind": draw(st.sampled_from(list(TERMS)))})
            elif action == "expression" and isinstance(data.get("terms"), list):
                field = draw(st.sampled_from(["fx", "fy", "ball"]))
                data["terms"].append({"kind": "expression",
                                      field: draw(VALID | HOSTILE | st.text(max_size=40))})
            elif action == "valid expression" and isinstance(data.get("terms"), list):
                field = draw(st.sampled_from(["fx", "fy"]))  # k: a parameter every spec has
                data["terms"].append({"kind": "expression",
                                      field: draw(VALID).replace("k", "rotor_mass")})
        except (KeyError, IndexError, TypeError):
            pass  # an edit that does not apply here (e.g. a key added to a list)


def _damage(draw, text: str) -> str:
    for _ in range(draw(st.integers(1, 3))):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.text(max_size=5)) + text[at + draw(st.integers(0, 5)):]
    return text


@st.composite
def spec_files(draw) -> tuple[str, str]:
    name = draw(st.sampled_from(shipped_spec_names()))
    data = copy.deepcopy(tomllib.loads((SPECS / f"{name}.toml").read_text()))
    _mutate(draw, data)
    try:
        text = tomli_w.dumps(data)
    except (TypeError, ValueError):  # e.g. a list mixing tables and values
        text = (SPECS / f"{name}.toml").read_text()
    if draw(st.integers(0, 4)) == 0:
        text = _damage(draw, text)
    return name, text


def check_spec(folder: Path, name: str, text: str) -> None:
    path = folder / f"{name}.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    stats["specs"] += 1
    try:
        spec, path = load_spec(path)
    except SpecError:
        return
    stats["loaded"] += 1
    source = module_source(spec, assemble(spec), spec_hash(path), path.name)
    compile(source, path.name, "exec")  # syntax only: nothing in it runs here


def check_expression(text: str) -> None:
    stats["expressions"] += 1
    expr = _parse_watched(text)
    if isinstance(expr, ExpressionError):
        return
    stats["parsed"] += 1
    sym = {n: ca.SX.sym(n) for n in SYMBOLS}
    code = CasadiPrinter().doprint(expr)  # our own printer's output, built over CasADi SX
    ca.Function("f", list(sym.values()), [eval(code, {"ca": ca, "math": math, **sym})])


def run(minutes: float, seed_value: int | None, deadline_s: float) -> int:
    with tempfile.TemporaryDirectory(prefix="bearingdyn-fuzz-") as tmp:
        return _rounds(Path(tmp), minutes, seed_value, deadline_s)


def _rounds(folder: Path, minutes: float, seed_value: int | None, deadline_s: float) -> int:
    config = settings(max_examples=200, deadline=deadline_s * 1000, database=None,
                      phases=[Phase.generate, Phase.shrink], print_blob=True,
                      suppress_health_check=list(HealthCheck))

    @config
    @given(spec_files())
    def fuzz_specs(case):
        check_spec(folder, *case)

    @config
    @given(st.text(max_size=200) | HOSTILE | VALID)
    def fuzz_expressions(text):
        check_expression(text)

    start, rounds = time.monotonic(), 0
    targets = [fuzz_specs, fuzz_expressions]
    while time.monotonic() - start < minutes * 60:
        target = targets[rounds % 2]
        if seed_value is not None:
            target = seed(seed_value + rounds)(target)
        try:
            target()
        except Exception as exc:  # a crash, shrunk by hypothesis (the example is in the notes)
            print("".join(traceback.format_exception(exc)), file=sys.stderr)
            print(f"CRASH in {target.__name__}: {type(exc).__name__}: {exc}", file=sys.stderr)
            return 1
        rounds += 1
        print(f"{time.monotonic() - start:6.0f} s  {stats}", file=sys.stderr)
    print(f"no crash in {minutes:g} min: {stats['specs']} specs ({stats['loaded']} valid), "
          f"{stats['expressions']} expressions ({stats['parsed']} valid)")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=3.0, help="time budget")
    parser.add_argument("--seed", type=int, default=None, help="reproducible rounds")
    parser.add_argument("--deadline", type=float, default=5.0,
                        help="longest time one input may take, s")
    args = parser.parse_args(argv)
    return run(args.minutes, args.seed, args.deadline)


if __name__ == "__main__":
    sys.exit(main())
