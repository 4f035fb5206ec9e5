"""Property-based tests (hypothesis): physics of the contact for random specs, parameters and
states; spec -> TOML -> spec; the expression parser on random text and syntax trees.

Contact (SymPy equations of random term combinations, and the generated CasADi code of the
shipped models): a ball out of contact carries nothing; a ball never pulls (its load is
>= 0) and the resultant of the balls pushes the rotor back, (F_x, F_y)·(x, y) <= 0; the load
goes to zero as the deflection goes to zero from above.
"""

from __future__ import annotations

import copy
import functools
import math
import string
import sys
import tomllib
from pathlib import Path

import casadi as ca
import numpy as np
import sympy as sp
import tomli_w
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from analysis.model import load_model
from modelgen.assemble import assemble
from modelgen.codegen import CasadiPrinter
from modelgen.expressions import FUNCTIONS, ExpressionError, parse_expression
from modelgen.quantities import QUANTITIES
from modelgen.spec import SpecError, parse_spec, shipped_spec_names
from tests.conftest import SPECS

FAST = settings(max_examples=60, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])
BASE = tomllib.loads((SPECS / "vakharia2015-consistent.toml").read_text())


# ---------------------------------------------------------------- the contact

@functools.cache
def ball_load(cage: str, centrifugal: str | None, custom: bool):
    """Q(c, s, x, y, vx, vy, t, *p) of a spec with these ball terms, and its parameters."""
    data = copy.deepcopy(BASE)
    data["terms"] = [{"kind": "hertz_contact", "cage": cage}]
    if centrifugal:
        data["terms"].append({"kind": "centrifugal", "variant": centrifugal})
    if custom:
        data["parameters"]["kb"] = {"value": 1e12, "unit": "N/m^2", "source": "test",
                                    "low": 0.0, "high": 1e15}
        data["terms"].append({"kind": "expression", "ball": "kb*delta**2"})
    eq = assemble(parse_spec(data))
    ctx = eq.ctx
    f = sp.lambdify([ctx.c, ctx.s, ctx.x, ctx.y, ctx.vx, ctx.vy, ctx.t,
                     *ctx.params.values()], eq.ball_load, modules="numpy")
    return f, list(ctx.params), parse_spec(data).parameter_values()


@st.composite
def contact_cases(draw, clearance=(-2e-5, 5e-5)):
    """(loads function, parameter vector, N_b, ball angles, gamma, spec kind)."""
    cage = draw(st.sampled_from(["race_diameters", "pitch_diameter"]))
    centrifugal = draw(st.sampled_from([None, "paper_eq9", "loaded_zone"]))
    custom = draw(st.booleans())
    f, names, values = ball_load(cage, centrifugal, custom)
    scale = draw(st.floats(0.2, 5.0))  # the whole bearing, so the geometry stays valid
    values = dict(values)
    for name in ("inner_race_diameter", "outer_race_diameter", "pitch_diameter",
                 "ball_diameter"):
        values[name] *= scale
    values["contact_stiffness"] = draw(st.floats(1e7, 1e12))
    values["radial_clearance"] = draw(st.floats(*clearance))
    values["speed_rpm"] = draw(st.floats(0.0, 3e4))
    values["ball_density"] = draw(st.floats(1e3, 2e4))
    n_balls = draw(st.integers(3, 17))
    psi = draw(st.floats(0.0, 2 * math.pi))
    theta = 2 * math.pi * np.arange(n_balls) / n_balls + psi
    p = [values[n] for n in names]
    return f, p, theta, values["radial_clearance"], centrifugal


def _loads(f, p, theta, x, y):
    return np.broadcast_to(f(np.cos(theta), np.sin(theta), x, y, 0.0, 0.0, 0.0, *p),
                           theta.shape).astype(float)


def _resultant(loads, theta):
    """Force of the balls on the rotor, -Σ Q_i (cos θ_i, sin θ_i) (N)."""
    return -np.sum(loads * np.cos(theta)), -np.sum(loads * np.sin(theta))


@FAST
@given(contact_cases(clearance=(1e-7, 5e-5)), st.floats(0, 0.999), st.floats(0, 2 * math.pi))
def test_no_force_when_every_ball_is_out_of_contact(case, fraction, phi):
    f, p, theta, gamma, centrifugal = case
    x, y = fraction * gamma * math.cos(phi), fraction * gamma * math.sin(phi)
    loads = _loads(f, p, theta, x, y)
    fx, fy = _resultant(loads, theta)
    if centrifugal == "paper_eq9":  # −P_c on every ball: cancels over the ball set
        assert math.hypot(fx, fy) <= 1e-12 * (np.abs(loads).sum() + 1e-300)
    else:
        assert np.all(loads == 0.0) and fx == fy == 0.0


@FAST
@given(contact_cases(), st.floats(0, 5), st.floats(0, 2 * math.pi))
def test_balls_never_pull_and_the_contact_restores(case, radius, phi):
    f, p, theta, gamma, centrifugal = case
    r = radius * max(abs(gamma), 1e-6)
    x, y = r * math.cos(phi), r * math.sin(phi)
    loads = _loads(f, p, theta, x, y)
    fx, fy = _resultant(loads, theta)
    if centrifugal != "paper_eq9":
        assert np.all(loads >= 0.0), "a ball pushes the rotor but never pulls it"
    size = np.abs(loads).sum() * r + 1e-300
    assert fx * x + fy * y <= 1e-12 * size, "the balls push the rotor back"


@FAST
@given(contact_cases(), st.integers(0, 16), st.floats(0, 2 * math.pi))
def test_load_vanishes_as_contact_opens(case, ball, _):
    f, p, theta, gamma, _ = case
    theta_i = theta[ball % len(theta)]
    far = -(abs(gamma) + 1e-3)  # every ball far out of contact: only −P_c is left
    free = _loads(f, p, np.array([theta_i]), far * math.cos(theta_i), far * math.sin(theta_i))[0]
    previous = math.inf
    for eps in (1e-7, 1e-9, 1e-11, 1e-13):
        r = gamma + eps  # ball i is compressed by eps, every other ball by less
        x, y = r * math.cos(theta_i), r * math.sin(theta_i)
        q = _loads(f, p, np.array([theta_i]), x, y)[0] - free
        assert 0.0 <= q <= previous
        previous = q
    k_max, kb = 1e12, 1e12  # the largest contact stiffness drawn; the custom kb*delta**2
    # δ = x cos θ + y sin θ − γ0 carries the rounding of r·(cos² + sin²) and of the
    # subtraction: a few ulp of γ0, against an approach of 1e-13 m
    delta = 1e-13 + 8 * abs(gamma) * np.finfo(float).eps
    bound = (k_max * delta**1.5 + kb * delta**2) * (1 + 1e-12)  # and the bound's own rounding
    assert previous <= bound, "load -> 0 as δ -> 0+"


def _generated_forces(name: str, n_balls: int):
    """Force of the balls on the rotor from the generated CasADi code (loads, damping off)."""
    model = load_model(name)
    rhs = model.functions(n_balls).rhs
    values = model.parameters({"radial_load": 0.0, "damping": 0.0, **(
        {"unbalance_force": 0.0} if "unbalance_force" in model.defaults else {})})
    mass = values["rotor_mass"]

    def force(t: float, x: float, y: float) -> np.ndarray:
        dz = np.asarray(rhs(t, [x, y, 0.0, 0.0], model.parameter_vector(values))).ravel()
        return mass * dz[2:]

    return force, values["radial_clearance"]


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(["vakharia2015", "vakharia2015-consistent", "balanced-rotor"]),
       st.integers(3, 12), st.floats(0, 3), st.floats(0, 2 * math.pi), st.floats(0, 1))
def test_generated_contact_is_zero_free_and_restoring(name, n_balls, radius, phi, t):
    force, gamma = _generated_forces(name, n_balls)
    x, y = radius * gamma * math.cos(phi), radius * gamma * math.sin(phi)
    fx, fy = force(t, x, y)
    if radius < 1:
        assert math.hypot(fx, fy) <= 1e-15
    assert fx * x + fy * y <= 1e-15 * abs(gamma)


def test_generated_contact_is_continuous_at_opening():
    force, gamma = _generated_forces("balanced-rotor", 8)
    # ball 0 sits at θ = 0 at t = 0: pushing the rotor along x opens and closes its contact
    forces = [force(0.0, gamma + eps, 0.0)[0] for eps in (1e-8, 1e-10, 1e-12, 0.0, -1e-12)]
    assert forces[0] < forces[1] < forces[2] < 0 and forces[3] == forces[4] == 0.0
    assert abs(forces[2]) <= 7.055e9 * (1e-12) ** 1.5 * 1.0001


# ---------------------------------------------------------------- spec round trip

SAFE_TEXT = st.text(string.ascii_letters + string.digits + " ,.-()'", min_size=1, max_size=40)


def _value(draw, name: str) -> float:
    q = QUANTITIES[name]
    return draw(st.floats(q.low, q.high, exclude_min=not q.low_inclusive))


@st.composite
def spec_data(draw) -> dict:
    """Valid spec data: a shipped spec with new values, texts, and maybe custom terms."""
    name = draw(st.sampled_from(shipped_spec_names()))
    data = tomllib.loads((SPECS / f"{name}.toml").read_text())
    geometry = {"inner_race_diameter", "outer_race_diameter", "pitch_diameter",
                "ball_diameter"}
    state = parse_spec(data).state_names()
    for pname, par in data["parameters"].items():
        if pname not in geometry and "low" not in par:  # declared ones keep their value
            par["value"] = _value(draw, pname.removesuffix("_left").removesuffix("_right"))
        par["source"] = draw(st.text(min_size=1, max_size=30))
    data["model"]["title"] = draw(SAFE_TEXT)
    data["model"]["description"] = draw(st.text(max_size=60))
    duration = draw(st.floats(1e-6, 1e5))
    data["simulation"] = {
        "dt": draw(st.floats(1e-9, 10.0)), "duration": duration,
        "transient": draw(st.floats(0.0, duration, exclude_max=True)),
        "initial": {state[0]: draw(st.floats(-1.0, 1.0)),
                    state[-1]: draw(st.floats(-1e3, 1e3))}}
    if draw(st.booleans()):
        low = draw(st.floats(-1e6, 1e6))
        high = draw(st.floats(low, 1e7, exclude_min=True))
        data["parameters"]["k_user"] = {"value": draw(st.floats(low, high)), "unit": "N/m",
                                        "source": "hypothesis", "low": low, "high": high}
        term = {"kind": "expression", "fx": f"-k_user*{state[0]}",
                "fy": draw(st.sampled_from([f"-k_user*{state[1]}", *(
                    ["sin(omega*t)"] if "speed_rpm" in data["parameters"] else [])])),
                "description": draw(st.text(max_size=20))}
        if "bodies" in data:
            term["body"] = data["bodies"][0]["name"]
        data["terms"].append(term)
    return data


@settings(max_examples=80, deadline=None)
@given(spec_data())
def test_spec_to_toml_to_spec_is_the_identity(data):
    spec = parse_spec(data)
    text = tomli_w.dumps(spec.model_dump(exclude_none=True))
    again = parse_spec(tomllib.loads(text))
    assert again == spec
    assert tomli_w.dumps(again.model_dump(exclude_none=True)) == text


# ---------------------------------------------------------------- the expression parser

DANGEROUS_EVENTS = ("exec", "os.system", "os.exec", "os.posix_spawn", "os.spawn",
                    "subprocess.Popen", "socket.", "builtins.input", "ctypes.")
"""Audit events that would mean the parser ran something (``compile`` is ast.parse)."""
_watch = {"on": False, "seen": []}


def _audit(event: str, args) -> None:
    if not (_watch["on"] and event.startswith(DANGEROUS_EVENTS)):
        return
    code = args[0] if args else None
    if event == "exec" and Path(getattr(code, "co_filename", "")).is_file():
        return  # a module imported lazily (by SymPy): its code comes from its file
    _watch["seen"].append(event)


sys.addaudithook(_audit)

SYMBOLS = {n: sp.Symbol(n, real=True) for n in ("x", "y", "k")}
NUMBERS = (st.integers(0, 100).map(str)
           | st.floats(0.01, 100.0).map(lambda v: f"{v:.6g}"))
LEAVES = st.sampled_from(["x", "y", "k", "pi"]) | NUMBERS


def _grow(children):
    one = st.sampled_from([f for f, (_, n) in FUNCTIONS.items() if n == 1])
    return st.one_of(
        st.tuples(children, st.sampled_from("+-*/"), children).map(
            lambda t: f"({t[0]} {t[1]} {t[2]})"),
        st.tuples(children, st.integers(-3, 3)).map(lambda t: f"({t[0]})**{t[1]}"),
        children.map(lambda c: f"-{c}"),
        st.tuples(one, children).map(lambda t: f"{t[0]}({t[1]})"),
        st.tuples(st.sampled_from(["Max", "Min"]), st.lists(children, min_size=2, max_size=4))
        .map(lambda t: f"{t[0]}({', '.join(t[1])})"),
    )


VALID = st.recursive(LEAVES, _grow, max_leaves=12)
HOSTILE_FORMS = [
    "{}.real", "{}.__class__", "{}[0]", "(lambda: {})()", "[{} for _ in ()]", "open({})",
    "__import__('os').system({})", "{} if x else 0", "'{}'", "getattr({}, 'a')", "{}()",
    "exec({})", "eval('{}')", "{} < 1", "({} := 1)", "*{}", "{}, 1", "__builtins__",
    "print({})", "{} @ x", "not {}",
]
HOSTILE = st.tuples(st.sampled_from(HOSTILE_FORMS), VALID).map(lambda t: t[0].format(t[1]))


def _parse_watched(text: str):
    _watch.update(on=True, seen=[])
    try:
        return parse_expression(text, SYMBOLS)
    except ExpressionError as exc:
        return exc
    finally:
        _watch["on"] = False
        assert _watch["seen"] == [], f"{text!r} made the parser run {_watch['seen']}"


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80) | HOSTILE | VALID)
def test_parser_runs_nothing_and_raises_only_its_error(text):
    result = _parse_watched(text)  # anything but Expr or ExpressionError propagates: fails
    assert isinstance(result, (sp.Expr, ExpressionError))


@settings(max_examples=150, deadline=None)
@given(HOSTILE)
def test_hostile_expressions_are_rejected(text):
    assert isinstance(_parse_watched(text), ExpressionError)


@settings(max_examples=150, deadline=None)
@given(VALID, st.floats(-2, 2), st.floats(-2, 2), st.floats(0.1, 3))
def test_printed_casadi_code_computes_the_parsed_expression(text, xv, yv, kv):
    """Whatever the parser makes, the CasADi printer prints, and the print computes it."""
    expr = _parse_watched(text)
    assume(isinstance(expr, sp.Expr))
    code = CasadiPrinter().doprint(expr)
    sym = {n: ca.SX.sym(n) for n in SYMBOLS}
    value = ca.Function("f", list(sym.values()), [eval(code, {"ca": ca, "math": math, **sym})])
    got = float(value(xv, yv, kv))
    with np.errstate(all="ignore"):
        point = (np.float64(v) for v in (xv, yv, kv))  # NumPy's 1/0 = inf, not an error
        want = float(sp.lambdify(list(SYMBOLS.values()), expr, modules="numpy")(*point))
    assume(math.isfinite(want) and abs(want) < 1e12)
    assert math.isclose(got, want, rel_tol=1e-9, abs_tol=1e-9)


def test_spec_errors_are_the_only_errors_of_bad_expressions_in_specs():
    data = copy.deepcopy(BASE)
    data["terms"].append({"kind": "expression", "fx": "x.__class__"})
    try:
        parse_spec(data)
    except SpecError as exc:
        assert "attribute access" in str(exc)
    else:
        raise AssertionError("accepted")
