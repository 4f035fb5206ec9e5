"""The catalogue of bad inputs: every one ends with one line naming the field and what is
allowed, exit code 2, no traceback (``--debug`` shows it).

Two tables. ``SPEC_CASES``: a shipped spec with one edit, written to a temporary folder and
loaded (``load_spec``, the first thing ``bearingdyn generate`` does; two of them also go
through the command). ``CLI_CASES``: the real ``bearingdyn`` command in a temporary folder.
The commands are slow to start (about 1 s each), so they all run at once, in parallel, when
the first test needs them (``cli_outcomes``); every test then checks its own.

``python -m tests.cli.test_bad_inputs`` writes docs/bad-inputs.md from these tables and the
messages they produce; ``test_docs_table_is_current`` keeps the two in step.
"""

from __future__ import annotations

import copy
import json
import os
import re
import sys
import threading
import tomllib
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
import xarray as xr

from modelgen.spec import SpecError, load_spec
from tests.conftest import ROOT, SPECS, run_cli

DOCS = ROOT / "docs" / "bad-inputs.md"
DROP = object()
"""Edit value: remove the key."""
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


# ---------------------------------------------------------------- spec files

@dataclass(frozen=True)
class SpecCase:
    """A shipped spec (``base``) with ``edits`` (dotted path -> value; ``terms.+`` appends)."""

    id: str
    group: str
    what: str
    edits: tuple[tuple[str, Any], ...]
    expect: tuple[str, ...]
    base: str = "vakharia2015"
    text: str | None = None
    """Raw file text instead of edits (for files that are not TOML)."""

    def write(self, folder: Path) -> Path:
        path = folder / f"{self.base}.toml"
        if self.text is not None:
            path.write_text(self.text)
            return path
        data = tomllib.loads((SPECS / f"{self.base}.toml").read_text())
        for dotted, value in self.edits:
            _edit(data, dotted, value)
        path.write_text(tomli_w.dumps(data))
        return path

    def shown(self) -> str:
        if self.text == "":
            return f"no file `{self.base}.toml`"
        if self.text is not None:
            return f"file text `{self.text.strip()}`"
        return "; ".join(f"`{p}` removed" if v is DROP else f"`{p} = {_inline(v)}`"
                         for p, v in self.edits)


def _edit(data: Any, dotted: str, value: Any) -> None:
    value = copy.deepcopy(value) if value is not DROP else DROP
    *parents, last = [int(k) if k.isdigit() else k for k in dotted.split(".")]
    for key in parents:
        data = data[key]
    if last == "+":
        data.append(value)
    elif value is DROP:
        del data[last]
    else:
        data[last] = value


def _inline(value: Any) -> str:
    """A value as inline TOML, for the docs."""
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_inline(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list):
        return "[" + ", ".join(_inline(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value if len(value) <= 50 else value[:24] + "…" + value[-24:],
                          ensure_ascii=False)
    if isinstance(value, float) and not np.isfinite(value):
        return "nan" if np.isnan(value) else ("inf" if value > 0 else "-inf")
    return str(value)


def expression(**fields: str) -> tuple[str, dict]:
    """Edit that appends a custom expression term."""
    return ("terms.+", {"kind": "expression", **fields})


K3 = ("parameters.k3", {"value": 1e15, "unit": "N/m^3", "source": "test", "low": 0.0,
                        "high": 1e20})
"""A user-declared parameter, as an edit."""
P = "parameters"

SPEC_CASES = [
    # wrong types
    SpecCase("number-as-text", "wrong type", "a number in quotes",
             ((f"{P}.rotor_mass.value", "0.6"),),
             ("parameters.rotor_mass.value: must be a number in (0, 100000] kg, got '0.6'",)),
    SpecCase("fractional-balls", "wrong type", "a fractional number of balls",
             (("structure.n_balls", 6.5),),
             ("structure.n_balls: must be a whole number in [3, 64], got 6.5",)),
    SpecCase("parameter-not-table", "wrong type", "a parameter without its table",
             ((f"{P}.damping", 200.0),), ("parameters.damping: must be a table, got 200.0",)),
    SpecCase("terms-not-list", "wrong type", "terms not a list of tables",
             (("terms", "hertz_contact"),),
             ("terms: must be a list of tables ([[…]]), got 'hertz_contact'",)),
    SpecCase("title-not-text", "wrong type", "text field given a number",
             (("model.title", 5),), ("model.title: must be text in quotes, got 5",)),
    SpecCase("not-toml", "wrong type", "a file that is not TOML", (),
             ("vakharia2015.toml: not valid TOML", "line 1"), text="speed = = 5000\n"),
    # missing fields
    SpecCase("missing-section", "missing field", "a required section left out",
             (("model", DROP),), ("model: missing required field",)),
    SpecCase("missing-source", "missing field", "a parameter without its source",
             ((f"{P}.damping.source", DROP),),
             ("parameters.damping.source: missing required field",)),
    SpecCase("missing-parameter", "missing field", "a parameter a term needs",
             ((f"{P}.contact_stiffness", DROP),),
             ("parameters.contact_stiffness: missing; terms[0] (hertz_contact) needs it "
              "(allowed range (0, 1e+13] N/m^1.5)",)),
    SpecCase("missing-structure", "missing field", "balls not given with a contact term",
             (("structure", DROP),),
             ("terms[0] (hertz_contact): acts on the balls and needs a bearing ([structure] "
              "n_balls in a one-body spec, else [[bearings]]) with a 'hertz_contact' term",)),
    SpecCase("missing-kind", "missing field", "a term without its kind",
             (("terms.1", {"variant": "paper_eq9"}),),
             ("terms[1].kind: missing; allowed: hertz_contact, centrifugal",)),
    SpecCase("empty-terms", "missing field", "no terms at all", (("terms", []),),
             ("terms: must not be empty",)),
    SpecCase("file-missing", "missing field", "a spec file that does not exist", (),
             ("nothere.toml: file not found",), base="nothere", text=""),
    # unknown fields
    SpecCase("field-typo", "unknown field", "a misspelt field",
             (("structure.n_bals", 6),),
             ("structure.n_bals: unknown field (did you mean 'n_balls'?)",)),
    SpecCase("section-typo", "unknown field", "a misspelt section",
             (("simulaton", {"dt": 1e-5}),),
             ("simulaton: unknown field (did you mean 'simulation'?)",)),
    SpecCase("parameter-typo", "unknown field", "a misspelt parameter",
             ((f"{P}.dampign", {"value": 1.0, "unit": "N*s/m", "source": "x"}),),
             ("parameters.dampign: unknown parameter (did you mean 'damping'?)",
              "a new parameter needs its allowed range: low = …, high = …")),
    SpecCase("term-typo", "unknown field", "a misspelt term kind",
             (("terms.0.kind", "hertz_contakt"),),
             ("terms[0].kind: unknown term 'hertz_contakt' (did you mean 'hertz_contact'?); "
              "allowed:",)),
    SpecCase("variant-typo", "unknown field", "a misspelt choice",
             (("terms.0.cage", "race_diameter"),),
             ("terms[0] (hertz_contact).cage: must be 'race_diameters' or 'pitch_diameter', got "
              "'race_diameter' (did you mean 'race_diameters'?)",)),
    SpecCase("name-mismatch", "unknown field", "model name differs from the file name",
             (("model.name", "other"),),
             ("model.name: must equal the file name 'vakharia2015', got 'other'",)),
    SpecCase("bad-model-name", "unknown field", "a model name that is not a module name",
             (("model.name", "Vakharia 2015"),),
             ("model.name: must be lower case letters, digits and '-', starting with a letter",
              "got 'Vakharia 2015'")),
    SpecCase("title-breaks-code", "unknown field", "a title that would end a code comment",
             (("model.title", 'x"""; import os; """'),),
             ("model.title: must be one line without '\"\"\"' (it is copied into generated "
              "code comments)",)),
    # units and ranges
    SpecCase("wrong-unit", "units and ranges", "a unit other than the quantity's",
             ((f"{P}.radial_load.unit", "kN"),),
             ("parameters.radial_load.unit: must be 'N', got 'kN'",)),
    SpecCase("negative-mass", "units and ranges", "negative mass",
             ((f"{P}.rotor_mass.value", -0.6),),
             ("parameters.rotor_mass.value: must be in (0, 100000] kg, got -0.6",)),
    SpecCase("negative-stiffness", "units and ranges", "negative contact stiffness",
             ((f"{P}.contact_stiffness.value", -7e9),),
             ("parameters.contact_stiffness.value: must be in (0, 1e+13] N/m^1.5, got -7e+09",)),
    SpecCase("negative-damping", "units and ranges", "negative damping",
             ((f"{P}.damping.value", -1.0),),
             ("parameters.damping.value: must be in [0, 1e+07] N*s/m, got -1",)),
    SpecCase("negative-speed", "units and ranges", "negative speed",
             ((f"{P}.speed_rpm.value", -5000.0),),
             ("parameters.speed_rpm.value: must be in [0, 1e+06] rpm, got -5000",)),
    SpecCase("races-swapped", "units and ranges", "inner race not inside the outer race",
             ((f"{P}.inner_race_diameter.value", 30e-3),),
             ("parameters.inner_race_diameter: must be smaller than outer_race_diameter "
              "(0.028262 m), got 0.03 m",)),
    SpecCase("ball-too-large", "units and ranges", "ball diameter larger than the race gap",
             ((f"{P}.ball_diameter.value", 5e-3),),
             ("parameters.ball_diameter: must be at most the race gap (outer_race_diameter − "
              "inner_race_diameter)/2 = 0.004762 m, got 0.005 m",)),
    SpecCase("pitch-outside-races", "units and ranges", "pitch circle outside the races",
             ((f"{P}.pitch_diameter.value", 30e-3),),
             ("parameters.pitch_diameter: must be in (0.018738, 0.028262) m, between the "
              "races, got 0.03 m",)),
    SpecCase("too-few-balls", "units and ranges", "fewer than 3 balls",
             (("structure.n_balls", 2),), ("structure.n_balls: must be in [3, 64], got 2",)),
    SpecCase("absurd-balls", "units and ranges", "an absurd number of balls",
             (("structure.n_balls", 1000),),
             ("structure.n_balls: must be in [3, 64], got 1000",)),
    SpecCase("balls-do-not-fit", "units and ranges", "more balls than fit on the pitch circle",
             (("structure.n_balls", 30),),
             ("structure.n_balls: must be in [3, 17]: at most 17 balls of 0.004762 m fit on "
              "the pitch circle (0.026725 m), got 30",)),
    SpecCase("nan-value", "units and ranges", "NaN as a value (TOML `nan`)",
             ((f"{P}.damping.value", float("nan")),),
             ("parameters.damping.value: must be a finite number in [0, 1e+07] N*s/m, "
              "got nan",)),
    SpecCase("inf-step", "units and ranges", "infinity as a time (TOML `inf`)",
             (("simulation.dt", float("inf")),),
             ("simulation.dt: must be a finite number in (0, 10] s, got inf",)),
    SpecCase("inf-initial-state", "units and ranges", "infinite initial state",
             (("simulation.x0", float("-inf")),),
             ("simulation.x0: must be a finite number (m), got -inf",)),
    SpecCase("zero-step", "units and ranges", "a time step of zero",
             (("simulation.dt", 0.0),), ("simulation.dt: must be in (0, 10] s, got 0.0",)),
    SpecCase("transient-too-long", "units and ranges", "duration shorter than the transient",
             (("simulation.transient", 5.0),),
             ("simulation.transient: must be shorter than simulation.duration (3 s)",)),
    SpecCase("duplicate-term", "units and ranges", "a built-in term twice",
             (("terms.+", {"kind": "radial_load"}),),
             ("terms: 'radial_load' appears 2 times; at most once",)),
    SpecCase("centrifugal-without-contact", "units and ranges", "a ball term without a "
             "contact", (("terms.0", {"kind": "centrifugal", "variant": "paper_eq9"}),),
             ("structure: bearing 'bearing' has no contact term; add [[terms]] kind = "
              "'hertz_contact' (or 'two_contact') for it, or remove the bearing",)),
    SpecCase("ball-term-without-balls", "units and ranges", "a ball load without a contact",
             (expression(ball="1e9*c"),), base="duffing",
             expect=("terms[3] (expression): acts on the balls and needs a bearing "
                     "([structure] n_balls in a one-body spec, else [[bearings]])",)),
    # bodies and bearings
    SpecCase("bearing-unknown-body", "bodies and bearings", "a bearing on a body that does not "
             "exist", (("bearings.0.outer", "housnig"),), base="rotor-housing",
             expect=("bearings[0].outer: unknown body 'housnig' (did you mean 'housing'?); "
                     "bodies: rotor, housing, ground",)),
    SpecCase("bearing-same-body", "bodies and bearings", "a bearing from a body to itself",
             (("bearings.0.outer", "rotor"),), base="rotor-housing",
             expect=("bearings[0].outer: must differ from the inner body",)),
    SpecCase("body-name-twice", "bodies and bearings", "two bodies of one name",
             (("bodies.1.name", "rotor"),), base="rotor-housing",
             expect=("bodies/bearings: the name 'rotor' is used 2 times",)),
    SpecCase("body-motion-unknown", "bodies and bearings", "an unknown motion",
             (("bodies.0.motion", "spinning"),), base="rotor-housing",
             expect=("bodies[0].motion: must be 'planar', 'linear' or 'planar_tilt', got "
                     "'spinning'",)),
    SpecCase("bearing-on-linear-body", "bodies and bearings", "a bearing on a body that moves "
             "along x only", (("bodies.1.motion", "linear"),), base="rotor-housing",
             expect=("bearings[0].outer: body 'housing' moves along x only; a bearing needs "
                     "planar bodies",)),
    SpecCase("term-unknown-bearing", "bodies and bearings", "a term on a bearing that does "
             "not exist", (("terms.0.bearing", "left"),), base="rotor-housing",
             expect=("terms[0] (hertz_contact).bearing: unknown bearing 'left'; bearings: "
                     "bearing",)),
    SpecCase("term-owner-missing", "bodies and bearings", "a term that does not say which of "
             "two bearings it belongs to", (("terms.0.bearing", DROP),),
             base="two-bearing-rotor",
             expect=("terms[0] (hertz_contact).bearing: missing; name the bearing it acts on, "
                     "one of: left, right",)),
    SpecCase("load-on-a-bearing", "bodies and bearings", "a load attached to a bearing",
             (("terms.2.bearing", "bearing"),), base="rotor-housing",
             expect=("terms[2] (radial_load).bearing: this term acts on a body",)),
    SpecCase("bearing-balls-do-not-fit", "bodies and bearings", "more balls than fit one "
             "bearing", (("bearings.1.n_balls", 20),), base="two-bearing-rotor",
             expect=("bearings[1].n_balls: must be in [3, 15]: at most 15 balls of 0.004762 m "
                     "fit on the pitch circle (0.0235 m), got 20",)),
    SpecCase("structure-and-bearings", "bodies and bearings", "[structure] beside [[bearings]]",
             (("structure", {"n_balls": 8}),), base="rotor-housing",
             expect=("structure: only in a spec without [[bodies]] and [[bearings]]",)),
    SpecCase("initial-unknown-state", "bodies and bearings", "an initial value of a state the "
             "model does not have", (("simulation.initial.x", 1e-6),), base="rotor-housing",
             expect=("simulation.initial.x: unknown state; state: x_rotor, y_rotor, x_housing, "
                     "y_housing, vx_rotor, vy_rotor, vx_housing, vy_housing",)),
    SpecCase("legacy-initial-on-bodies", "bodies and bearings", "x0 in a model of two bodies",
             (("simulation.x0", 1e-6),), base="rotor-housing",
             expect=("simulation.x0: the model has no state 'x' (state: x_rotor, y_rotor, "
                     "x_housing, y_housing, vx_rotor, vy_rotor, vx_housing, vy_housing); use "
                     "simulation.initial",)),
    SpecCase("body-mass-undeclared", "bodies and bearings", "a body whose mass parameter is "
             "not declared", (("bodies.1.mass", "pedestal_mass"),), base="rotor-housing",
             expect=("parameters.pedestal_mass: missing; body 'housing' needs it (declare it "
                     "with value, unit, source, low and high)",)),
    SpecCase("bearing-parameter-unit", "bodies and bearings", "a per-bearing parameter with "
             "the wrong unit", ((f"{P}.radial_clearance_left",
                                 {"value": 1e-5, "unit": "mm", "source": "x"}),),
             base="two-bearing-rotor",
             expect=("parameters.radial_clearance_left.unit: must be 'm', got 'mm'",)),
    SpecCase("housing-without-support", "bodies and bearings", "a body that nothing holds "
             "to ground (the housing's support removed; used to blow up as 'try a smaller "
             "dt')", (("bodies.1.support", DROP),), base="rotor-housing",
             expect=("bodies[0] ('rotor'): nothing holds it to ground (held only by bearing "
                     "'bearing' to 'housing'); give it or a body it is joined to support",)),
    SpecCase("body-attached-to-nothing", "bodies and bearings", "a body attached to nothing "
             "(its states stayed 0)", (("bodies.+", {"name": "frame", "mass": "housing_mass"}),),
             base="rotor-housing",
             expect=("bodies[2] ('frame'): attached to nothing (no bearing or term acts on it "
                     "and it starts at rest: its states would stay 0)",)),
    SpecCase("support-without-stiffness", "bodies and bearings", "a support of damping only "
             "(holds nothing)", (("bodies.1.support.stiffness", DROP),), base="rotor-housing",
             expect=("nothing holds it to ground",)),
    SpecCase("spring-removed", "bodies and bearings", "a Duffing oscillator without its "
             "spring (a free mass under a harmonic force)", (("terms.0", DROP),),
             base="duffing",
             expect=("body 'rotor': nothing holds it to ground; give it support",)),
    SpecCase("defect-ball-beyond-balls", "bodies and bearings", "a pit on a ball the "
             "bearing does not have", (("terms.1.ball", 12),), base="6205-ball-defect",
             expect=("terms[1] (localized_defect)."
                     "ball: must be in [1, 9] (a ball of bearing 'bearing', 9 by "
                     "default), got 12",)),
    # user-declared parameters
    SpecCase("user-parameter-without-range", "user parameters", "a new parameter without a "
             "range", ((f"{P}.k3", {"value": 1.0, "unit": "N/m^3", "source": "x"}),),
             ("parameters.k3: unknown parameter", "a new parameter needs its allowed range: "
              "low = …, high = …")),
    SpecCase("user-parameter-out-of-range", "user parameters", "a new parameter outside its "
             "range", (K3, (f"{P}.k3.value", -1.0)),
             ("parameters.k3.value: must be in [0, 1e+20] N/m^3, got -1",)),
    SpecCase("user-parameter-half-range", "user parameters", "a new parameter with one bound",
             (K3, (f"{P}.k3.high", DROP)),
             ("parameters.k3.high: missing; a new parameter needs its allowed range",)),
    SpecCase("user-parameter-empty-range", "user parameters", "low not below high",
             (K3, (f"{P}.k3.low", 1e30)),
             ("parameters.k3.low: must be smaller than high (1e+20), got 1e+30",)),
    SpecCase("user-parameter-taken-name", "user parameters", "a new parameter named like a "
             "symbol", ((f"{P}.delta", {**K3[1]}),),
             ("parameters.delta: 'delta' is taken (a symbol, function, Python or "
              "generated-code name)",)),
    SpecCase("builtin-with-range", "user parameters", "a range on a built-in parameter",
             ((f"{P}.damping.low", 0.0), (f"{P}.damping.high", 10.0)),
             ("parameters.damping: 'damping' is built in with the fixed range [0, 1e+07] "
              "N*s/m; remove low and high",)),
    # custom expressions
    SpecCase("expr-attribute", "custom expressions", "attribute access",
             (expression(fx="x.__class__"),),
             ("terms[5] (expression).fx: attribute access is not allowed: 'x.__class__'",)),
    SpecCase("expr-call", "custom expressions", "a call of anything but the listed functions",
             (expression(fx="__import__('os').system('touch PWNED')"),),
             ("terms[5] (expression).fx: attribute access is not allowed: "
              "'__import__('os').system'",)),
    SpecCase("expr-builtin-call", "custom expressions", "a call of a Python builtin",
             (expression(fx="eval('1')"),),
             ("terms[5] (expression)."
              "fx: calls to 'eval' are not allowed; functions: sin, cos, exp, sqrt, "
              "abs, Heaviside, Max, Min: 'eval('1')'",)),
    SpecCase("expr-lambda", "custom expressions", "a lambda",
             (expression(fx="(lambda: 0)()"),),
             ("terms[5] (expression).fx: lambdas are not allowed: 'lambda: 0'",)),
    SpecCase("expr-comprehension", "custom expressions", "a comprehension",
             (expression(fx="Max(x, [y for y in (x, y)])"),),
             ("terms[5] (expression).fx: comprehensions are not allowed: '[y for y in (x, y)]'",)),
    SpecCase("expr-subscript", "custom expressions", "a subscript",
             (expression(fy="y[0]"),),
             ("terms[5] (expression).fy: subscripts are not allowed: 'y[0]'",)),
    SpecCase("expr-dunder", "custom expressions", "a name starting with '_'",
             (expression(fx="__builtins__"),),
             ("terms[5] (expression)."
              "fx: names starting with '_' are not allowed: '__builtins__'",)),
    SpecCase("expr-too-long", "custom expressions", "an expression over 2000 characters",
             (expression(fx="+".join(["x"] * 1001)),),
             ("terms[5] (expression).fx: too long: 2001 characters, at most 2000",)),
    SpecCase("expr-too-deep", "custom expressions", "nesting deeper than 40 levels",
             (expression(fx="(" * 41 + "x" + ")" * 41),),
             ("terms[5] (expression).fx: nested deeper than 40 levels",)),
    SpecCase("expr-syntax", "custom expressions", "not an expression",
             (expression(fx="x +"),),
             ("terms[5] (expression).fx: not a valid expression (invalid syntax): 'x +'",)),
    SpecCase("expr-power-caret", "custom expressions", "'^' for a power",
             (expression(fx="-k3*x^3"),),
             ("terms[5] (expression).fx: '^' is not a power here; use '**': '-k3*x^3'",)),
    SpecCase("expr-division-by-zero", "custom expressions", "a division by zero",
             (expression(fx="1/(x - x)"),),
             ("terms[5] (expression).fx: division by zero or an infinite value: '1/(x - x)'",)),
    SpecCase("expr-complex", "custom expressions", "a complex number",
             (expression(fy="sqrt(-4)*y"),),
             ("terms[5] (expression)."
              "fy: complex value (e.g. sqrt of a negative number): 'sqrt(-4)*y'",)),
    SpecCase("expr-huge-number", "custom expressions", "a number beyond the double range",
             (expression(fx="1e999*x"),),
             ("terms[5] (expression).fx: number outside the floating-point range: '1e999'",)),
    SpecCase("expr-unknown-name", "custom expressions", "an undeclared name",
             (K3, expression(fx="-k_3*x**3")),
             ("terms[5] (expression)."
              "fx: unknown name 'k_3' (did you mean 'k3'?); a new parameter needs a "
              "declaration [parameters.k_3] with value, unit, source, low and high",)),
    SpecCase("expr-ball-symbol", "custom expressions", "a per-ball symbol in a rotor force",
             (expression(fx="1e9*delta"),),
             ("terms[5] (expression)."
              "fx: 'delta' is a per-ball symbol; it may be used in 'ball' only",)),
    SpecCase("expr-star", "custom expressions", "'*' unpacking in a call (reported as an "
             "argument count before)", (expression(fx="Max(*x)"),),
             ("terms[5] (expression).fx: '*' unpacking is not allowed: '*x'",)),
    SpecCase("expr-double-star", "custom expressions", "'**' unpacking in a call",
             (expression(fx="sin(**x)"),),
             ("terms[5] (expression).fx: '**' unpacking is not allowed: 'sin(**x)'",)),
    SpecCase("defect-ball-zero", "bodies and bearings", "a pit on ball 0 (the range was "
             "missing from the message)", (("terms.1.ball", 0),), base="6205-ball-defect",
             expect=("terms[1] (localized_defect).ball: must be in [1, 64], got 0",)),
    SpecCase("expr-empty", "custom expressions", "an expression term without expressions",
             (expression(description="nothing"),),
             ("terms[5] (expression): an expression term needs at least one of fx, fy, ball",)),
]


def _spec_message(case: SpecCase, folder: Path) -> str:
    folder.mkdir(parents=True, exist_ok=True)
    path = case.write(folder) if case.text != "" else folder / f"{case.base}.toml"
    cwd = Path.cwd()
    os.chdir(folder)
    try:
        load_spec(path.name)
    except SpecError as exc:
        return f"error: {exc}"
    finally:
        os.chdir(cwd)
    raise AssertionError(f"{case.id}: the spec was accepted")


@pytest.mark.parametrize("case", SPEC_CASES, ids=[c.id for c in SPEC_CASES])
def test_bad_spec(case: SpecCase, tmp_path):
    message = _spec_message(case, tmp_path)
    assert "\n" not in message
    for fragment in case.expect:
        assert fragment in message, message
    assert not (tmp_path / "PWNED").exists(), "nothing in a spec ever runs"


def test_every_problem_of_a_spec_is_in_its_one_line(tmp_path):
    case = SpecCase("several", "", "", ((f"{P}.damping.value", float("nan")),
                                        ("structure.n_bals", 6), (f"{P}.rotor_mass.value", "x")),
                    ())
    message = _spec_message(case, tmp_path)
    assert "\n" not in message and message.count("; ") >= 2
    for field_name in ("parameters.damping.value", "structure.n_bals", "parameters.rotor_mass"):
        assert field_name in message
    # checks across fields (units, names, geometry) run once every field is valid alone
    case = SpecCase("cross", "", "", ((f"{P}.radial_load.unit", "kN"),
                                      (f"{P}.ball_diameter.value", 6e-3)), ())
    message = _spec_message(case, tmp_path / "cross")
    assert "radial_load.unit: must be 'N'" in message
    assert "ball_diameter: must be at most" in message


# ---------------------------------------------------------------- the command line

@dataclass(frozen=True)
class CliCase:
    id: str
    group: str
    what: str
    args: tuple[str, ...]
    expect: tuple[str, ...]
    setup: Callable[[Path], None] | None = None
    one_line: bool = True
    """False for usage errors that click/typer print before the command runs."""
    marks: tuple = field(default=())
    env: tuple[tuple[str, str], ...] = ()
    """Environment variables the command runs with (``BEARINGDYN_MODELS=…``)."""
    fixed: tuple[str, ...] | None = None
    """The corrected command, run in the same folder after the refusal: it must succeed
    (nothing the refusal left may block it)."""

    def shown(self) -> str:
        prefix = "".join(f"{k}={v} " for k, v in self.env)
        return f"`{prefix}bearingdyn " + " ".join(self.args) + "`"


SIM = ("simulate", "vakharia2015", "-o", "r.nc")
SHORT = ("--duration", "0.01", "--transient", "0", "--no-compile")


def _corrupt_result(folder: Path) -> None:
    (folder / "r.nc").write_bytes(b"CDF\x01 truncated netCDF file")


def _foreign_result(folder: Path) -> None:
    xr.Dataset({"z": ("t", np.zeros(3))}).to_netcdf(folder / "r.nc", engine="h5netcdf")


def _unwritable_folder(folder: Path) -> None:
    (folder / "locked").mkdir()
    (folder / "locked").chmod(0o500)


def _output_is_folder(folder: Path) -> None:
    (folder / "out.nc").mkdir()


def _bad_spec(folder: Path) -> None:
    text = (SPECS / "vakharia2015.toml").read_text()
    (folder / "vakharia2015.toml").write_text(
        text.replace('kind = "unbalance"', 'kind = "unbalanse"'))


def _hostile_spec(folder: Path) -> None:
    SpecCase("", "", "", (K3, expression(fx="().__class__.__base__.__subclasses__()")),
             ()).write(folder)


CLI_CASES = [
    CliCase("balls-too-few", "command line", "fewer than 3 balls", (*SIM, "--n-balls", "2"),
            ("--n-balls: must be a whole number in [3, 17] (at most 17 balls fit the geometry), "
             "got 2",)),
    CliCase("balls-absurd", "command line", "an absurd number of balls",
            (*SIM, "--n-balls", "1000"),
            ("--n-balls: must be a whole number in [3, 17] (at most 17 balls fit the "
             "geometry), got 1000",)),
    CliCase("balls-not-integer", "command line", "an option of the wrong type (checked by the "
            "command-line parser, before the command runs)", (*SIM, "--n-balls", "six"),
            ("Invalid value for '--n-balls'",)),
    CliCase("step-zero", "command line", "a time step of zero", (*SIM, "--dt", "0"),
            ("dt: must be a finite number > 0 s, got 0.0",)),
    CliCase("step-nan", "command line", "NaN as a time step", (*SIM, "--dt", "nan"),
            ("dt: must be a finite number > 0 s, got nan",)),
    CliCase("step-unstable", "command line", "a time step above the RK4 stability limit of "
            "the linearised contact stiffness",
            (*SIM, "--n-balls", "8", "--dt", "2e-4", "--set", "radial_load=1e5"),
            ("dt: must be in (0, 0.000101] s for RK4 with these parameters, got 0.0002",
             "try dt = 5e-05 s, or method cvodes")),
    CliCase("duration-below-transient", "command line", "duration shorter than the transient",
            (*SIM, "--duration", "0.5", "--transient", "1"),
            ("transient: must be in [0, duration) = [0, 0.5) s, got 1.0",)),
    CliCase("set-negative-mass", "command line", "`--set` outside the range",
            (*SIM, "--set", "rotor_mass=-1"),
            ("rotor_mass: must be in (0, 100000] kg, got -1.0",)),
    CliCase("set-unknown", "command line", "`--set` of an unknown parameter",
            (*SIM, "--set", "dampign=1"),
            ("dampign: not a parameter of model 'vakharia2015' (did you mean 'damping'?)",)),
    CliCase("set-inf", "command line", "`--set` to infinity", (*SIM, "--set", "damping=inf"),
            ("damping: must be in [0, 1e+07] N*s/m, got inf",)),
    CliCase("set-not-number", "command line", "`--set` to text", (*SIM, "--set", "damping=lots"),
            ("--set damping: value must be a number, got 'lots'",)),
    CliCase("set-no-value", "command line", "`--set` without a value",
            (*SIM, "--set", "damping"), ("--set: expected name=value, got 'damping'",)),
    CliCase("speed-negative", "command line", "negative speed", (*SIM, "--speed-rpm", "-5"),
            ("speed_rpm: must be in [0, 1e+06] rpm, got -5.0",)),
    CliCase("method-unknown", "command line", "an unknown integrator",
            (*SIM, *SHORT, "--method", "euler"),
            ("method: must be 'rk4' or 'cvodes', got 'euler'",)),
    CliCase("model-unknown", "command line", "an unknown model", ("simulate", "vakharia", "-o",
            "r.nc"), ("model: no model named 'vakharia' (did you mean 'vakharia2015'?)"
                      "; available:",)),
    CliCase("spec-unknown-term", "command line", "a bad spec given to `generate`",
            ("generate", "vakharia2015.toml", "--out", "gen"),
            ("vakharia2015.toml: terms[4].kind: unknown term 'unbalanse' (did you mean "
             "'unbalance'?)",), setup=_bad_spec),
    CliCase("spec-hostile-expression", "command line", "a spec expression that tries to "
            "escape", ("generate", "vakharia2015.toml", "--out", "gen"),
            ("terms[5] (expression).fx: attribute access is not allowed: '().__class__.__base__."
             "__subclasses__'",), setup=_hostile_spec),
    CliCase("output-folder-missing", "files", "an output folder that does not exist",
            (*SIM[:3], "nowhere/r.nc", *SHORT), ("output: folder 'nowhere' does not exist",)),
    CliCase("output-folder-locked", "files", "an output folder without write permission",
            (*SIM[:3], "locked/r.nc", *SHORT), ("output: folder 'locked' is not writable",),
            setup=_unwritable_folder,
            marks=(pytest.mark.skipif(IS_ROOT, reason="root may write anywhere"),)),
    CliCase("output-is-folder", "files", "an output path that is a folder",
            (*SIM[:3], "out.nc", *SHORT), ("out.nc", "folder"), setup=_output_is_folder),
    CliCase("result-missing", "files", "a result file that does not exist",
            ("spectrum", "missing.nc"), ("result file: 'missing.nc' does not exist",)),
    CliCase("result-corrupt", "files", "a corrupt result file", ("spectrum", "r.nc"),
            ("result file: 'r.nc' is not a readable netCDF file",), setup=_corrupt_result),
    CliCase("result-foreign", "files", "a netCDF file that is not a bearingdyn run",
            ("poincare", "r.nc"),
            ("result file: 'r.nc' is not a bearingdyn result (it names no model; variables: "
             "z)",),
            setup=_foreign_result),
    CliCase("section-unknown", "command line", "an unknown Poincaré section",
            ("poincare", "r.nc", "--section", "moon"),
            ("--section: must be shaft, cage, vc, cage[bearing], vc[bearing] or param:NAME, "
             "got 'moon'",)),
    CliCase("blow-up", "numerical failures", "a motion that blows up (softening spring)",
            ("simulate", "duffing", "-o", "r.nc", "--set", "cubic_stiffness=-1", "--duration",
             "20", "--transient", "0", "--no-compile"),
            ("the motion blew up at t = 1.35 s", "try a smaller dt, more damping, or check the "
             "parameters")),
]


# ---------------------------------------------------------------- every command, every option

_RUN_LOCK = threading.Lock()
_RUN_CACHE: dict[str, bytes] = {}


def _sample_run_bytes(kind: str) -> bytes:
    """A short run of the paper's model as bytes (made once per test session): ``good``,
    ``tampered`` (dt < 0 in its attributes), ``kind`` (a damaged kind attribute), ``nan``
    (one state NaN), ``one`` (one sample), ``short`` (too few section points to classify),
    ``netcdf3`` (classic format)."""
    with _RUN_LOCK:
        if kind not in _RUN_CACHE:
            import tempfile

            from analysis.integrate.simulate import simulate

            ds = simulate("vakharia2015", 8, duration=0.05, transient=0.0)
            variants = {"good": ds, "tampered": ds.assign_attrs(dt=-1.0),
                        "kind": ds.assign_attrs(kind="chrt"),
                        "nan": ds.assign(x=ds.x.where(ds.t != ds.t[5])),
                        "one": ds.isel(t=slice(0, 1)), "short": ds.isel(t=slice(0, 2000))}
            with tempfile.TemporaryDirectory() as tmp:
                for name, data in variants.items():
                    data.to_netcdf(Path(tmp) / name, engine="h5netcdf")
                    _RUN_CACHE[name] = (Path(tmp) / name).read_bytes()
                ds.to_netcdf(Path(tmp) / "n3", engine="scipy", format="NETCDF3_64BIT")
                _RUN_CACHE["netcdf3"] = (Path(tmp) / "n3").read_bytes()
        return _RUN_CACHE[kind]


def _run_file(kind: str = "good", name: str = "run.nc") -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        (folder / name).write_bytes(_sample_run_bytes(kind))
    return setup


def _fifo(name: str) -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        os.mkfifo(folder / name)
    return setup


def _folder(name: str) -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        (folder / name).mkdir()
    return setup


def _spec_file(name: str, text: str) -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    return setup


def _cases(group: str, base: tuple[str, ...], rows, setup=None) -> list[CliCase]:
    """CliCases from rows ``(id, what, extra args, expected fragments[, setup])``."""
    made = []
    for row in rows:
        case_id, what, extra, expect, *own = row
        made.append(CliCase(case_id, group, what, (*base, *extra), tuple(expect),
                            setup=own[0] if own else setup))
    return made


LONG = "a" * 250 + ".nc"
SIM_SHORT = (*SIM, *SHORT)
RUN = ("run.nc",)
CONT = ("continue", "balanced-rotor", "--param", "speed_rpm", "--from", "7000", "--to", "7100",
        "-o", "b.nc")
SWEEP = ("sweep", "balanced-rotor", "--param", "speed_rpm", "--from", "7000", "--to", "7100",
         "--num", "3", "-o", "d.nc")
CHART = ("chart", "vakharia2015", "--x", "speed_rpm:3000:4000:2", "--y", "n_balls:7:8",
         "-o", "c.nc")
CURVE = ("curve", "b.nc", "--point", "PD", "--param", "radial_load", "--to", "60", "-o",
         "k.nc")

CLI_CASES += _cases("simulate", ("simulate", "vakharia2015", "-o", "r.nc"), [
    ("sim-duration-zero", "a duration of zero", ("--duration", "0"), ["duration: must be"]),
    ("sim-duration-negative", "a negative duration", ("--duration", "-1"),
     ["duration: must be"]),
    ("sim-duration-nan", "NaN as the duration", ("--duration", "nan"), ["duration: must be"]),
    ("sim-duration-inf", "an infinite duration", ("--duration", "inf"), ["duration: must be"]),
    ("sim-duration-huge", "a duration of 1e12 s (would allocate petabytes)",
     ("--duration", "1e12"), ["duration / dt:", "at most 1e+10 per run"]),
    ("sim-dt-tiny", "a step of 1e-300 s", ("--dt", "1e-300"), ["duration / dt:"]),
    ("sim-dt-negative", "a negative step", ("--dt", "-1e-5"), ["dt: must be a finite number"]),
    ("sim-dt-inf", "an infinite step", ("--dt", "inf"), ["dt: must be a finite number"]),
    ("sim-dt-coarse", "a step that does not resolve VC (2.5 steps per period)",
     ("--dt", "2e-3", "--duration", "0.1", "--transient", "0"),
     ["dt: must resolve the fastest forcing VC", "at least 4 steps per period"]),
    ("sim-dt-above-duration", "a step longer than the run", ("--dt", "0.5", "--duration",
                                                             "0.1", "--transient", "0"),
     ["dt:"]),
    ("sim-transient-negative", "a negative transient", ("--duration", "0.01", "--transient",
                                                        "-1"), ["transient: must be in"]),
    ("sim-transient-nan", "NaN as the transient", ("--duration", "0.01", "--transient",
                                                   "nan"), ["transient: must be in"]),
    ("sim-save-every-zero", "--save-every 0", ("--save-every", "0", *SHORT),
     ["--save-every: must be a whole number >= 1"]),
    ("sim-save-every-negative", "--save-every -3", ("--save-every", "-3", *SHORT),
     ["--save-every: must be a whole number >= 1"]),
    ("sim-memory", "a run held in memory beyond 8 GiB (CVODES keeps every sample)",
     ("--duration", "3000", "--method", "cvodes"), ["save_every: the run would keep"]),
    ("sim-speed-nan", "NaN as the speed", ("--speed-rpm", "nan", *SHORT), ["speed_rpm: must be"]),
    ("sim-speed-inf", "an infinite speed", ("--speed-rpm", "inf", *SHORT), ["speed_rpm: must be"]),
    ("sim-speed-twice", "--speed-rpm and --set speed_rpm together",
     ("--speed-rpm", "3000", "--set", "speed_rpm=4000", *SHORT), ["--speed-rpm: given twice"]),
    ("sim-set-twice", "one parameter set twice", ("--set", "damping=100", "--set",
                                                  "damping=300", *SHORT),
     ["--set damping: given twice (100 and 300)"]),
    ("sim-set-n-balls", "the number of balls through --set", ("--set", "n_balls=7", *SHORT),
     ["--set n_balls: the number of balls is structure", "--n-balls"]),
    ("sim-set-empty-name", "--set without a name", ("--set", "=5", *SHORT),
     ["--set: expected name=value"]),
    ("sim-set-clearance-huge", "a clearance of a metre", ("--set", "radial_clearance=1",
                                                         *SHORT), ["radial_clearance: must be"]),
    ("sim-set-mass-zero", "a rotor mass of zero", ("--set", "rotor_mass=0", *SHORT),
     ["rotor_mass: must be in (0"]),
    ("sim-set-stiffness-nan", "NaN stiffness", ("--set", "contact_stiffness=nan", *SHORT),
     ["contact_stiffness: must be"]),
    ("sim-set-overflow", "a number beyond the double range", ("--set", "damping=1e400",
                                                             *SHORT), ["damping: must be"]),
    ("sim-balls-zero", "zero balls", ("--n-balls", "0", *SHORT),
     ["--n-balls: must be a whole number"]),
    ("sim-balls-too-many", "more balls than fit the geometry", ("--n-balls", "18", *SHORT),
     ["--n-balls: must be a whole number in [3, 17]"]),
    ("sim-balls-named", "a bearing name on a one-bearing model", ("--n-balls", "left=7",
                                                                  *SHORT), ["left"]),
    ("sim-balls-two-numbers", "two plain numbers of balls", ("--n-balls", "7", "--n-balls",
                                                             "8", *SHORT),
     ["give one number"]),
    ("sim-method-case", "a method in capitals", ("--method", "RK4", *SHORT),
     ["method: must be 'rk4' or 'cvodes'"]),
    ("sim-option-unknown", "an option that does not exist", ("--nballs", "8"),
     ["No such option: --nballs", "--n-balls"]),
])
CLI_CASES += _cases("files", ("simulate", "vakharia2015", *SHORT, "-o"), [
    ("out-suffix-unknown", "a result name with an unknown suffix", ("r.xyz",),
     ["must end in one of .nc", "got '.xyz'"]),
    ("out-no-suffix", "a result name without a suffix", ("result",), ["(no suffix given)"]),
    ("out-figure-suffix", "a figure suffix for a result", ("r.png",), ["got '.png'"]),
    ("out-too-long", "a file name longer than the file system takes", (LONG,),
     ["the file name is 253 bytes long"]),
    ("out-fifo", "an output that is a named pipe", ("pipe.nc",),
     ["exists and is not a plain file"], _fifo("pipe.nc")),
    ("out-existing-folder", "an output that is an existing folder with a result's name",
     ("old.nc",), ["'old.nc' is a folder"], _folder("old.nc")),
])
CLI_CASES += _cases("models and specs", ("simulate",), [
    ("model-private", "an internal module as a model", ("_runtime", "-o", "r.nc"),
     ["model: no model named '_runtime'"]),
    ("model-empty", "an empty model name", ("", "-o", "r.nc"), ["model: the name is empty"]),
    ("model-traversal", "a model name that climbs out of the specs", ("../specs/x", "-o",
                                                                     "r.nc"), ["model:"]),
    ("model-spec-missing", "a .toml path that does not exist", ("mine.toml", "-o", "r.nc"),
     ["model: spec file mine.toml not found"]),
    ("model-not-a-spec", "a folder that holds no model", ("empty", "-o", "r.nc"),
     ["empty"], _folder("empty")),
    ("model-spec-deep", "TOML nested 100 000 deep", ("deep.toml", "-o", "r.nc"),
     ["not valid TOML: arrays or tables nested too deeply"],
     _spec_file("deep.toml", "a = " + "[" * 100_000 + "]" * 100_000 + "\n")),
    ("model-spec-binary", "a spec that is not text", ("bin.toml", "-o", "r.nc"),
     ["not valid TOML"], lambda folder: (folder / "bin.toml").write_bytes(b"\xff\xfe\x00")),
])


def _spec_and_a_file(folder: Path) -> None:
    (folder / "duffing.toml").write_text((SPECS / "duffing.toml").read_text())
    (folder / "f.txt").write_text("not a folder")


CLI_CASES += _cases("models and specs", ("generate", "duffing.toml", "--out"), [
    ("generate-out-is-file", "generate --out naming a file", ("f.txt",),
     ["--out: 'f.txt' exists and is not a folder"], _spec_and_a_file),
])
CLI_CASES += _cases("runs as input", ("spectrum",), [
    ("input-folder", "a folder as the run", ("sub",), ["'sub' is a folder, not a result file"],
     _folder("sub")),
    ("input-fifo", "a named pipe as the run", ("pipe.nc",), ["is not a plain file"],
     _fifo("pipe.nc")),
    ("input-tampered", "a run whose dt attribute was edited to -1", RUN,
     ["attribute dt must be a finite number > 0", "a damaged or edited file"],
     _run_file("tampered")),
    ("input-nan", "a run with a NaN state", RUN, ["variable x is not finite at t = 5e-05 s"],
     _run_file("nan")),
    ("input-one-sample", "a run of one sample", RUN, ["holds 1 sample(s); a run needs at least 2"],
     _run_file("one")),
    ("spectrum-max-peaks-zero", "--max-peaks 0", (*RUN, "--max-peaks", "0"), ["max"],
     _run_file()),
    ("spectrum-var-unknown", "a variable the run does not have", (*RUN, "--var", "z"), ["z"],
     _run_file()),
    ("spectrum-figure-suffix", "a figure name with a result suffix", (*RUN, "-o", "f.nc"),
     ["must end in one of .png"], _run_file()),
])
CLI_CASES += _cases("runs as input", ("poincare",), [
    ("poincare-section-bearing", "a section of a bearing the model lacks",
     (*RUN, "--section", "vc[left]"), ["left"], _run_file()),
    ("poincare-section-param", "a section on a parameter the model lacks",
     (*RUN, "--section", "param:nothing"), ["nothing"], _run_file()),
    ("poincare-axis-unknown", "a map axis the run does not have", (*RUN, "--x", "q"), ["q"],
     _run_file()),
    ("poincare-figure-suffix", "a figure without a suffix", (*RUN, "-o", "figure"),
     ["(no suffix given)"], _run_file()),
])
CLI_CASES += _cases("runs as input", ("classify",), [
    ("classify-short", "a run too short for a verdict", RUN,
     ["point(s) on the shaft section; a verdict needs at least 34"], _run_file("short")),
    ("classify-nan", "a run with a NaN state", RUN, ["variable x is not finite"],
     _run_file("nan")),
    ("classify-section-unknown", "an unknown section", (*RUN, "--section", "moon"),
     ["section: must be shaft, cage, vc"], _run_file()),
    ("classify-missing", "a run that does not exist", ("gone.nc",), ["does not exist"]),
])
CLI_CASES += _cases("runs as input", ("plot",), [
    ("plot-suffix", "a figure name with an unknown suffix", (*RUN, "-o", "f.bmpx"),
     ["must end in one of .png"], _run_file()),
    ("plot-var-unknown", "a variable the run does not have", (*RUN, "-o", "f.png", "--var",
                                                             "q"), ["q"], _run_file()),
    ("plot-missing", "a result that does not exist", ("gone.nc", "-o", "f.png"),
     ["does not exist"]),
])
CLI_CASES += _cases("stability", ("lyapunov", "vakharia2015", "--duration", "0.05",
                                  "--transient", "0.01"), [
    ("lyap-duration-zero", "an averaging time of zero", ("--duration", "0"), ["duration:"]),
    ("lyap-transient-negative", "a negative transient", ("--transient", "-1"),
     ["transient: must be a finite number >= 0"]),
    ("lyap-tangent-negative", "a negative tangent transient", ("--tangent-transient", "-1"),
     ["tangent_transient: must be a finite number >= 0"]),
    ("lyap-tangent-nan", "NaN as the tangent transient", ("--tangent-transient", "nan"),
     ["tangent_transient: must be a finite number >= 0"]),
    ("lyap-dt-zero", "a step of zero", ("--dt", "0"), ["dt: must be a finite number > 0"]),
    ("lyap-dt-unstable", "a step beyond RK4's stability limit, without a transient",
     ("--transient", "0", "--duration", "1", "--dt", "5e-4"),
     ["dt: must be in (0, ", "s for RK4 with these parameters"]),
    ("lyap-renorm-zero", "--renorm-every 0", ("--renorm-every", "0"),
     ["--renorm-every: must be a whole number >= 1"]),
    ("lyap-renorm-long", "a renormalisation interval longer than the run",
     ("--renorm-every", "100000000"), ["renorm_every: 10 renormalisations", "must fit"]),
    ("lyap-steps-huge", "a run of 1e17 steps", ("--duration", "1e12"),
     ["duration: 1e+17 RK4 steps in all"]),
    ("lyap-balls", "too few balls", ("--n-balls", "2"), ["--n-balls: must be a whole number"]),
    ("lyap-figure-suffix", "a figure with a result suffix", ("-o", "l.nc"),
     ["must end in one of .png"]),
])
CLI_CASES += _cases("stability", ("floquet", "balanced-rotor", "--n-balls", "8"), [
    ("floquet-period-unknown", "an unknown period", ("--period", "moon"), ["period: must be"]),
    ("floquet-period-zero", "a period of zero VC periods", ("--period", "vc:0"),
     ["period: the number in 'vc:0' must be a positive integer"]),
    ("floquet-period-huge", "a period of 100 000 VC periods (would hang)",
     ("--period", "vc:100000"), ["period vc:100000:", "at most 2e+06 per period"]),
    ("floquet-ratio-zero", "a zero ratio", ("--period", "ratio:0/1"), ["period: the number"]),
    ("floquet-param-unknown", "a period held by an unknown parameter",
     ("--period", "param:nothing"), ["period: param:nothing: not a parameter"]),
    ("floquet-segments-zero", "zero shooting segments", ("--segments", "0"),
     ["segments: must be a whole number in [1, 64]"]),
    ("floquet-segments-many", "100 shooting segments", ("--segments", "100"),
     ["segments: must be a whole number in [1, 64]"]),
    ("floquet-dt-zero", "a step of zero", ("--dt", "0"), ["dt: must be a finite number > 0"]),
    ("floquet-dt-unstable", "a step beyond RK4's stability limit", ("--dt", "5e-4"),
     ["dt: must be in (0, ", "s for RK4 with these parameters"]),
    ("floquet-settle-negative", "a negative settling time", ("--settle", "-1"),
     ["settle: must be a finite number >= 0 s"]),
    ("floquet-settle-nan", "NaN as the settling time", ("--settle", "nan"),
     ["settle: must be a finite number >= 0 s"]),
    ("floquet-settle-inf", "an infinite settling time", ("--settle", "inf"),
     ["settle: must be a finite number >= 0 s"]),
])
CLI_CASES += _cases("stability", ("floquet", "duffing"), [
    ("floquet-vc-no-bearings", "a VC period on a model without bearings", ("--period", "vc"),
     ["period: model 'duffing' has no bearings"]),
])
CLI_CASES += _cases("continuation", CONT, [
    ("cont-ds-max-zero", "--ds-max 0", ("--ds-max", "0"), ["ds_max: must be a finite number > 0"]),
    ("cont-ds-max-negative", "--ds-max -1", ("--ds-max", "-1"),
     ["ds_max: must be a finite number > 0"]),
    ("cont-ds-max-nan", "--ds-max nan", ("--ds-max", "nan"),
     ["ds_max: must be a finite number > 0"]),
    ("cont-max-points-zero", "--max-points 0", ("--max-points", "0"),
     ["--max-points: must be a whole number in [2, 100000]"]),
    ("cont-max-points-one", "--max-points 1", ("--max-points", "1"),
     ["--max-points: must be a whole number in [2, 100000]"]),
    ("cont-dt-zero", "a step of zero", ("--dt", "0"), ["dt: must be a finite number > 0"]),
    ("cont-settle-negative", "a negative settling time", ("--settle", "-5"),
     ["settle: must be a finite number >= 0 s"]),
    ("cont-plot-suffix", "a figure with a result suffix", ("--plot", "b.nc"),
     ["must end in one of .png"]),
    ("cont-period-unknown", "an unknown period", ("--period", "moon"), ["period: must be"]),
    ("cont-balls", "too few balls", ("--n-balls", "2"), ["--n-balls: must be a whole number"]),
])
CLI_CASES += _cases("continuation", ("continue",), [
    ("cont-to-nan", "NaN as the end value", ("balanced-rotor", "--param", "speed_rpm",
                                             "--from", "7000", "--to", "nan", "-o", "b.nc"),
     ["speed_rpm: must be"]),
    ("cont-same-ends", "the same start and end", ("balanced-rotor", "--param", "speed_rpm",
                                                  "--from", "7000", "--to", "7000", "-o",
                                                  "b.nc"), ["stop: must differ from start"]),
    ("cont-param-unknown", "an unknown parameter", ("balanced-rotor", "--param", "sped",
                                                    "--from", "1", "--to", "2", "-o", "b.nc"),
     ["param: 'sped' is not a parameter"]),
    ("cont-nothing-to-start", "neither a model nor a branch", ("--to", "2", "-o", "b.nc"),
     ["MODEL"]),
    ("cont-branch-missing", "a branch file that does not exist",
     ("--from-branch", "gone.nc", "--to", "2", "-o", "b.nc"), ["gone.nc"]),
    ("cont-branch-is-run", "a run given as a branch", ("--from-branch", "run.nc", "--to",
                                                       "6000", "-o", "b.nc"),
     ["not a continuation branch"], _run_file()),
    ("cont-output-suffix", "a branch file name with a figure suffix",
     ("balanced-rotor", "--param", "speed_rpm", "--from", "1", "--to", "2", "-o", "b.png"),
     ["must end in one of .nc"]),
])
CLI_CASES += _cases("sweeps", SWEEP, [
    ("sweep-num-zero", "a grid of no values", ("--num", "0"),
     ["axis speed_rpm: count must be in [1, 100000], got 0"]),
    ("sweep-num-huge", "a grid of 1e11 values", ("--num", "100000000000"),
     ["axis speed_rpm: count must be in [1, 100000]"]),
    ("sweep-from-nan", "NaN as the first value", ("--from", "nan"),
     ["axis speed_rpm: start must be a finite number"]),
    ("sweep-to-inf", "an axis ending in inf", ("--to", "inf"),
     ["axis speed_rpm: stop must be a finite number, got inf"]),
    ("sweep-param-unknown", "an unknown parameter", ("--param", "sped"), ["sped"]),
    ("sweep-direction", "an unknown direction", ("--direction", "sideways"),
     ["direction: must be up, down or both"]),
    ("sweep-transient-negative", "a negative transient (named as the transient)",
     ("--transient", "-1"), ["transient: must be a finite number >= 0 s, got -1.0"]),
    ("sweep-samples-negative", "--samples -3 (named as the samples)", ("--samples", "-3"),
     ["samples: must be a whole number in [1, 100000]"]),
    ("sweep-samples-zero", "--samples 0", ("--samples", "0"),
     ["samples: must be a whole number in [1, 100000]"]),
    ("sweep-section", "an unknown section", ("--section", "moon"), ["moon"]),
    ("sweep-dt-zero", "a step of zero", ("--dt", "0"), ["dt: must be a finite number > 0 s"]),
    ("sweep-dt-coarse", "a step that does not resolve the forcing (2 ms, VC about 380 Hz)",
     ("--dt", "0.002"), ["dt: must resolve the fastest forcing VC"]),
    ("sweep-dt-unstable", "a step beyond RK4's stability limit", ("--dt", "5e-4"),
     ["dt: must be in (0, ", "s for RK4 with these parameters"]),
    ("sweep-executor", "an unknown executor", ("--executor", "gpu"),
     ["--executor: must be serial, processes or dask"]),
    ("sweep-workers-negative", "negative workers", ("--workers", "-1"),
     ["--workers: must be a whole number in [1, 1024], got -1"]),
    ("sweep-workers-zero", "zero workers", ("--workers", "0"),
     ["--workers: must be a whole number in [1, 1024], got 0"]),
    ("sweep-set-axis", "the swept parameter also given with --set",
     ("--set", "speed_rpm=3000"), ["--set speed_rpm: also an axis"]),
    ("sweep-output-suffix", "a diagram file name with a figure suffix", ("-o", "d.png"),
     ["must end in one of .nc"]),
    ("sweep-balls-axis-twice", "a ball axis also given with --n-balls",
     ("--param", "n_balls", "--from", "7", "--to", "9", "--n-balls", "8"), ["n_balls"]),
])
CLI_CASES += _cases("sweeps", CHART, [
    ("chart-axis-syntax", "an axis without its count", ("--x", "speed_rpm:1:2"),
     ["axis: expected name:start:stop:count"]),
    ("chart-axis-inf", "an axis ending in inf", ("--x", "speed_rpm:1000:inf:3"),
     ["axis speed_rpm: stop must be a finite number, got inf"]),
    ("chart-axis-text", "an axis with a word for a number", ("--x", "speed_rpm:fast:2:3"),
     ["axis speed_rpm: 'fast' is not a number"]),
    ("chart-balls-down", "a ball axis given high to low", ("--y", "n_balls:9:6"),
     ["axis n_balls: low must be <= high", "write n_balls:6:9"]),
    ("chart-balls-fraction", "a ball axis with a fraction", ("--y", "n_balls:6.5:9"),
     ["axis n_balls: '6.5' is not a whole number"]),
    ("chart-same-axes", "one parameter on both axes", ("--y", "speed_rpm:1000:2000:2"),
     ["axis speed_rpm: the same on both axes"]),
    ("chart-axis-and-set", "an axis also given with --set", ("--set", "speed_rpm=3000"),
     ["--set speed_rpm: also an axis"]),
    ("chart-grid-huge", "a grid of 1e10 points", ("--x", "speed_rpm:1:2:100000", "--y",
                                                  "damping:1:2:100000"),
     ["axes: at most 1000000 points in all"]),
    ("chart-revolutions-zero", "--revolutions 0", ("--revolutions", "0"),
     ["--revolutions: must be a whole number in [1, 100000], got 0"]),
    ("chart-transient-nan", "NaN as the transient", ("--transient", "nan"),
     ["transient: must be a finite number >= 0 s"]),
    ("chart-section", "an unknown section", ("--section", "moon"), ["moon"]),
    ("chart-dt-nan", "NaN as the step", ("--dt", "nan"), ["dt: must be a finite number > 0 s"]),
    ("chart-dt-coarse", "a step that does not resolve VC at the grid's fastest corner "
     "(4000 rpm, 8 balls: VC = 139.5 Hz)", ("--dt", "0.002"),
     ["dt: must resolve the fastest forcing VC = 139.5 Hz"]),
    ("chart-dask-workers", "a Dask cluster of -1 workers (used to hang)",
     ("--executor", "dask", "--workers", "-1"), ["--workers: must be a whole number"]),
    ("chart-balls-too-many", "a ball axis beyond the geometry", ("--y", "n_balls:7:30"),
     ["n_balls: must be a whole number in [3, 17]"]),
    ("chart-bearing-unknown", "a ball axis of a bearing the model lacks",
     ("--y", "n_balls[left]:7:9"), ["has no bearing 'left'"]),
    ("chart-param-unknown", "an axis over an unknown parameter", ("--y", "dampign:1:2:2"),
     ["dampign"]),
])
CLI_CASES += _cases("curves", CURVE, [
    ("curve-max-points", "--max-points 0", ("--max-points", "0"),
     ["--max-points: must be a whole number in [2, 100000]"]),
    ("curve-ds-max", "--ds-max 0", ("--ds-max", "0"), ["ds_max: must be a finite number > 0"]),
    ("curve-to-nan", "NaN as the end value", ("--to", "nan"), ["stop: must be a finite number"]),
    ("curve-branch-missing", "a branch that does not exist", (), ["'b.nc' does not exist"]),
    ("curve-plot-suffix", "a figure with a result suffix", ("--plot", "k.nc"),
     ["must end in one of .png"]),
    ("curve-output-suffix", "a curve file with a figure suffix", ("-o", "k.png"),
     ["must end in one of .nc"]),
])
CLI_CASES += _cases("curves", ("curve", "run.nc", "--point", "PD", "--param", "radial_load",
                               "--to", "60", "-o", "k.nc"), [
    ("curve-branch-is-run", "a run given as a branch", (), ["not a branch file"],
     _run_file()),
])
CLI_CASES += _cases("jobs", ("run",), [
    ("run-balls", "too few balls", ("--n-balls", "2"), ["--n-balls: must be a whole number"]),
    ("run-duration", "a duration of zero", ("--duration", "0"), ["duration: must be"]),
    ("run-transient", "a negative transient", ("--transient", "-1"), ["transient:"]),
    ("run-model", "an unknown model", ("--model", "vakharia"), ["model: no model named"]),
    ("run-set", "an unknown parameter", ("--set", "dampign=1"), ["dampign"]),
    ("run-out-is-file", "an output folder that is a file", ("-o", "f.txt"),
     ["--out-dir: 'f.txt' exists and is not a folder"],
     _spec_file("f.txt", "a file")),
])
CLI_CASES += _cases("jobs", ("bench",), [
    ("bench-repeat", "--repeat 0", ("--repeat", "0"), ["repeat"]),
    ("bench-duration", "--duration 0", ("--duration", "0"), ["duration"]),
    ("bench-memory", "--memory-duration -1", ("--memory-duration", "-1"), ["memory"]),
])
CLI_CASES += _cases("jobs", ("reproduce", "vakharia2015", "--quick"), [
    ("reproduce-workers", "zero workers", ("--workers", "0"), ["--workers: must be"]),
    ("reproduce-executor", "an unknown executor", ("--executor", "gpu"), ["--executor"]),
    ("reproduce-out-is-file", "an output folder that is a file", ("-o", "f.txt"),
     ["--out-dir: 'f.txt' exists and is not a folder"],
     _spec_file("f.txt", "a file")),
])

CLI_CASES += _cases("checked before any write", ("stiffness", "vakharia2015"), [
    ("stiffness-ross-folder-missing", "--ross into a folder that does not exist (refused "
     "before the coefficients are computed)", ("--ross", "nowhere/r.json"),
     ["--ross: folder 'nowhere' does not exist"]),
    ("stiffness-ross-suffix", "--ross to a file that is not JSON", ("--ross", "r.txt"),
     ["--ross: 'r.txt' must end in one of .json, got '.txt'"]),
    ("stiffness-ross-is-folder", "--ross naming a folder", ("--ross", "sub.json"),
     ["--ross: 'sub.json' is a folder"], _folder("sub.json")),
    ("stiffness-figure-suffix", "a stiffness figure with a result suffix", ("-o", "f.nc"),
     ["--output: 'f.nc' must end in one of .png"]),
    ("stiffness-speeds-alone", "--speeds without --ross", ("--speeds", "1000:2000:3"),
     ["--speeds: only with --ross"]),
])
CLI_CASES += _cases("checked before any write", ("reproduce",), [
    ("reproduce-model-unknown", "an unknown model (used to leave empty report folders)",
     ("vakharia", "--quick", "-o", "rep"), ["model: no model named 'vakharia'"]),
    ("reproduce-out-deep", "a report folder inside a folder that does not exist",
     ("vakharia2015", "--quick", "-o", "no/rep"), ["--out-dir: folder 'no' does not exist"]),
])
CLI_CASES += _cases("checked before any write", (), [
    ("explore-output-suffix", "an explorer page that is not HTML",
     ("explore", "c.nc", "-o", "page.txt"), ["--output: 'page.txt' must end in one of .html"]),
    ("explore-bins", "too few spectrum bins (judged before the workers start)",
     ("explore", "c.nc", "-o", "page.html", "--spectrum-bins", "3"),
     ["--spectrum-bins: must be a whole number >= 16, got 3"]),
    ("explore-run-as-chart", "a run given as the chart (judged before the workers start)",
     ("explore", "run.nc", "-o", "page.html"), ["chart file: kind must be 'chart', got None"],
     _run_file()),
    ("explore-chart-missing", "a chart file that does not exist",
     ("explore", "gone.nc", "-o", "page.html"), ["result file: 'gone.nc' does not exist"]),
    ("cite-output-folder-missing", "a citation into a folder that does not exist",
     ("cite", "vakharia2015", "-o", "nowhere/x.bib"), ["--output: folder 'nowhere' does not "
                                                       "exist"]),
    ("sweep-step-no-parts", "a sweep refused for its step (used to leave d.nc.parts, which "
     "blocked the corrected command)", (*SWEEP, "--dt", "0.002"),
     ["dt: must resolve the fastest forcing VC"]),
    ("chart-step-no-parts", "a chart refused for its step", (*CHART, "--dt", "0.002"),
     ["dt: must resolve the fastest forcing VC"]),
    ("generate-out-deep", "generate into a folder inside one that does not exist",
     ("generate", "vakharia2015.toml", "--out", "gen/model"),
     ["--out: folder 'gen' does not exist"], _bad_spec),
])

CLI_CASES += _cases("accepted without a word (now judged)", ("simulate", "vakharia2015", "-o",
                                                            "r.nc", "--no-compile"), [
    ("save-every-beyond-run", "--save-every beyond the run's steps (one sample kept)",
     ("--duration", "0.01", "--transient", "0", "--save-every", "2000"),
     ["save_every: must be in [1, 1000] to keep at least 2 samples after the transient",
      "got 2000: 1 sample(s) kept"]),
    ("save-every-beyond-transient", "--save-every that keeps one sample after the transient",
     ("--duration", "0.01", "--transient", "0.005", "--save-every", "800"),
     ["save_every: must be in [1, 500]", "got 800"]),
    ("save-every-huge", "--save-every 1e11", ("--duration", "0.01", "--transient", "0",
                                              "--save-every", "100000000000"),
     ["save_every: must be in [1, 1000]"]),
])
CLI_CASES += _cases("accepted without a word (now judged)", ("simulate", "two-bearing-rotor",
                                                            "-o", "r.nc", *SHORT), [
    ("balls-bearing-twice", "one bearing's balls given twice (the last one used to win)",
     ("--n-balls", "left=7", "--n-balls", "left=8"),
     ["'--n-balls': bearing 'left' given twice (7 and 8); give each bearing once"]),
    ("balls-bearing-twice-comma", "one bearing twice in one --n-balls",
     ("--n-balls", "left=7,right=8,left=9"), ["bearing 'left' given twice (7 and 9)"]),
])
CLI_CASES += _cases("accepted without a word (now judged)", ("plot",), [
    ("plot-nan", "a run holding NaN (spectrum, poincare and classify refused it)",
     (*RUN, "-o", "f.png"), ["result file: 'run.nc': variable x is not finite at t = 5e-05 s"],
     _run_file("nan")),
    ("plot-one-sample", "a run of one sample", (*RUN, "-o", "f.png"),
     ["holds 1 sample(s); a run needs at least 2"], _run_file("one")),
    ("plot-tampered", "a run whose dt attribute was edited to -1", (*RUN, "-o", "f.png"),
     ["attribute dt must be a finite number > 0"], _run_file("tampered")),
])
CLI_CASES += _cases("accepted without a word (now judged)", SWEEP, [
    ("sweep-serial-and-scheduler", "--executor serial with --scheduler (the executor was "
     "silently overridden)", ("--executor", "serial", "--scheduler", "tcp://127.0.0.1:9"),
     ["--scheduler: only with --executor dask (or without --executor), got --executor "
      "serial"]),
    ("sweep-processes-and-scheduler", "--executor processes with --scheduler",
     ("--executor", "processes", "--scheduler", "tcp://127.0.0.1:9"),
     ["--scheduler: only with --executor dask"]),
    ("sweep-workers-and-scheduler", "--workers with --scheduler (ignored before)",
     ("--workers", "2", "--scheduler", "tcp://127.0.0.1:9"),
     ["--workers: not with --scheduler", "got --workers 2"]),
])
CLI_CASES += [
    CliCase("models-folder-missing", "accepted without a word (now judged)", "a "
            "BEARINGDYN_MODELS folder that does not exist (was ignored)", SIM_SHORT,
            ("BEARINGDYN_MODELS: 'nowhere' is not an existing folder; give folders of specs",),
            env=(("BEARINGDYN_MODELS", "nowhere"),)),
    CliCase("models-folder-is-file", "accepted without a word (now judged)", "a "
            "BEARINGDYN_MODELS entry that is a file", ("models",),
            ("BEARINGDYN_MODELS: 'f.txt' is not an existing folder",),
            setup=_spec_file("f.txt", "a file"), env=(("BEARINGDYN_MODELS", "f.txt"),)),
    CliCase("models-shadowed-name", "accepted without a word (now judged)", "a user spec in "
            "BEARINGDYN_MODELS with a shipped model's name, asked for by that name (was a "
            "warning, and the shipped model ran)", ("simulate", "duffing", "-o", "r.nc",
                                                    *SHORT),
            ("model: 'duffing' is both the shipped model and the spec mine/duffing.toml in "
             "BEARINGDYN_MODELS; rename that spec",),
            setup=_spec_file("mine/duffing.toml", (SPECS / "duffing.toml").read_text()),
            env=(("BEARINGDYN_MODELS", "mine"),),
            fixed=("simulate", "mine/duffing.toml", "-o", "r.nc", *SHORT)),
]


def _link_loop(name: str) -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        (folder / f"{name}.a").symlink_to(name)
        (folder / name).symlink_to(f"{name}.a")
    return setup


def _dangling(name: str) -> Callable[[Path], None]:
    def setup(folder: Path) -> None:
        (folder / name).symlink_to("gone.nc")
    return setup


BLAME = "messages that name the right thing"
CLI_CASES += _cases(BLAME, ("spectrum", *RUN, "--envelope"), [
    ("envelope-band-above-nyquist", "a pass band above the Nyquist frequency (was clipped, "
     "then printed as given)", ("--band", "20000:60000"),
     ["--band: must lie in [0, 50000] Hz, below the Nyquist frequency of this run (dt = "
      "1e-05 s), got 20000:60000"], _run_file()),
    ("envelope-band-zero-width", "a band of zero width", ("--band", "100:100"),
     ["--band: must be LO:HI in Hz with 0 <= LO < HI, got '100:100'"], _run_file()),
    ("envelope-band-narrow", "a band narrower than the run's frequency resolution (gave "
     "empty tables)", ("--band", "1000:1010"),
     ["--band: must be at least 40 Hz wide (two bins of this run's resolution 1/T = 20 Hz), "
      "got 1000:1010 (10 Hz)"], _run_file()),
])
CLI_CASES += _cases(BLAME, (), [
    ("sweep-speed-zero", "a speed axis from 0 to 0 (was blamed on shaft_hz)",
     (*SWEEP, "--from", "0", "--to", "0"),
     ["axis speed_rpm: the 'shaft' section has no period at speed_rpm = 0 (shaft_hz = 0 Hz); "
      "give values at which it turns (> 0 at both ends), or another --section"]),
    ("chart-speed-zero", "a chart whose speed axis starts at 0",
     (*CHART[:3], "speed_rpm:0:4000:2", *CHART[4:]),
     ["axis speed_rpm: the 'shaft' section has no period at speed_rpm = 0"]),
    ("run-model-no-balls", "the paper's case of a model without balls (said 'leave n_balls "
     "out, got 6' though none was given)", ("run", "--model", "duffing", "-o", "out"),
     ["--model: the paper's case (N_b = 6…10) varies N_b, the balls of a model with one "
      "bearing; model 'duffing' has no bearing"]),
    ("run-model-two-bearings", "the paper's case of a model with two bearings",
     ("run", "--model", "two-bearing-rotor", "-o", "out"),
     ["model 'two-bearing-rotor' has bearings left, right"]),
    ("reproduce-model-no-balls", "the reproduction of a model without balls",
     ("reproduce", "duffing", "--quick", "-o", "rep"),
     ["model: the reproduction varies N_b", "model 'duffing' has no bearing"]),
    ("model-link-loop", "a spec that is a symbolic-link loop (was 'not found')",
     ("simulate", "loop.toml", "-o", "r.nc"),
     ["model: 'loop.toml' is a symbolic link loop"], _link_loop("loop.toml")),
    ("result-link-loop", "a result file that is a symbolic-link loop",
     ("spectrum", "loop.nc"), ["result file: 'loop.nc' is a symbolic link loop"],
     _link_loop("loop.nc")),
    ("result-link-dangling", "a result file that links to nothing",
     ("spectrum", "link.nc"),
     ["result file: 'link.nc' is a symbolic link to 'gone.nc', which does not exist"],
     _dangling("link.nc")),
    ("generate-link-loop", "a spec to generate that is a symbolic-link loop",
     ("generate", "loop.toml", "--out", "gen"),
     ["loop.toml: is a symbolic link loop"], _link_loop("loop.toml")),
    ("plot-foreign", "a netCDF file of another program (was \"no variable 'x'\")",
     ("plot", "r.nc", "-o", "f.png"),
     ["result file: 'r.nc' is not a bearingdyn result (it names no model"], _foreign_result),
])

JUDGED = "judged, not failed inside"
CLI_CASES += _cases(JUDGED, SWEEP, [
    ("scheduler-scheme", "a scheduler address with a misspelt scheme",
     ("--scheduler", "htp://127.0.0.1:8786"),
     ["--scheduler: must be tcp://HOST:PORT (tcp or tls, port 1-65535), got "
      "'htp://127.0.0.1:8786' (unknown scheme 'htp')"]),
    ("scheduler-no-port", "a scheduler address without its port",
     ("--scheduler", "tcp://127.0.0.1"), ["got 'tcp://127.0.0.1' (no port)"]),
    ("scheduler-no-host", "a scheduler address without its host",
     ("--scheduler", "tcp://:8786"), ["got 'tcp://:8786' (no host)"]),
    ("scheduler-port-range", "a port beyond 65535", ("--scheduler", "tcp://127.0.0.1:99999"),
     ["(port 99999)"]),
    ("scheduler-empty", "an empty scheduler address (started a local cluster before)",
     ("--scheduler", ""), ["got '' (no port)"]),
    ("scheduler-refused", "a scheduler address where nothing listens (answered after 20 s)",
     ("--scheduler", "tcp://127.0.0.1:9"),
     ["--scheduler: tcp://127.0.0.1:9: nothing listens at 127.0.0.1:9 (connection refused)"]),
    ("scheduler-unknown-host", "a scheduler on a host that does not exist",
     ("--scheduler", "tcp://no-such-host.invalid:8786"),
     ["unknown host 'no-such-host.invalid'"]),
])
CLI_CASES += _cases(JUDGED, ("plot",), [
    ("plot-kind-damaged", "a result whose kind attribute was damaged (an internal error "
     "before)", (*RUN, "-o", "f.png"),
     ["result file: 'run.nc': attribute kind must be one of diagram, chart to be drawn, got "
      "'chrt'"], _run_file("kind")),
])
CLI_CASES += _cases(JUDGED, ("spectrum", *RUN, "--envelope"), [
    ("envelope-band-beyond", "a low-pass band beyond the Nyquist frequency (a filter error "
     "surfaced as an internal error)", ("--band", "0:60000"),
     ["--band: must lie in [0, 50000] Hz", "got 0:60000"], _run_file()),
    ("envelope-band-nan", "NaN as a band edge", ("--band", "nan:5000"),
     ["--band: must be LO:HI in Hz with 0 <= LO < HI, got 'nan:5000'"], _run_file()),
])

RUN_UPS = "run-ups, waterfalls, orbits, harmonic balance and tori"
CLI_CASES += _cases(RUN_UPS, SIM_SHORT, [
    ("ramp-start-zero", "a ramp that starts at 0 rpm", ("--speed-rpm", "0:5000"),
     ["--speed-rpm: the ramp's start speed must be a finite number > 0 rpm, got 0.0"]),
    ("speed-table-out-of-order", "a speed table whose times go back",
     ("--speed-rpm", "table.csv"),
     ["speed table 'table.csv' line 4: t_s must increase, got 0.1 after 0.2"],
     _spec_file("table.csv", "t_s,speed_rpm\n0,1000\n0.2,3000\n0.1,2000\n")),
])
CLI_CASES += _cases(RUN_UPS, (), [
    ("waterfall-constant-speed", "a waterfall of a constant-speed run",
     ("waterfall", *RUN, "-o", "w.png"),
     ["waterfall: the run is at a constant speed", "simulate with --speed-rpm A:B"],
     _run_file()),
    ("orbit-unknown-coordinate", "an orbit of a coordinate the run lacks",
     ("plot", *RUN, "--orbit", "--var", "x", "--var", "q", "-o", "o.png"),
     ["var: no state variable 'q' in this run; variables: x, y, vx, vy"], _run_file()),
    ("hb-no-harmonics", "harmonic balance with no harmonics",
     ("hb", "vakharia2015", "--period", "vc", "--harmonics", "0", "-o", "h.nc"),
     ["--harmonics: must be a whole number >= 1, got 0"]),
    ("hb-speed-zero-period", "a shaft period of a model whose speed is 0 (an internal "
     "error before)", ("hb", "mathieu", "--period", "shaft", "--harmonics", "4", "-o", "h.nc"),
     ["period: shaft is not defined for these parameters", "is the speed zero"]),
    ("torus-equal-frequencies", "a torus of one frequency twice",
     ("torus", "vakharia2015", "--frequencies", "shaft,shaft", "--harmonics", "4,2",
      "-o", "t.nc"),
     ["--frequencies: shaft and shaft are the same frequency"]),
    ("torus-unknown-bearing", "a torus frequency of a bearing the model lacks",
     ("torus", "vakharia2015", "--frequencies", "shaft,vc[left]", "--harmonics", "4,2",
      "-o", "t.nc"),
     ["--frequencies: no bearing 'left' in model 'vakharia2015'; bearings: bearing"]),
    ("torus-no-harmonics", "a torus with no harmonics of one frequency",
     ("torus", "vakharia2015", "--frequencies", "shaft,vc", "--harmonics", "0,2",
      "-o", "t.nc"),
     ["--harmonics: each of H1,H2 must be a whole number >= 1, got '0,2'"]),
])

CLI_CASES += _cases("envelopes and noise", ("spectrum", *RUN), [
    ("noise-snr-range", "an SNR beyond its range", ("--noise", "500"),
     ["--noise: must be an SNR in dB in [-60, 200], got 500.0"]),
    ("noise-seed-negative", "a negative noise seed", ("--noise", "0", "--noise-seed", "-1"),
     ["--noise-seed: must be a whole number >= 0, got -1"]),
    ("band-resonance-none", "the resonance band of a model without a structural resonance",
     ("--envelope", "--band", "resonance"),
     ["--band: 'resonance' needs a structural resonance of the model", "this model has none"]),
], setup=_run_file())

THIRD = "third round: judged before any store, work or allocation"
ATTR = ("attractors", "vakharia2015", "--samples", "4", "--box", "x:-1e-6:1e-6", "-o", "a.nc",
        "--max-periods", "40", "--revisits", "5", "--hits", "2", "--executor", "serial",
        "--quiet")
TORUS = ("torus", "vakharia2015", "--frequencies", "shaft,vc", "--harmonics", "4,2", "-o",
         "t.nc", "--run", "tr.nc")


BASINS_QUICK = ("--max-periods", "40", "--revisits", "5", "--hits", "2", "--executor", "serial",
                "--quiet")
RAMP_FIXED = (*SIM_SHORT, "--speed-rpm", "3000:4000")
"""The corrected command of a bad speed table: a ramp given inline."""


def _speed_table(rows: int) -> Callable[[Path], None]:
    return _spec_file("table.csv", "t_s,speed_rpm\n" + "".join(
        f"{0.001 * i:g},{1000 + i}\n" for i in range(rows)))


def _branch_of(model: str) -> Callable[[Path], None]:
    """Setup: ``b.nc``, the smallest file ``attractors --branch`` takes as a branch, of
    ``model``."""
    def setup(folder: Path) -> None:
        ds = xr.Dataset({"special": ("point", np.array(["", ""], dtype=object)),
                         "speed_rpm": ("point", [5000.0, 5500.0])},
                        attrs={"param": "speed_rpm", "model": model, "spec_sha256": "0" * 64})
        ds.to_netcdf(folder / "b.nc", engine="h5netcdf")
    return setup


def _tampered_kind(folder: Path) -> None:
    """Setup: ``run.nc``, a run whose ``kind`` attribute was edited to ``chart``."""
    (folder / "good.nc").write_bytes(_sample_run_bytes("good"))
    ds = xr.load_dataset(folder / "good.nc", engine="h5netcdf")
    (folder / "good.nc").unlink()
    ds.assign_attrs(kind="chart").to_netcdf(folder / "run.nc", engine="h5netcdf")


def _ramp_run(folder: Path) -> None:
    """Setup: ``run.nc``, a 0.3 s run-up of the paper's model from 3000 to 5000 rpm (made
    once per session)."""
    with _RUN_LOCK:
        if "ramp" not in _RUN_CACHE:
            import tempfile

            from analysis.integrate.simulate import simulate
            from analysis.integrate.speed_profile import SpeedProfile

            ds = simulate("vakharia2015", 6, duration=0.3, transient=0.0,
                          speed_rpm=SpeedProfile.ramp(3000.0, 5000.0))
            with tempfile.TemporaryDirectory() as tmp:
                ds.to_netcdf(Path(tmp) / "ramp.nc", engine="h5netcdf")
                _RUN_CACHE["ramp"] = (Path(tmp) / "ramp.nc").read_bytes()
    (folder / "run.nc").write_bytes(_RUN_CACHE["ramp"])


def _no_kind(folder: Path) -> None:
    """Setup: ``r.nc``, a bearingdyn result (it names its model) without a kind attribute
    and without times (a chart whose kind was removed)."""
    xr.Dataset({"nature": ("speed_rpm", np.zeros(2))},
               attrs={"model": "vakharia2015"}).to_netcdf(folder / "r.nc", engine="h5netcdf")


CLI_CASES += [CliCase(*row[:5], setup=row[5] if len(row) > 5 else None,
                      fixed=row[6] if len(row) > 6 else None) for row in [
    ("attractors-seed-negative", THIRD, "a negative seed (was an internal error that left "
     "OUT.parts and then refused the corrected seed)", (*ATTR, "--seed", "-1"),
     ("seed: must be a whole number in [0, 9223372036854775807], got -1",), None,
     (*ATTR, "--seed", "1")),
    ("attractors-seed-2-70", THIRD, "a seed of 2**70 (the same)",
     (*ATTR, "--seed", str(2**70)),
     (f"seed: must be a whole number in [0, 9223372036854775807], got {2**70}",), None,
     (*ATTR, "--seed", "1")),
    ("attractors-box-1e300", THIRD, "initial states of +-1e300 m (were mapped as "
     "'diverged')", (*ATTR[:5], "x:-1e300:1e300", *ATTR[6:]),
     ("--box: x from -1e+300 to 1e+300 m reaches beyond the blow-up limit",), None, ATTR),
    ("attractors-box-vx-1e300", THIRD, "initial velocities of +-1e300 m/s (were accepted)",
     (*ATTR, "--box", "vx:-1e300:1e300"),
     ("--box: vx from -1e+300 to 1e+300 m/s reaches beyond the velocity bound of 103 m/s "
      "(10 x the blow-up limit 0.00119 m x the model's fastest rate",), None,
     (*ATTR, "--box", "vx:-0.01:0.01")),
    ("basins-grid-vx-1e300", THIRD, "a basins grid of velocities of +-1e300 m/s (was "
     "accepted)", ("basins", "vakharia2015", "--x", "x:-1e-5:1e-5:4", "--y",
                   "vx:-1e300:1e300:4", "-o", "b.nc"),
     ("--y: vx from -1e+300 to 1e+300 m/s reaches beyond the velocity bound",), None,
     ("basins", "vakharia2015", "--x", "x:-1e-5:1e-5:4", "--y", "vx:-0.01:0.01:4", "-o",
      "b.nc", *BASINS_QUICK)),
    ("chart-ics-box-vx-1e300", THIRD, "chart --ics states drawn among velocities of +-1e300 "
     "m/s (was accepted)", (*CHART, "--ics", "2", "--ics-box", "vx:-1e300:1e300"),
     ("--ics-box: vx from -1e+300 to 1e+300 m/s reaches beyond the velocity bound",), None,
     (*CHART, "--ics", "2", "--ics-box", "vx:-0.01:0.01", "--quiet")),
    ("attractors-param-count-1e9", THIRD, "a --param count of 1e9 (was allocated first)",
     (*ATTR, "--param", "speed_rpm:5000:6000:1000000000"),
     ("--param: must be a whole number in [1, 100000] (values of the parameter), got "
      "1000000000",), None, (*ATTR, "--param", "speed_rpm:5000:6000:2")),
    ("basins-grid-names-axes", BLAME, "a basins grid too large for memory (named 'samples')",
     ("basins", "vakharia2015", "--x", "x:-1e-5:1e-5:100000", "--y", "y:-1e-5:1e-5:100000",
      "-o", "b.nc"),
     ("x, y: a 100000 x 100000 grid: 10000000000 initial states would need about",), None,
     ("basins", "vakharia2015", "--x", "x:-1e-5:1e-5:4", "--y", "y:-1e-5:1e-5:4", "-o",
      "b.nc", *BASINS_QUICK)),
    ("attractors-branch-other-model", "accepted without a word (now judged)", "a "
     "continuation branch of another model given to --branch",
     (*ATTR, "--param", "speed_rpm:5000:5500:2", "--branch", "b.nc"),
     ("--branch 'b.nc': the branch is of model 'duffing'; give a branch of model "
      "'vakharia2015'",), _branch_of("duffing"), (*ATTR, "--param", "speed_rpm:5000:5500:2")),
    ("attractors-workers-serial", "accepted without a word (now judged)", "--workers with "
     "--executor serial", (*ATTR, "--workers", "2"),
     ("--workers: --executor serial runs on one worker",), None, ATTR),
    ("spectrum-noise-seed-alone", "accepted without a word (now judged)", "--noise-seed "
     "without --noise", ("spectrum", *RUN, "--noise-seed", "3"),
     ("--noise-seed: only with --noise SNR_DB",), _run_file(),
     ("spectrum", *RUN, "--noise-seed", "3", "--noise", "20")),
    ("torus-run-duration-after", THIRD, "a --run length refused only after the torus was "
     "solved and written", (*TORUS, "--duration", "1e9"),
     ("--duration: 1e+09 s at dt = 1e-05 s gives 100000000000000 samples; give between 2 "
      "and 5e7",)),
    ("waterfall-samples-per-rev-1e9", THIRD, "--samples-per-rev of 1e9 (was allocated "
     "first)", ("waterfall", *RUN, "--orders", "--samples-per-rev", "1000000000"),
     ("--samples-per-rev: at most 2499999 over the record's 20 revolutions",), _ramp_run,
     ("waterfall", *RUN, "--orders", "--samples-per-rev", "64")),
    ("speed-table-folder", BLAME, "a speed table that is a folder (was 'not found')",
     (*SIM_SHORT, "--speed-rpm", "table.csv"),
     ("--speed-rpm: the speed table 'table.csv' is a folder",), _folder("table.csv"), RAMP_FIXED),
    ("speed-table-fifo", BLAME, "a speed table that is a pipe (was 'not found')",
     (*SIM_SHORT, "--speed-rpm", "table.csv"),
     ("--speed-rpm: the speed table 'table.csv' is a pipe (FIFO), not a plain file",),
     _fifo("table.csv"), RAMP_FIXED),
    ("speed-table-device", BLAME, "a speed table that is a device (was 'not found')",
     (*SIM_SHORT, "--speed-rpm", "/dev/null"),
     ("--speed-rpm: the speed table '/dev/null' is a device or socket",), None, RAMP_FIXED),
    ("speed-table-rows", THIRD, "a speed table over the row limit (was read whole first)",
     (*SIM_SHORT, "--speed-rpm", "table.csv"),
     ("speed table 'table.csv': must have 2 to 257 rows, got more than 257",),
     _speed_table(300), RAMP_FIXED),
    ("speed-table-bytes", THIRD, "a speed table of 1,000,000 rows (16 MB; was read whole)",
     (*SIM_SHORT, "--speed-rpm", "table.csv"),
     ("--speed-rpm: the speed table 'table.csv' is ", "bytes; at most 1048576 bytes"),
     _speed_table(1_000_000), RAMP_FIXED),
    ("plot-kind-tampered", BLAME, "a run whose kind attribute was edited to 'chart' (was a "
     "KeyError inside plot)", ("plot", *RUN, "-o", "p.png"),
     ("result file: 'run.nc': attribute kind says 'chart', but the file lacks the chart's",),
     _tampered_kind),
    ("bode-no-kind", BLAME, "a Bode plot of a netCDF file without a kind (was called "
     "\"kind 'run'\")", ("plot", "r.nc", "--bode", "-o", "p.png"),
     ("result file: 'r.nc' is not a sweep's diagram (it has no kind attribute)",),
     _no_kind),
]]

NO_CC = (("BEARINGDYN_CC", "/nonexistent/bin/cc"),)
"""A machine without a C compiler: no member kernel can be built."""
SWEEP_NO_FOLLOW = ("sweep", "vakharia2015", "--param", "speed_rpm", "--from", "4000", "--to",
                   "5000", "--num", "4", "--no-follow", "-o", "d.nc")
CLI_CASES += [
    CliCase("chart-kernel-unbuildable", THIRD, "chart --device cpu where the member kernel "
            "cannot be built (no C compiler; was run point by point without a word)",
            (*CHART, "--device", "cpu"),
            ("--device cpu: the member kernel of model 'vakharia2015' with N_b 7 cannot be "
             "built: C compiler '/nonexistent/bin/cc' not found",), env=NO_CC,
            fixed=(*CHART, "--device", "auto", "--quiet")),
    CliCase("sweep-kernel-unbuildable", THIRD, "sweep --no-follow --device cpu where the "
            "member kernel cannot be built (was an estimate, then an internal error)",
            (*SWEEP_NO_FOLLOW, "--device", "cpu"),
            ("--device cpu: the member kernel of model 'vakharia2015' with N_b 6 cannot be "
             "built: C compiler '/nonexistent/bin/cc' not found",), env=NO_CC),
]

_GENERATED: dict[str, bytes] = {}


def _damaged_out(damage: Callable[[Path], None]) -> Callable[[Path], None]:
    """Setup: ``gen/``, a folder written by ``bearingdyn generate duffing.toml --out gen``
    (made once, copied), then ``damage(gen)``."""
    def setup(folder: Path) -> None:
        with _RUN_LOCK:
            if not _GENERATED:
                import tempfile

                from modelgen.codegen import generate

                with tempfile.TemporaryDirectory() as tmp:
                    spec = Path(tmp) / "duffing.toml"
                    spec.write_text((SPECS / "duffing.toml").read_text())
                    generate([str(spec)], root=Path(tmp) / "gen")
                    _GENERATED.update({str(f.relative_to(Path(tmp) / "gen")): f.read_bytes()
                                       for f in (Path(tmp) / "gen").rglob("*")
                                       if f.is_file() and "__pycache__" not in f.parts})
        for rel, data in _GENERATED.items():
            (folder / "gen" / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / "gen" / rel).write_bytes(data)
        damage(folder / "gen")
    return setup


CLI_CASES += _cases("half-written and damaged generated code", ("simulate", "gen", "-o",
                                                               "r.nc", *SHORT), [
    ("out-folder-truncated", "a model folder whose module was truncated by hand (was an "
     "internal error)", (),
     ["model: gen is damaged (duffing/__init__.py was changed (truncated or edited)); write "
      "it again with `bearingdyn generate SPEC --out"],
     _damaged_out(lambda gen: (gen / "duffing" / "__init__.py").write_text("NAME = 'duf"))),
    ("out-folder-file-missing", "a model folder with its C file removed", (),
     ["model: gen is damaged (duffing/duffing.c is missing)"],
     _damaged_out(lambda gen: (gen / "duffing" / "duffing.c").unlink())),
    ("out-folder-manifest-damaged", "a model folder whose manifest is not JSON", (),
     ["model: gen is damaged (MANIFEST.json is damaged)"],
     _damaged_out(lambda gen: (gen / "MANIFEST.json").write_text("{"))),
    ("out-folder-runtime-missing", "a model folder without its runtime", (),
     ["model: gen is not a generated model folder"],
     _damaged_out(lambda gen: (gen / "_runtime.py").unlink())),
])

FOURTH = "fourth round: targets, options and the environment judged first"
ONE_ROW = """name = "one-row"
[conditions]
speed_rpm = 5000.0
[[rows]]
n_balls = 8
class = "quasi-periodic"
"""
CALIBRATE = ("calibrate", "vakharia2015", "--prior", "damping:10:3162:log", "--samples", "4",
             "--rounds", "1", "--revolutions", "40", "--transient-revolutions", "5", "-o",
             "cal.nc")
CAL_FIXED = (*CALIBRATE, "--target", "one.toml")


def _target(text: str, name: str = "t.toml") -> Callable[[Path], None]:
    """Setup: a target file ``name`` holding ``text``, and the valid ``one.toml`` beside."""
    def setup(folder: Path) -> None:
        (folder / "one.toml").write_text(ONE_ROW)
        (folder / name).write_text(text)
    return setup


def _target_variant(old: str, new: str) -> Callable[[Path], None]:
    assert old in ONE_ROW
    return _target(ONE_ROW.replace(old, new))


def _fifo_target(folder: Path) -> None:
    (folder / "one.toml").write_text(ONE_ROW)
    os.mkfifo(folder / "t.toml")


def _folder_target(folder: Path) -> None:
    (folder / "one.toml").write_text(ONE_ROW)
    (folder / "t.toml").mkdir()


def _cache_is_a_file(folder: Path) -> None:
    (folder / "one.toml").write_text(ONE_ROW)
    (folder / "cache").write_text("a file where the cache folder should be")


ATTRACTORS = ("attractors", "balanced-rotor", "--n-balls", "8", "--set", "radial_load=50",
              "--samples", "4", "--box", "x:-20e-6:30e-6", "--box", "y:-20e-6:20e-6", "-o",
              "att.nc")
CLI_CASES += [
    CliCase("target-class-number", FOURTH, "a target row's class given as a number (was an "
            "internal error)", (*CALIBRATE, "--target", "t.toml"),
            ("target rows[0].class: must be a class or a list of them, got 5",),
            setup=_target_variant('class = "quasi-periodic"', "class = 5"), fixed=CAL_FIXED),
    CliCase("target-present-number", FOURTH, "a target's present lines given as a number "
            "(was an internal error)", (*CALIBRATE, "--target", "t.toml"),
            ("target rows[0].present.x: must be a line name or a list of them, got 5",),
            setup=_target_variant('class = "quasi-periodic"',
                                  'class = "quasi-periodic"\npresent = {x = 5}')),
    CliCase("target-balls-list", FOURTH, "a target row's n_balls given as a list (was an "
            "internal error)", (*CALIBRATE, "--target", "t.toml"),
            ("target rows[0].n_balls: must be a whole number of balls, or a table by bearing",),
            setup=_target_variant("n_balls = 8", "n_balls = [8]")),
    CliCase("target-rows-text", FOURTH, "a target's rows given as text (was called an empty "
            "target)", (*CALIBRATE, "--target", "t.toml"),
            ("target rows: must be a list of [[rows]] tables, got 'abc'",),
            setup=_target('name = "t"\nrows = "abc"\n')),
    CliCase("target-missing", FOURTH, "a target file that does not exist (was not named)",
            (*CALIBRATE, "--target", "nothere.toml"),
            ("--target: must be a built-in target", "there is no file 'nothere.toml'"),
            setup=_target(ONE_ROW, "one.toml"), fixed=CAL_FIXED),
    CliCase("target-folder", FOURTH, "a target that is a folder",
            (*CALIBRATE, "--target", "t.toml"), ("'t.toml' is a folder",),
            setup=_folder_target),
    CliCase("target-fifo", FOURTH, "a target that is a FIFO (never read: it would wait)",
            (*CALIBRATE, "--target", "t.toml"), ("'t.toml' is not a regular file",),
            setup=_fifo_target),
    CliCase("target-device", FOURTH, "/dev/zero as the target (never read)",
            (*CALIBRATE, "--target", "/dev/zero"), ("'/dev/zero' is not a regular file",)),
    CliCase("target-dollar-name", FOURTH, "a target name with $…$ (broke the figure after "
            "the work was done and the file written)",
            (*CALIBRATE, "--target", "t.toml", "--plot", "cal.png"),
            ("target name: must be one line of text (at most 120 characters, no '$'), got "
             "'$N_b$ table'",),
            setup=_target_variant('name = "one-row"', 'name = "$N_b$ table"'),
            fixed=(*CAL_FIXED, "--plot", "cal.png")),
    CliCase("prior-fixed-by-target", FOURTH, "a --prior on a parameter the target fixes "
            "(speed_rpm: silently overridden by the rows)",
            ("calibrate", "vakharia2015", "--prior", "speed_rpm:3000:6000", "--samples", "4",
             "--rounds", "1", "-o", "cal.nc", "--target", "one.toml"),
            ("--prior speed_rpm: the target fixes speed_rpm (N_b = 8); calibrate a parameter "
             "the target leaves free",), setup=_target(ONE_ROW, "one.toml"), fixed=CAL_FIXED),
    CliCase("calibrate-dt-too-large", FOURTH, "calibrate --dt 1 (was blamed on --prior)",
            (*CAL_FIXED, "--dt", "1"), ("--dt: at N_b = 8: dt: must be in",),
            setup=_target(ONE_ROW, "one.toml"), fixed=CAL_FIXED),
    CliCase("calibrate-cache-is-a-file", FOURTH, "calibrate with a cache path that is a file "
            "(was an internal error after the estimate)", CAL_FIXED,
            ("--device cpu: the member kernel of model 'vakharia2015' with N_b 8 cannot be "
             "built", "Not a directory"), setup=_cache_is_a_file,
            env=(("BEARINGDYN_CACHE", "cache"),)),
    CliCase("calibrate-no-compiler", FOURTH, "calibrate without a C compiler (was an "
            "internal error after the estimate)", CAL_FIXED,
            ("--device cpu: the member kernel of model 'vakharia2015' with N_b 8 cannot be "
             "built: C compiler '/nonexistent/bin/cc' not found",),
            setup=_target(ONE_ROW, "one.toml"), env=NO_CC),
    CliCase("threads-not-a-number", FOURTH, "BEARINGDYN_THREADS=abc (was ignored)",
            ("devices",), ("BEARINGDYN_THREADS: must be a whole number in [1, ",
                           "got 'abc'; unset it to use every core"),
            env=(("BEARINGDYN_THREADS", "abc"),)),
    CliCase("threads-zero", FOURTH, "BEARINGDYN_THREADS=0 (was ignored)", ("devices",),
            ("BEARINGDYN_THREADS: must be a whole number in [1, ", "got '0'"),
            env=(("BEARINGDYN_THREADS", "0"),)),
    CliCase("threads-negative", FOURTH, "BEARINGDYN_THREADS=-4 (was ignored)", ("devices",),
            ("BEARINGDYN_THREADS: must be a whole number in [1, ", "got '-4'"),
            env=(("BEARINGDYN_THREADS", "-4"),)),
    CliCase("threads-too-many", FOURTH, "BEARINGDYN_THREADS=100000 (was reported as 100000 "
            "cores)", ("devices",), ("BEARINGDYN_THREADS: must be a whole number in [1, ",
                                     "got '100000'"),
            env=(("BEARINGDYN_THREADS", "100000"),)),
    CliCase("target-vc-two-bearings", FOURTH, "a bare VC in a target of a two-bearing model "
            "(the refusal listed VC as valid and never said VC[<bearing>])",
            ("calibrate", "two-bearing-rotor", "--target", "t.toml", "--prior",
             "damping:10:1000", "--samples", "4", "--rounds", "1", "-o", "cal.nc"),
            ("target rows[0].major.x: must be a line name m X + n VC[<bearing>]",
             "VC[left], 2VC[left]", "got 'VC'"),
            setup=_target('name = "vc"\n[[rows]]\nn_balls = {left = 8, right = 8}\n'
                          'major = { x = "VC" }\n')),
    CliCase("match-threshold-without-param", FOURTH, "--match-threshold without --param (was "
            "ignored)", (*ATTRACTORS, "--match-threshold", "0.3"),
            ("--match-threshold: matches attractors between consecutive --param values; give "
             "--param NAME:LO:HI:N, or leave it out",), fixed=ATTRACTORS),
]



@dataclass
class Outcome:
    returncode: int
    stdout: str
    stderr: str
    folder: Path
    before: dict = field(default_factory=dict)
    after: dict = field(default_factory=dict)


def _listing(folder: Path) -> dict[str, bytes | None]:
    """Every entry under ``folder`` with its bytes (None for folders and pipes)."""
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None
            for p in sorted(folder.rglob("*"))}


def _run_case(case: CliCase, folder: Path) -> Outcome:
    folder.mkdir(parents=True)
    if case.setup:
        case.setup(folder)
    before = _listing(folder)
    res = run_cli(*case.args, cwd=folder, env=dict(case.env))
    return Outcome(res.returncode, res.stdout, res.stderr, folder, before, _listing(folder))


def run_cli_cases(root: Path, cases: list[CliCase] = CLI_CASES) -> dict[str, Outcome]:
    """Run every command case in its own folder under ``root``, several at a time."""
    workers = min(8, 2 * (os.cpu_count() or 1))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {c.id: pool.submit(_run_case, c, root / c.id) for c in cases}
        return {name: future.result() for name, future in futures.items()}


ONE_WORKER = pytest.mark.xdist_group("bad-input-commands")
"""The tests that read ``cli_outcomes`` run on one of xdist's workers (``--dist loadgroup``:
tests/conftest.py), so the catalogue's commands run once (it was once per worker: twice the
minutes)."""


@pytest.fixture(scope="module")
def cli_outcomes(tmp_path_factory) -> dict[str, Outcome]:
    return run_cli_cases(tmp_path_factory.mktemp("cli"))


@ONE_WORKER
@pytest.mark.parametrize("case", [pytest.param(c, id=c.id, marks=c.marks) for c in CLI_CASES])
def test_bad_command(case: CliCase, cli_outcomes):
    out = cli_outcomes[case.id]
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    message = out.stderr.strip()
    if case.one_line:
        assert message.startswith("error: ") and "\n" not in message, message
    for fragment in case.expect:
        assert fragment in message, message
    assert out.after == out.before, "a refused command writes, removes and changes nothing"


@ONE_WORKER
@pytest.mark.parametrize("case", [pytest.param(c, id=c.id) for c in CLI_CASES if c.fixed])
def test_the_corrected_command_then_runs(case: CliCase, cli_outcomes):
    """Nothing a refusal leaves (a store folder, a temporary) blocks the corrected command,
    run in the same folder after it."""
    out = cli_outcomes[case.id]
    assert out.returncode == 2, out.stderr
    res = run_cli(*case.fixed, cwd=out.folder, env=dict(case.env))
    assert res.returncode == 0, res.stderr


@ONE_WORKER
def test_spec_errors_through_the_command_are_one_line(cli_outcomes):
    """The spec cases above load in-process; these two show the command's side: exit 2."""
    for name in ("spec-unknown-term", "spec-hostile-expression"):
        out = cli_outcomes[name]
        assert out.returncode == 2 and out.stderr.count("\n") == 1
        assert not (out.folder / "gen").exists(), "nothing generated from a bad spec"


def test_catalogue_is_large_and_distinct():
    ids = [c.id for c in [*SPEC_CASES, *CLI_CASES]]
    assert len(ids) == len(set(ids)) and len(ids) >= 250


# ---------------------------------------------------------------- numerical failures

def test_blow_up_stops_with_its_time_and_a_fix():
    from analysis.errors import SimulationError
    from analysis.integrate.simulate import simulate

    with pytest.raises(SimulationError, match=r"blew up at t = 1\.35 s.*try a smaller dt"):
        simulate("duffing", duration=20.0, transient=0.0, cubic_stiffness=-1.0, compiled=False)


def test_unstable_step_is_refused_before_running():
    """The step check catches what used to end in a blow-up (the RK4 instability)."""
    from analysis.errors import InputError
    from analysis.integrate.simulate import simulate

    with pytest.raises(InputError, match=r"dt: must be in \(0, 0\.000101\] s.*5e-05"):
        simulate("vakharia2015", 8, duration=0.05, transient=0.0, dt=2e-4, radial_load=1e5)
    ok = simulate("vakharia2015", 8, duration=0.02, transient=0.0, dt=5e-5, radial_load=1e5,
                  compiled=False)
    assert np.all(np.isfinite(ok.x.values))


def test_cvodes_failure_surfaces_the_solver_message():
    from analysis.errors import SimulationError
    from analysis.integrate.simulate import simulate

    with pytest.raises(SimulationError, match=r"CVODES failed: .*CV_ILL_INPUT"):
        simulate("vakharia2015", duration=0.01, transient=0.0, method="cvodes", rtol=1e-30,
                 atol=0.0)


def test_newton_non_convergence_is_a_result():
    from analysis.stability.periodic import shoot

    orbit = shoot("balanced-rotor", 8, "vc", radial_load=50.0, max_iter=1, tol=1e-30,
                  settle=0.05)
    assert not orbit.converged
    assert orbit.message == f"no convergence in 1 iterations (scaled residual {orbit.residual:.2e})"


def test_continuation_start_failure_is_reported():
    from analysis.errors import InputError
    from analysis.stability.continuation import continue_orbits

    with pytest.raises(InputError, match=r"start: no periodic orbit found at forcing_amplitude "
                                         r"= 7\.5 \(singular Newton matrix"):
        continue_orbits("duffing", param="forcing_amplitude", start=7.5, stop=8.0,
                        period="shaft", dt=0.01, guess=np.array([2.5, 0, 0, 0]), t0=0.0)


def test_crash_mid_write_leaves_nothing(tmp_path):
    from analysis.errors import WriteError
    from analysis.io import atomic_write

    def half_then_crash(tmp: Path) -> None:
        tmp.write_bytes(b"CDF\x01 half a result")
        raise OSError("disk full")

    with pytest.raises(WriteError, match="disk full"):
        atomic_write(tmp_path / "run.nc", half_then_crash)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "run.nc").write_text("previous result")
    with pytest.raises(WriteError, match="nothing was changed"):
        atomic_write(tmp_path / "run.nc", half_then_crash)
    assert [p.name for p in tmp_path.iterdir()] == ["run.nc"]
    assert (tmp_path / "run.nc").read_text() == "previous result", "the old file survives"


# ---------------------------------------------------------------- the docs table

GROUPS = ["wrong type", "missing field", "unknown field", "units and ranges", "user parameters",
          "custom expressions", "bodies and bearings", "command line", "simulate", "files",
          "models and specs", "runs as input", "stability", "continuation", "sweeps", "curves",
          "jobs", "checked before any write", "accepted without a word (now judged)",
          "messages that name the right thing", "judged, not failed inside",
          "half-written and damaged generated code", RUN_UPS, "envelopes and noise", THIRD,
          FOURTH, "numerical failures"]


KERNEL_KEY = re.compile(r"_[0-9a-f]{20}\.so")
"""A kernel library's cache key in a message (it depends on the host's compiler, its flags
and instruction set: the page shows ``_<key>.so``)."""


def render_docs(spec_messages: dict[str, str], cli_outcomes: dict[str, Outcome]) -> str:
    """docs/bad-inputs.md from the catalogue and the messages it produced."""
    rows: dict[str, list[str]] = {g: [] for g in GROUPS}
    for case in SPEC_CASES:
        rows[case.group].append(_row(case.what, case.shown(), spec_messages[case.id]))
    for case in CLI_CASES:
        out = cli_outcomes[case.id]
        text = out.stderr.strip()
        if case.id == "output-is-folder" or (IS_ROOT and case.id == "output-folder-locked"):
            text = "(see the note below the table)"
        elif not case.one_line:  # click's usage error: the line after the usage lines
            errors = [line for line in text.splitlines() if line.startswith("Error: ")]
            text = errors[-1].removeprefix("Error: ") if errors else text.splitlines()[-1]
        rows[case.group].append(_row(case.what, case.shown(), KERNEL_KEY.sub("_<key>.so", text)))
    parts = [DOCS_HEAD]
    for group in GROUPS:
        parts.append(f"\n## {group.capitalize()}\n\n| input | example | message |\n|---|---|---|\n"
                     + "\n".join(rows[group]) + "\n")
    parts.append(DOCS_TAIL)
    return "".join(parts)


def _row(what: str, shown: str, message: str) -> str:
    shown, message = (text.replace("|", "\\|") for text in (shown, message))
    return f"| {what} | {shown} | `{message}` |"


DOCS_HEAD = """# Bad inputs and what bearingdyn says

Generated by `python -m tests.cli.test_bad_inputs` from the catalogue in
[tests/cli/test_bad_inputs.py](../tests/cli/test_bad_inputs.py), which the test suite runs:
every row is a test, and a test fails when this page and the messages drift apart.

Every bad input ends the command with **one line** on stderr, `error: <field>: <what is
allowed>, got <value>`, and **exit code 2**; `bearingdyn --debug …` shows the traceback.
Spec files are checked field by field, and all problems of a file are listed in that one
line, separated by `;`. Spec examples below edit `modelgen/specs/vakharia2015.toml`
(`duffing.toml` where noted by the message); the spec messages are those of
`bearingdyn generate vakharia2015.toml`.
"""

DOCS_TAIL = """
Notes:

- *Wrong option types* (`--n-balls six`) and unknown options are caught by the command-line
  parser before the command runs: one line naming the option and the command's `--help`,
  exit code 2.
- *An output folder without write permission* is refused before the file is written (for
  root, who may write anywhere, the check passes). Outputs are checked before any work:
  suffix, an existing folder or pipe at the path, the name's length, the folder.
- Every refused command in this catalogue leaves its folder exactly as it was: the test
  compares every file's bytes before and after.
- Anything unexpected ends in one line too (`internal error: <type>: <message> (run with
  --debug for the traceback)`, exit code 1); a full disk or a missing permission while
  writing is one line with exit code 1 (the old file, if any, is kept); Ctrl-C or SIGTERM
  ends with `interrupted`, exit code 130, also while the command is still loading (the
  console script's first statement installs the handler, `analysis/cli/entry.py`). What
  remains is the interpreter's own start before that statement: Python's initialisation and
  `site` with the environment's `.pth` files (20–100 ms here, more on a loaded machine); a
  Ctrl-C there is Python's own (a `KeyboardInterrupt` traceback from `site`, or the process
  killed before Python handles signals). `tests/cli/test_startup_interrupt.py` interrupts at
  0–1 s.
- *A writer killed during its final write* (SIGKILL, a power cut) leaves its hidden
  temporary beside the output (`.OUT.<pid>-<random>.tmp`, the whole streamed run so far);
  the next run to the same output removes every such temporary whose process is gone
  (`analysis.io.remove_stale_temporaries`, called before every write), and keeps one a
  running writer still fills. `tests/cli/test_interrupts.py` kills a 30 s `simulate` with a
  real SIGKILL and runs the next command.
- Generated code is written whole or not at all (a temporary folder, renamed into
  place): a disk that fills during `bearingdyn generate` ends in one line naming the file
  (`error: cannot use '…/__init__.py': No space left on device`, exit code 1) and leaves
  the old model folder, or none. A damaged user-cache entry (checked against its
  `MANIFEST.json` of SHA-256 hashes) is generated again with one warning line;
  `tests/modelgen/test_generate_faults.py` fills the disk part way and damages entries by hand.
- Numerical failures: a blow-up (non-finite state, or a displacement beyond 1000 clearances
  or a quarter of the ball diameter) stops the run with its time and a suggestion; CVODES
  failures carry the solver's own return code; a shooting solve that does not converge is
  a result (`converged = false` and the reason), and a continuation whose first orbit does
  not converge stops with the reason (`start: …`).

## Custom expression terms

`[[terms]] kind = "expression"` takes `fx`, `fy` (force on the rotor, N) and `ball` (radial
load of every ball in contact, N) as text. Allowed: numbers, `pi`, the state `x`, `y`, `vx`,
`vy`, the time `t`, the shaft speed `omega` (rad/s), in `ball` also `c`, `s` (cos and sin of the
ball angle) and `delta` (its contact deflection, m), the model's parameters, `+ - * / **`,
parentheses, and the functions `sin cos exp sqrt abs Heaviside Max Min` (Heaviside(0) = 0).
A new parameter is declared with its unit and range:
`k3 = { value = 1e15, unit = "N/m^3", source = "…", low = 0.0, high = 1e20 }`.
The text is read as a syntax tree and checked against that list; it is never executed.
Limits: 2000 characters, 40 levels of nesting, numeric exponents within ±100, every number a
finite double.

## Fuzzing

`python -m tests.fuzz_spec --minutes 3` feeds randomly damaged specs (any TOML value in any
field, keys removed and added, broken TOML text, custom terms with random and hostile
expressions) to the spec loader, and random text and syntax trees to the expression parser,
until the time is up. Anything but a valid result or the clean error is a crash: it is
printed, shrunk to a small example, and the exit code is 1. Not part of the test suite.
"""


def spec_messages(root: Path) -> dict[str, str]:
    """The message of every spec case, each loaded in its own folder under ``root``."""
    messages = {}
    for case in SPEC_CASES:
        (root / case.id).mkdir(parents=True)
        messages[case.id] = _spec_message(case, root / case.id)
    return messages


@ONE_WORKER
def test_docs_table_is_current(cli_outcomes, tmp_path):
    assert DOCS.read_text() == render_docs(spec_messages(tmp_path), cli_outcomes), (
        "docs/bad-inputs.md is stale: run `python -m tests.cli.test_bad_inputs`")


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        DOCS.write_text(render_docs(spec_messages(Path(tmp) / "spec"),
                                    run_cli_cases(Path(tmp) / "cli")))
    print(f"wrote {DOCS.relative_to(ROOT)}", file=sys.stderr)
