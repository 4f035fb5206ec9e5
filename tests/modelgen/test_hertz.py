"""Hertz point contact of a ball and its races (modelgen/hertz.py), against textbook values."""

from __future__ import annotations

import itertools
import math

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from modelgen.hertz import (
    RaceStiffness,
    combined_stiffness,
    curvatures,
    race_contact,
    unrolled_stiffness,
)

STEEL = {"youngs_modulus": 208e9, "poisson_ratio": 0.3}


def contact(race: str, d_b: float, d_m: float, f: float, **kw) -> object:
    return race_contact(d_b, d_m, f, STEEL["youngs_modulus"], STEEL["poisson_ratio"], race,
                        **kw)


def test_worked_example_tiwari_harris():
    """Textbook worked example: R. Tiwari, *Rotor Systems: Analysis and Identification*
    (CRC), as taught in NPTEL course 112103024 "Rotor Dynamics", Module 3, Lecture 1, p. 8
    (archive.nptel.ac.in/content/storage2/courses/112103024/module3/lec1/8.html): a
    deep-groove ball bearing with r_i = r_o = 3.09 mm, D_b = 6 mm, D_m = 20 mm, zero contact
    angle. The page prints the curvature difference F(ρ_i) = 0.96 and the dimensionless
    deflections read from Harris (2000), Fig. 3.12 / Table 3.4: δ*_i = 0.545 and δ*_o = 0.63
    (the page labels the outer value "F(ρ_i) = 0.96" too, a typo: the outer race has
    F(ρ_o) = 0.927). Tolerances: half a unit of the printed last digit for F(ρ_i) and δ*_o,
    two units for δ*_i (a value interpolated in Harris' table).

    Our intermediate values (exact solution): Σρ_i = 485.9 1/m, F(ρ_i) = 0.96004, κ_i = 11.93,
    δ*_i = 0.5464; Σρ_o = 266.1 1/m, F(ρ_o) = 0.92703, κ_o = 8.214, δ*_o = 0.6318.
    """
    inner = contact("inner", 6e-3, 20e-3, 3.09 / 6)
    outer = contact("outer", 6e-3, 20e-3, 3.09 / 6)
    assert inner.curvature_difference == pytest.approx(0.96, abs=0.005)
    assert inner.delta_star == pytest.approx(0.545, abs=0.002)
    assert outer.delta_star == pytest.approx(0.63, abs=0.005)
    # the curvature sums by hand, Harris' definitions: 2·(2/D) + ρ_II1 + ρ_II2 (1/mm)
    gamma = 6 / 20
    assert inner.curvature_sum * 1e-3 == pytest.approx(
        4 / 6 + (2 / 6) * gamma / (1 - gamma) - 1 / 3.09, rel=1e-14)
    assert outer.curvature_sum * 1e-3 == pytest.approx(
        4 / 6 - (2 / 6) * gamma / (1 + gamma) - 1 / 3.09, rel=1e-14)


def test_harris_steel_deflection_constant():
    """Harris & Kotzalas, Rolling Bearing Analysis, ch. "Contact stress and deformation":
    for steel balls and races (E = 2.075e5 N/mm², ν = 0.3) the approach of a point contact is
    δ = 2.79e-4 δ* Q^{2/3} (Σρ)^{1/3} (mm, N, 1/mm) and the semi-axes are
    a, b = 0.0236 a*, b* (Q/Σρ)^{1/3}. Our K gives the same constants (3 printed digits)."""
    modulus, nu = 2.075e11, 0.3
    for race in ("inner", "outer"):
        c = race_contact(12.7e-3, 65e-3, 0.52, modulus, nu, race)
        q = 1000.0  # N
        delta = (q / c.stiffness) ** (2 / 3)  # m
        coefficient = delta * 1e3 / (c.delta_star * q ** (2 / 3)
                                     * (c.curvature_sum * 1e-3) ** (1 / 3))
        assert coefficient == pytest.approx(2.79e-4, abs=0.005e-4)
        # semi-major axis a = a* (3 Q / (E' Σρ))^{1/3} (Hertz) in mm, Harris' 0.0236 a* ...
        e_prime = modulus / (1 - nu**2)
        a_mm = c.a_star * (3 * q / (e_prime * c.curvature_sum)) ** (1 / 3) * 1e3
        assert a_mm / (c.a_star * (q / (c.curvature_sum * 1e-3)) ** (1 / 3)) == pytest.approx(
            0.0236, abs=0.00005)


def test_paper_table1_stiffness():
    """Table 1 of the paper (D_b = 4.762 mm, D_m = 23.5 mm) with conformity 0.52 and steel:
    about 7.2e9 N/m^1.5 (issue 8; docs/paper-slips.md S1)."""
    k_i = contact("inner", 4.762e-3, 23.5e-3, 0.52).stiffness
    k_o = contact("outer", 4.762e-3, 23.5e-3, 0.52).stiffness
    assert k_i == pytest.approx(1.9806e10, rel=1e-4)
    assert k_o == pytest.approx(2.0983e10, rel=1e-4)
    assert combined_stiffness(k_i, k_o) == pytest.approx(7.2055e9, rel=1e-4)


def test_exact_ellipticity_solves_its_equation():
    from scipy.special import ellipe, ellipk

    from modelgen.hertz import difference_of_ellipticity

    for f, gamma, race in itertools.product((0.505, 0.52, 0.6, 1.0), (0.05, 0.2, 0.4),
                                            ("inner", "outer")):
        c = contact(race, gamma, 1.0, f)
        m = 1 - 1 / c.ellipticity**2
        assert c.first_kind == ellipk(m) and c.second_kind == ellipe(m)
        assert difference_of_ellipticity(c.ellipticity, c.first_kind, c.second_kind) == \
            pytest.approx(c.curvature_difference, abs=1e-14)


def test_generated_stiffness_matches_exact_over_the_allowed_range():
    """The unrolled solver (Hamrock–Brewe start, 4 Newton steps, AGM) of the generated code
    against SciPy's exact solution: groove conformity 0.505…1 (its allowed range),
    D_b/D_m 0.02…0.45."""
    worst = 0.0
    for f in np.linspace(0.505, 1.0, 12):
        for gamma in np.linspace(0.02, 0.45, 12):
            for race, sign in (("inner", 1), ("outer", -1)):
                exact = contact(race, gamma * 0.1, 0.1, f).stiffness
                got = unrolled_stiffness(gamma * 0.1, 0.1, f, 208e9, 0.3, sign)
                worst = max(worst, abs(got / exact - 1))
    assert worst < 1e-13


def test_hamrock_brewe_error():
    """Hamrock–Brewe's closed forms (k ≈ α^{2/π}, ℰ ≈ 1 + q/α, ℱ ≈ π/2 + q ln α) against the
    exact K: within 2.1 % at conformity 0.52 (the shipped specs), up to 9 % for the tightest
    allowed groove (0.505, α ≈ 100, where k is off by 6 % and ℱ by 2 %), D_b/D_m 0.1…0.35.
    Hence the generated code refines them with Newton steps."""
    def worst(conformities):
        error = 0.0
        for f, gamma, race in itertools.product(conformities, np.linspace(0.1, 0.35, 6),
                                                ("inner", "outer")):
            exact = contact(race, gamma, 1.0, f)
            approx = contact(race, gamma, 1.0, f, method="hamrock_brewe")
            error = max(error, abs(approx.stiffness / exact.stiffness - 1))
        return error

    assert 0.01 < worst([0.52]) < 0.021
    assert 0.05 < worst(np.linspace(0.505, 0.6, 8)) < 0.091


def test_helper_of_the_generated_code_and_its_derivatives():
    """race_stiffness as the generated module has it: the exact value, finite gradient."""
    namespace = {"ca": ca, "math": math}
    exec(RaceStiffness.helper_source(), namespace)  # our own generated source
    x = ca.SX.sym("x", 5)
    for sign, race in ((1, "inner"), (-1, "outer")):
        k = namespace["race_stiffness"](*ca.vertsplit(x), sign)
        f = ca.Function("f", [x], [k, ca.jacobian(k, x)])
        value, grad = f([4.762e-3, 23.5e-3, 0.52, 208e9, 0.3])
        assert float(value) == pytest.approx(contact(race, 4.762e-3, 23.5e-3, 0.52).stiffness,
                                             rel=1e-14)
        assert np.all(np.isfinite(np.asarray(grad)))
        # K ∝ E/(1 − ν²): ∂K/∂E = K/E
        assert float(grad[3]) == pytest.approx(float(value) / 208e9, rel=1e-12)


def test_race_stiffness_is_compact_in_equations():
    d_b, d_m, f, e, nu = sp.symbols("D_b D_m f E nu", positive=True)
    assert sp.latex(RaceStiffness(d_b, d_m, f, e, nu, 1)).startswith(r"K_i\left(")
    assert sp.latex(RaceStiffness(d_b, d_m, f, e, nu, -1)).startswith(r"K_o\left(")
    value = RaceStiffness(4.762e-3, 23.5e-3, 0.52, 208e9, 0.3, 1).evalf()
    assert float(value) == pytest.approx(1.98055e10, rel=1e-5)


def test_curvature_difference_of_a_conforming_groove():
    """F(ρ) → (ρ_II1 − ρ_II2)/Σρ: positive, below 1, larger for a tighter groove."""
    tight = curvatures(4.762e-3, 23.5e-3, 0.505, 1)[1]
    loose = curvatures(4.762e-3, 23.5e-3, 0.56, 1)[1]
    assert 0 < loose < tight < 1
