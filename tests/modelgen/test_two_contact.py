"""Two-contact balls (modelgen/terms/two_contact.py): inner and outer race in series with the
centrifugal force in the ball's radial equilibrium."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from analysis import load_model
from modelgen.hertz import combined_stiffness, race_contact
from modelgen.spec import SpecError, parse_spec
from modelgen.terms.two_contact import race_loads
from tests.model_variants import spec_data, variant

K_I, K_O = 1.98055e10, 2.09834e10  # Table 1 geometry, conformity 0.52, steel (N/m^1.5)


def inner_load(delta: float, f_c: float) -> float:
    """Q_i as the generated code computes it (same algorithm, NumPy)."""
    return float(race_loads(delta, K_I, K_O, f_c)["inner_load"])


def exact_inner_load(delta: float, f_c: float) -> float:
    """Q_i by bracketing the root of δ_i + ((K_i δ_i^1.5 + F_c)/K_o)^(2/3) = δ."""
    opening = (f_c / K_O) ** (2 / 3)
    if delta <= opening:
        return 0.0
    u = brentq(lambda u: u + ((K_I * u**1.5 + f_c) / K_O) ** (2 / 3) - delta, 0.0, delta,
               xtol=1e-300, rtol=1e-15, maxiter=500)
    return K_I * u**1.5


@pytest.fixture(scope="module")
def one_contact(tmp_path_factory):
    """The same model with one combined Hertz contact (stiffness from the same geometry)."""
    terms = [{"kind": "hertz_contact", "cage": "race_diameters", "stiffness": "geometry"},
             *spec_data("vakharia2015-two-contact")["terms"][1:]]
    return variant(tmp_path_factory.mktemp("one"), "vakharia2015-two-contact",
                   "one-contact-geometry", terms=terms)[0]


def test_newton_steps_reach_the_root():
    """4 Newton steps vs Brent's method: |error| below 1e-15 of K_i δ^1.5 for F_c from 1e-6 to
    1e3 N and δ from just above the opening approach to 1000 times it."""
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(3000):
        f_c = 10 ** rng.uniform(-6, 3)
        delta = (f_c / K_O) ** (2 / 3) * (1 + 10 ** rng.uniform(-8, 3))
        error = abs(inner_load(delta, f_c) - exact_inner_load(delta, f_c))
        worst = max(worst, error / (K_I * delta**1.5))
    assert worst < 1e-15


def test_outer_load_is_inner_load_plus_centrifugal_force():
    """Q_o − Q_i = F_c with δ_i + δ_o = δ, to 1e-12, in contact with both races."""
    rng = np.random.default_rng(1)
    for _ in range(500):
        f_c = 10 ** rng.uniform(-4, 2)
        delta = (f_c / K_O) ** (2 / 3) * (1 + 10 ** rng.uniform(-3, 2))
        loads = race_loads(delta, K_I, K_O, f_c)
        q_o = K_O * (delta - loads["inner_deflection"]) ** 1.5
        assert q_o - loads["inner_load"] == pytest.approx(f_c, rel=1e-12, abs=1e-12 * q_o)
        assert loads["inner_deflection"] + loads["outer_deflection"] == pytest.approx(delta,
                                                                                      rel=1e-12)


def test_inner_contact_opens_below_the_opening_approach():
    """Q_i = 0 exactly for δ <= (F_c/K_o)^(2/3) (the ball rides on the outer race), > 0 above."""
    f_c = 2.0
    opening = (f_c / K_O) ** (2 / 3)
    for delta in (-1e-5, 0.0, 0.5 * opening, opening):
        assert inner_load(delta, f_c) == 0.0
    assert inner_load(opening * (1 + 1e-6), f_c) > 0.0


def test_reduces_to_one_contact_without_centrifugal_force():
    """F_c = 0: Q_i = K δ^1.5 with K = [K_i^(−2/3) + K_o^(−2/3)]^(−3/2),
    δ_i = δ/(1 + (K_i/K_o)^(2/3))."""
    k = combined_stiffness(K_I, K_O)
    for delta in np.geomspace(1e-9, 1e-4, 30):
        assert inner_load(delta, 0.0) == pytest.approx(k * delta**1.5,
                                                                      rel=1e-14)
    assert inner_load(-1e-6, 0.0) == 0.0


@pytest.mark.parametrize("n_balls", [6, 9])
def test_generated_rhs_reduces_to_one_contact_model(one_contact, n_balls):
    """Generated rhs of vakharia2015-two-contact vs the one-contact model with the geometric
    K at random states and parameters, F_c = 0 (speed 0, or a vanishing ball density at
    random speeds): equal to 1e-10 relative."""
    two = load_model("vakharia2015-two-contact")
    rhs_two, rhs_one = two.functions(n_balls).rhs, one_contact.functions(n_balls).rhs
    rng = np.random.default_rng(n_balls)
    worst = 0.0
    for i in range(40):
        values = {k: v * rng.uniform(0.9, 1.1) for k, v in two.defaults.items()}
        values["speed_rpm"] = 0.0 if i % 2 else rng.uniform(0, 30000)
        values["ball_density"] = 7850.0 if i % 2 else 1e-30
        z = np.concatenate([rng.uniform(-25e-6, 25e-6, 2), rng.uniform(-0.05, 0.05, 2)])
        t = rng.uniform(0, 1)
        got = np.asarray(rhs_two(t, z, two.parameter_vector(values))).ravel()
        want = np.asarray(rhs_one(t, z, one_contact.parameter_vector(values))).ravel()
        scale = np.abs(want[2:]).max()
        worst = max(worst, np.abs(got[2:] - want[2:]).max() / scale)
        np.testing.assert_array_equal(got[:2], want[:2])
    assert worst < 1e-10


def test_centrifugal_effect_grows_as_speed_squared():
    """The centrifugal force F_c = ½ m_b D_m ω_cage² (∝ speed²) is the outer load minus the
    inner load at every speed; the relief of the inner load at a fixed approach is
    r/(1 + r)·F_c to first order, r = (K_i/K_o)^(2/3) (differentiate δ = δ_i + δ_o at
    fixed δ): so it grows as speed², ratio 4 for a doubled speed, with a deviation that is
    itself second order (quartered when the speed is halved)."""
    model = load_model("vakharia2015-two-contact")
    base = model.defaults
    k_i, k_o = (race_contact(base["ball_diameter"], base["pitch_diameter"],
                             base[f"groove_conformity_{r}"], base["youngs_modulus"],
                             base["poisson_ratio"], r).stiffness for r in ("inner", "outer"))
    r = (k_i / k_o) ** (2 / 3)
    x = 14e-6  # ball 0 at θ = 0 compressed by 4 µm

    def inner(speed: float) -> float:
        p = model.parameter_vector({**base, "speed_rpm": speed})
        return float(model.module.ball_load_bearing(1.0, 0.0, 1, 6, [x, 0.0, 0.0, 0.0], 0.0, p))

    def centrifugal(speed: float) -> float:
        cage = speed * np.pi / 30 * base["inner_race_diameter"] / (
            base["inner_race_diameter"] + base["outer_race_diameter"])
        return (0.5 * base["ball_density"] * np.pi * base["ball_diameter"] ** 3 / 6
                * base["pitch_diameter"] * cage**2)

    for speed in (5000.0, 30000.0):  # Q_o − Q_i = F_c, Q_o from the outer deflection
        q_i, delta = inner(speed), x - base["radial_clearance"]
        q_o = k_o * (delta - (q_i / k_i) ** (2 / 3)) ** 1.5
        assert q_o - q_i == pytest.approx(centrifugal(speed), rel=1e-9)
    relief = {n: inner(0.0) - inner(n) for n in (250.0, 500.0, 1000.0, 2000.0)}
    for n in (250.0, 500.0):
        assert relief[n] / centrifugal(n) == pytest.approx(r / (1 + r), rel=2e-5)
    deviation = [relief[2 * n] / relief[n] - 4 for n in (250.0, 500.0, 1000.0)]
    assert all(-2e-4 < d < 0 for d in deviation)
    assert deviation[1] / deviation[0] == pytest.approx(4, rel=0.01)
    assert deviation[2] / deviation[1] == pytest.approx(4, rel=0.01)


def test_jacobian_is_finite_at_the_switch():
    """Ball 0 exactly at the opening approach δ = (F_c/K_o)^(2/3), and (speed 0) at δ = 0:
    the Jacobian and its derivative are finite."""
    model = load_model("vakharia2015-two-contact")
    funcs = model.functions(8)
    base = model.defaults
    for speed in (20000.0, 0.0):
        values = {**base, "speed_rpm": speed}
        p = model.parameter_vector(values)
        # F_c and K_o as the model has them: Q_i + F_c = K_o δ_o^1.5 at δ_i = 0
        k_o = race_contact(base["ball_diameter"], base["pitch_diameter"],
                           base["groove_conformity_outer"], base["youngs_modulus"],
                           base["poisson_ratio"], "outer").stiffness
        cage = float(model.cage_speed("bearing", p))
        f_c = (0.5 * base["ball_density"] * np.pi * base["ball_diameter"] ** 3 / 6
               * base["pitch_diameter"] * cage**2)
        x = base["radial_clearance"] + (f_c / k_o) ** (2 / 3)
        z = np.array([x, 0.0, 0.0, 0.0])
        jac = np.asarray(funcs.jac(0.0, z, p))
        assert np.all(np.isfinite(jac))
        zs = ca.SX.sym("z", 4)
        hess = ca.Function("h", [zs], [ca.jacobian(funcs.jac(0.0, zs, p)[2, 0], zs)])
        assert np.all(np.isfinite(np.asarray(hess(z))))


def test_spec_rejects_a_second_contact_or_a_centrifugal_term():
    data = spec_data("vakharia2015-two-contact")
    with_centrifugal = {**data, "terms": [*data["terms"], {"kind": "centrifugal",
                                                           "variant": "loaded_zone"}]}
    with pytest.raises(SpecError, match="already holds the centrifugal force"):
        parse_spec(with_centrifugal)
    two_contacts = {**data, "terms": [*data["terms"], {"kind": "hertz_contact"}]}
    with pytest.raises(SpecError, match="both model the ball contacts"):
        parse_spec({**two_contacts, "parameters": {
            **data["parameters"],
            "contact_stiffness": {"value": 7e9, "unit": "N/m^1.5", "source": "test"}}})
