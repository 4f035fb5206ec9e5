"""Symbolic assembly: the paper's centrifugal sum cancels exactly; Eq. 8's stray k is gone."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from modelgen.assemble import assemble, latex_equations
from modelgen.spec import load_spec


@pytest.mark.parametrize("n_balls", range(3, 13))
def test_paper_centrifugal_sum_is_exactly_zero(n_balls):
    eq = assemble(load_spec("vakharia2015")[0])
    fx, fy = eq.centrifugal_resultant(n_balls)
    assert fx == 0 and fy == 0


@pytest.mark.parametrize("n_balls", [3, 6, 7, 10])
def test_consistent_centrifugal_does_not_cancel(n_balls):
    eq = assemble(load_spec("vakharia2015-consistent")[0])
    fx, _ = eq.centrifugal_resultant(n_balls)
    values = {eq.ctx.p(n): v for n, v in load_spec("vakharia2015-consistent")[0]
              .parameter_values().items()}
    values.update({eq.ctx.x: 11e-6, eq.ctx.y: 0.0, eq.ctx.t: 0.0})
    # the loaded ball(s) lose F_c = ½ m_b D_m ω_cage² of their load: about 0.23 N at 5000 rpm
    change = float(fx.subs(values))
    assert change == pytest.approx(-0.227, rel=0.02)


def test_y_equation_has_no_stray_k():
    """Eq. 8 multiplies by a second k; the assembled y force is the x force rotated by 90°."""
    spec = load_spec("balanced-rotor")[0]
    eq = assemble(spec)
    ctx = eq.ctx
    q = eq.ball_load
    rotated = q.subs({ctx.c: ctx.s, ctx.s: -ctx.c, ctx.x: ctx.y, ctx.y: -ctx.x},
                     simultaneous=True)
    assert sp.simplify(rotated - q) == 0
    assert sp.degree(q.subs(ctx.p("contact_stiffness"), sp.Symbol("K")), sp.Symbol("K")) == 1


def test_latex_lists_the_equations():
    lines = latex_equations(load_spec("vakharia2015-consistent")[0])
    assert lines[0].startswith(r"M_R \ddot{x}") and r"\sum_{i=1}^{N_b}" in lines[0]
    assert r"\max" in lines[2] and r"\rho_b" in lines[2]


def test_static_ball_load_matches_hertz():
    eq = assemble(load_spec("vakharia2015")[0])
    f = sp.lambdify([eq.ctx.c, eq.ctx.s, eq.ctx.x, eq.ctx.y, *eq.ctx.params.values()],
                    eq.ball_load.subs(eq.ctx.p("pitch_diameter"), 0))
    values = load_spec("vakharia2015")[0].parameter_values()
    values["pitch_diameter"] = 0.0
    args = list(values.values())
    assert f(1.0, 0.0, 12e-6, 0.0, *args) == pytest.approx(7.055e9 * (2e-6) ** 1.5)
    assert f(np.cos(1.0), np.sin(1.0), 12e-6, 0.0, *args) == 0.0


def test_harris_force_matches_harris_empirical_formula():
    """½ m_b D_m ω_cage² (our term) vs Harris' steel formula 2.26e-11·D³·d_m·n_m² (mm, rpm)."""
    from modelgen.terms.centrifugal import harris_force

    spec = load_spec("vakharia2015-consistent")[0]
    eq = assemble(spec)
    p = spec.parameter_values()
    ours = float(harris_force(eq.ctx).subs({eq.ctx.p(n): v for n, v in p.items()}))
    cage_rpm = p["speed_rpm"] * p["inner_race_diameter"] / (
        p["inner_race_diameter"] + p["outer_race_diameter"])
    empirical = 2.26e-11 * (p["ball_diameter"] * 1e3) ** 3 * p["pitch_diameter"] * 1e3 \
        * cage_rpm**2
    assert ours == pytest.approx(empirical, rel=5e-3)
