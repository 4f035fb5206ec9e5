"""Custom expression terms: the whitelist parser, its printing as CasADi code, and a spec
that uses them all the way to the generated right-hand side.

The catalogue of rejected expressions (with their messages) is in tests/cli/test_bad_inputs.py;
random strings and syntax trees are in tests/modelgen/test_properties.py.
"""

from __future__ import annotations

import math
import tomllib

import casadi as ca
import numpy as np
import pytest
import sympy as sp
import tomli_w

from analysis.model import load_model
from modelgen.assemble import assemble
from modelgen.codegen import CasadiPrinter, _preview_module, render
from modelgen.expressions import ExpressionError, check_expression, parse_expression
from modelgen.spec import load_spec, parse_spec
from tests.conftest import SPECS

x, y, k = sp.symbols("x y k", real=True)
SYMBOLS = {"x": x, "y": y, "k": k}


@pytest.mark.parametrize(("text", "want"), [
    ("-k*x**3", -k * x**3),
    ("2*x - y/3 + 1.5", 2 * x - y / 3 + sp.Float(1.5)),
    ("+x - -y", x + y),
    ("sin(x)*cos(y) + exp(-x**2) + sqrt(abs(y))", sp.sin(x) * sp.cos(y) + sp.exp(-x**2)
     + sp.sqrt(sp.Abs(y))),
    ("Max(0, x, y) - Min(x, 1)", sp.Max(0, x, y) - sp.Min(x, 1)),
    ("Heaviside(x - 1)*k", sp.Heaviside(x - 1, 0) * k),
    ("x**(3/2) + x**-0.5", x ** sp.Rational(3, 2) + x ** sp.Float(-0.5)),
    ("2*pi*x", 2 * sp.pi * x),
    ("12345678901234567890*x", sp.Float(float(12345678901234567890)) * x),
])
def test_whitelisted_expressions_parse_to_sympy(text, want):
    assert parse_expression(text, SYMBOLS) == want


def test_names_are_reported_without_functions_and_constants():
    assert check_expression("k*sin(pi*x) + Max(y, 0)") == {"k", "x", "y"}


def test_heaviside_is_zero_at_zero_like_the_casadi_code():
    assert parse_expression("Heaviside(x)", SYMBOLS).subs(x, 0) == 0


@pytest.mark.parametrize(("text", "reason"), [
    ("1/0", "division by zero"), ("x/(1 - 1)", "division by zero"),
    ("sqrt(-1)", "complex value"), ("1e999*x", "floating-point range"),
    ("9**9**9", "exponent out of range"), ("(10**15)**100", "floating-point range"),
    ("x**y**1000", "exponent out of range"), ("kk*x", "unknown name 'kk' (did you mean 'k'?)"),
    ("Max(x)", "Max takes 2 to 16 argument(s), got 1"), ("True*x", "True/False"),
    ("None", "None are not allowed"), ("x < y", "comparisons"), ("x if y else k", "if"),
    ("(x := 1)", "assignments"), ("x and y", "'and'/'or'"), ("{x: y}", "dicts"),
    ("x % 2", "'%'"), ("x // 2", "'//'"), ("~x", "unary"), ("f'{x}'", "strings"),
])
def test_rejected_with_the_reason(text, reason):
    with pytest.raises(ExpressionError) as info:
        parse_expression(text, SYMBOLS)
    assert reason in str(info.value)


@pytest.mark.parametrize("expr", [
    x ** sp.Rational(-1, 2), x ** sp.Rational(-3, 2), sp.exp(1) * x, sp.Abs(x) ** -2,
    sp.Max(x, y, 1), sp.Min(x, y, x * y, -1), sp.Heaviside(x - y, 0) * y, 1 / (x + y) ** 2,
    x ** sp.Float(0.25), sp.Float(2.5) ** x, sp.pi * sp.sqrt(x), sp.sin(x) ** -1,
])
def test_casadi_printer_handles_what_the_parser_makes(expr):
    code = CasadiPrinter().doprint(expr)
    sx, sy = ca.SX.sym("x"), ca.SX.sym("y")
    f = ca.Function("f", [sx, sy], [eval(code, {"ca": ca, "math": math, "x": sx, "y": sy})])
    exact = sp.lambdify([x, y], expr, modules="numpy")
    for xv, yv in ((0.7, 0.3), (2.0, -1.5), (0.1, 0.9)):
        np.testing.assert_allclose(float(f(xv, yv)), float(exact(xv, yv)), rtol=1e-13)


CUSTOM = {
    "parameters": {
        "k3": {"value": 2e15, "unit": "N/m^3", "source": "test", "low": 0.0, "high": 1e20},
        "g": {"value": 9.81, "unit": "m/s^2", "source": "standard gravity", "low": 0.0,
              "high": 100.0},
        "cb": {"value": 50.0, "unit": "N*s/m", "source": "test", "low": 0.0, "high": 1e4},
    },
    "terms": [
        {"kind": "expression", "description": "gravity and a cubic support",
         "fx": "rotor_mass*g - k3*x**3", "fy": "-k3*y**3 + 0.1*sin(omega*t)"},
        {"kind": "expression", "description": "contact damping", "ball": "cb*(vx*c + vy*s)"},
    ],
}


def custom_spec(folder, name: str = "balanced-rotor") -> tuple[dict, object]:
    data = tomllib.loads((SPECS / f"{name}.toml").read_text())
    data["parameters"].update(CUSTOM["parameters"])
    data["terms"].extend(CUSTOM["terms"])
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(data))
    return data, path


def test_custom_terms_generate_the_equations_they_say(tmp_path):
    """Generated CasADi rhs of a spec with custom terms vs a plain lambdify of SymPy."""
    _, path = custom_spec(tmp_path)
    spec, _ = load_spec(path)
    eq = assemble(spec)
    ctx = eq.ctx
    files = render(path).files
    assert "'k3': (0.0, 1e+20, True)" in files["balanced_rotor/__init__.py"]
    assert "| `k3` | $k_{3}$ | 2e+15 | N/m^3 | test |" in files["balanced_rotor/MODEL.md"]
    n_balls = 8
    exact = sp.lambdify([ctx.t, *ctx.state, *ctx.params.values()], eq.first_order(n_balls),
                        modules="numpy")
    with _preview_module("balanced_rotor", files["balanced_rotor/__init__.py"]) as module:
        rhs = module.build(n_balls).rhs
        rng = np.random.default_rng(1)
        values = spec.parameter_values()
        p = np.array(list(values.values()))
        for _ in range(20):
            z = np.concatenate([rng.uniform(-15e-6, 15e-6, 2), rng.uniform(-0.05, 0.05, 2)])
            t = rng.uniform(0, 1)
            got = np.asarray(rhs(t, z, p)).ravel()
            want = np.asarray(exact(t, *z, *p), dtype=float).ravel()
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_custom_ball_load_acts_only_in_contact(tmp_path):
    data, _ = custom_spec(tmp_path)
    data["terms"][-1]["ball"] = "5 + 0*delta"  # pushes 5 N whenever the ball touches
    eq = assemble(parse_spec(data))
    ctx = eq.ctx
    q = sp.lambdify([ctx.c, ctx.s, ctx.x, ctx.y, ctx.vx, ctx.vy, *ctx.params.values()],
                    eq.ball_load)
    p = list(parse_spec(data).parameter_values().values())
    gamma = parse_spec(data).parameter_values()["radial_clearance"]
    assert q(1.0, 0.0, 0.5 * gamma, 0.0, 0.0, 0.0, *p) == 0.0  # not touching: nothing
    assert q(1.0, 0.0, 1.0001 * gamma, 0.0, 0.0, 0.0, *p) == pytest.approx(5.0, rel=1e-3)


def test_round_trip_keeps_user_parameters_and_expressions(tmp_path):
    _, path = custom_spec(tmp_path)
    spec, _ = load_spec(path)
    again = parse_spec(tomllib.loads(tomli_w.dumps(spec.model_dump())))
    assert again == spec
    assert spec.quantity("g").range_text() == "[0, 100] m/s^2"


def test_per_ball_expressions_see_the_ball_angle_index_and_count(tmp_path):
    """A ball term of theta, i and n_balls (a load doubled on ball 1 that depends on the
    ball's angle): what it adds to the generated rhs equals its sum over the balls written
    out by hand, θ_i = 2π(i − 1)/N_b + ω_cage t."""
    base = tomllib.loads((SPECS / "balanced-rotor.toml").read_text())
    data = {**base, "terms": [*base["terms"], {
        "kind": "expression", "description": "ball-dependent load",
        "ball": "kb*delta*(1 + Heaviside(1.5 - i))*cos(theta)**2/n_balls"}],
        "parameters": {**base["parameters"], "kb": {
            "value": 3e7, "unit": "N/m", "source": "test", "low": 0.0, "high": 1e12}}}
    rhs = {}
    for key, spec_data in (("with", data), ("without", base)):
        folder = tmp_path / key
        folder.mkdir()
        path = folder / "balanced-rotor.toml"
        path.write_text(tomli_w.dumps(spec_data))
        files = render(path).files
        with _preview_module("balanced_rotor", files["balanced_rotor/__init__.py"]) as module:
            rhs[key] = module.build(7).rhs
    model = load_model("balanced-rotor")
    values = {**model.defaults, "kb": 3e7}
    p = np.array(list(values.values()))
    n_balls, gamma = 7, values["radial_clearance"]
    cage = float(model.cage_speed("bearing", model.parameter_vector(model.defaults)))
    rng = np.random.default_rng(5)
    for _ in range(10):
        z = np.concatenate([rng.uniform(1.2 * gamma, 2 * gamma, 1),  # balls near θ = 0 in
                            rng.uniform(-0.3 * gamma, 0.3 * gamma, 1),  # contact
                            rng.uniform(-0.05, 0.05, 2)])
        t = rng.uniform(0, 1)
        fx = fy = 0.0
        for i in range(1, n_balls + 1):
            theta = 2 * math.pi * (i - 1) / n_balls + cage * t
            delta = z[0] * math.cos(theta) + z[1] * math.sin(theta) - gamma
            if delta > 0:
                q = values["kb"] * delta * (1 + (i == 1)) * math.cos(theta) ** 2 / n_balls
                fx, fy = fx - q * math.cos(theta), fy - q * math.sin(theta)
        added = (np.asarray(rhs["with"](t, z, p)).ravel()
                 - np.asarray(rhs["without"](t, z, p[:-1])).ravel())
        want = np.array([0, 0, fx, fy]) / values["rotor_mass"]
        np.testing.assert_allclose(added, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
        assert np.abs(want).max() > 0
