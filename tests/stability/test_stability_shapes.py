"""The stability layer on models of other shapes: the 8-state rotor in a housing, the
two-bearing rotor (translation and tilt) and the 1-DOF Mathieu equation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.flow import Period, evaluate, flow_map
from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.signal.poincare import poincare_section
from analysis.stability.classify import _normalised_points, classify, default_section
from analysis.stability.continuation import continue_orbits
from analysis.stability.lyapunov import lyapunov
from analysis.stability.periodic import (
    divergence_integral,
    liouville_error,
    shoot,
    stability_boundary,
)

HOUSING_PERIODIC = dict(radial_load=50.0, unbalance_force=0.0)
"""Balanced rotor in a sprung housing at 50 N: a stable VC-periodic orbit."""


def housing_trace(v: dict) -> float:
    """tr ∂f/∂z of rotor-housing (1/s): bearing damping c on the relative velocity, housing
    damping c_h to ground, in x and y: −2c/m_r − 2(c + c_h)/m_h."""
    return -2 * (v["damping"] / v["rotor_mass"]
                 + (v["damping"] + v["housing_damping"]) / v["housing_mass"])


@pytest.fixture(scope="module")
def housing_orbit():
    return shoot("rotor-housing", None, "vc", **HOUSING_PERIODIC)


def test_rotor_housing_orbit_has_eight_multipliers(housing_orbit):
    orbit = housing_orbit
    assert orbit.converged and orbit.stability == "stable", orbit.message
    assert orbit.monodromy.shape == (8, 8) and orbit.multipliers.shape == (8,)
    assert orbit.state_names[2] == "x_housing" and orbit.n_balls == 8
    # the orbit is a fixed point of the flow map, checked by a separate evaluation
    model, s = orbit.system.model, orbit.structure
    end = evaluate(flow_map(model, s, Period.parse("vc"), orbit.n_steps), orbit.z0,
                   orbit.t0, orbit.system.p)[0]
    scale = np.abs(orbit.z0).reshape(2, 4).max(axis=1).repeat(4)
    assert np.max(np.abs(end - orbit.z0) / scale) < 1e-9


def test_liouville_general_form_rotor_housing(housing_orbit):
    """det M = exp(∫ tr J dt): the integral (Simpson on the RK4 orbit, tr J from the rhs
    Jacobian) meets the closed form, and det of the AD monodromy meets it to the RK4 error,
    which falls at fourth order (measured 1.9e-6, 1.6e-7, 1.1e-8 at 377, 754, 1508 steps)."""
    orbit = housing_orbit
    system = orbit.system
    integral = divergence_integral(system, "vc", orbit.z0, orbit.t0, orbit.n_steps)
    assert integral == pytest.approx(housing_trace(orbit.values) * orbit.period_s, rel=1e-12)
    assert orbit.n_steps == 377
    assert liouville_error(orbit) < 3e-6

    def error(n_steps: int) -> float:
        mono = evaluate(flow_map(system.model, orbit.structure, Period.parse("vc"), n_steps),
                        orbit.z0, orbit.t0, system.p)[1]
        exact = divergence_integral(system, "vc", orbit.z0, orbit.t0, n_steps)
        return abs(np.linalg.det(mono) / math.exp(exact) - 1)

    e1, e2 = error(754), error(1508)
    assert e1 < 2e-7 and e1 / e2 > 12  # 16 for exact fourth order


def test_rotor_housing_exponents_sum_to_the_mean_divergence():
    """Chaotic with the default unbalance (λ1 > 0); the 8 exponents sum to the trace
    (measured relative error 1.1e-7)."""
    res = lyapunov("rotor-housing", duration=0.5, transient=0.2)
    assert res.sizes["index"] == 8 and res.attrs["n_exponents"] == 8
    want = housing_trace(res.attrs)
    assert res.attrs["mean_divergence"] == pytest.approx(want, rel=1e-12)
    assert res.attrs["sum_of_exponents"] == pytest.approx(want, rel=1e-6)
    assert res.attrs["state_names"].split()[4] == "vx_rotor"
    assert res.attrs["spec_file"].endswith("rotor-housing.toml")
    assert float(res.exponents[0] - res.ci95[0]) > 0


def test_n_exponents_is_checked_against_the_state_size():
    with pytest.raises(InputError, match=r"n_exponents: must be a whole number in \[1, 2\]"):
        lyapunov("mathieu", duration=10.0, transient=0.0, n_exponents=3)
    one = lyapunov("mathieu", duration=10.0, transient=0.0, n_exponents=1)
    assert one.sizes["index"] == 1


# ---- Mathieu: ε = stiffness_amplitude, δ = stiffness_mean, T = forcing_period = 2π -------

EPS = 0.1
MATHIEU = dict(oscillator_mass=1.0, forcing_period=2 * math.pi, damping=0.0,
               stiffness_amplitude=EPS)
DT = 2 * math.pi / 2000


def tongue_series(sign: int) -> float:
    """First tongue of x'' + (δ + ε cos t) x = 0: δ = 1/4 ± ε/2 − ε²/8 ∓ ε³/32 + O(ε⁴)."""
    return 0.25 + sign * EPS / 2 - EPS**2 / 8 - sign * EPS**3 / 32


@pytest.mark.parametrize("test", ["PD", "radius"])
def test_mathieu_first_tongue_matches_the_series(test):
    """Measured: lower 0.1987809670 (series 0.19878125, −2.8e-7), upper 0.2987185148
    (series 0.29871875, −2.4e-7): within the O(ε⁴) ≈ 1e-4·c of the series' next term."""
    system = System.make("mathieu", **MATHIEU)
    lower = stability_boundary(system, "stiffness_mean", 0.15, 0.25, test=test, dt=DT)
    upper = stability_boundary(system, "stiffness_mean", 0.25, 0.35, test=test, dt=DT)
    assert lower.orbit.period == "param:forcing_period" and lower.orbit.n_steps == 2000
    assert abs(lower.value - tongue_series(-1)) < 1e-6
    assert abs(upper.value - tongue_series(+1)) < 1e-6
    for b in (lower, upper):  # a double multiplier at −1 on the boundary
        np.testing.assert_allclose(b.multipliers, [-1, -1], atol=1e-5)
        assert b.bracket[1] - b.bracket[0] < 1e-10


def test_mathieu_floquet_liouville_and_lyapunov():
    """Undamped: det M = 1; inside the tongue μ1 μ2 = 1 with μ real < −1 and the largest
    Lyapunov exponent is log|μ1|/T; damped: det M = exp(−cT/m)."""
    inside = shoot("mathieu", dt=DT, stiffness_mean=0.25, **MATHIEU)
    assert inside.converged and inside.stability == "unstable"
    assert inside.monodromy.shape == (2, 2)
    mu = np.sort(inside.multipliers.real)
    assert mu[0] < -1 < mu[1] < 0 and np.all(inside.multipliers.imag == 0)
    assert np.linalg.det(inside.monodromy) == pytest.approx(1.0, abs=1e-10)
    outside = shoot("mathieu", dt=DT, stiffness_mean=0.4, **MATHIEU)
    assert outside.stability == "marginal"
    assert np.abs(outside.multipliers) == pytest.approx([1, 1], abs=1e-9)
    damped = shoot("mathieu", dt=DT, **{**MATHIEU, "damping": 0.05})
    assert np.linalg.det(damped.monodromy) == pytest.approx(math.exp(-0.05 * 2 * math.pi),
                                                            rel=1e-10)
    assert liouville_error(damped) < 1e-10
    res = lyapunov("mathieu", duration=2000.0, transient=0.0, stiffness_mean=0.25,
                   **MATHIEU)
    want = math.log(inside.spectral_radius) / inside.period_s
    assert abs(float(res.exponents[0]) - want) < max(2 * float(res.ci95[0]), 0.02 * want)
    assert res.attrs["sum_of_exponents"] == pytest.approx(0.0, abs=1e-10)


def test_mathieu_continuation_crosses_the_tongue():
    """Continuation in δ through the first tongue: PD points at both boundaries (measured
    −9.8e-7 from the series at each), and no NS label where the undamped multipliers sit
    on the unit circle."""
    br = continue_orbits("mathieu", param="stiffness_mean", start=0.15, stop=0.35,
                         dt=DT, ds_max=0.02, **MATHIEU)
    assert list(br.state.values) == ["x", "vx"] and br.sizes["k"] == 2
    pd = np.sort(br.stiffness_mean.values[br.special.values == "PD"])
    assert len(pd) == 2 and set(br.special.values) == {"", "PD"}  # no NS on the circle
    assert pd[0] == pytest.approx(tongue_series(-1), abs=1e-4)
    assert pd[1] == pytest.approx(tongue_series(+1), abs=1e-4)


def test_default_periods_by_model_shape():
    assert shoot("mathieu", dt=DT, **MATHIEU).period == "param:forcing_period"
    with pytest.raises(InputError, match=r"period: model 'two-bearing-rotor' has bearings "
                                         r"left, right"):
        shoot("two-bearing-rotor", unbalance_force=0.0)
    with pytest.raises(InputError, match="no bearings, so no VC"):
        shoot("mathieu", None, "vc")


def test_two_bearing_orbit_on_the_common_vc_period():
    """8 and 10 balls on one cage speed: 4 left VC periods = 5 right VC periods, the period
    of the balanced rotor's forcing. tr J = −4c/m − 2c(s_l² + s_r²)/I (c per bearing)."""
    orbit = shoot("two-bearing-rotor", None, "vc[left]:4", unbalance_force=0.0)
    assert orbit.converged, orbit.message
    system = orbit.system
    right = float(Period.parse("vc[right]:5").seconds(system.model, system.structure,
                                                      system.p))
    assert orbit.period_s == pytest.approx(right, rel=1e-14)
    assert orbit.multipliers.shape == (8,) and orbit.n_balls == {"left": 8, "right": 10}
    v = orbit.values
    trace = -4 * v["damping"] / v["rotor_mass"] - 2 * v["damping"] * (
        v["station_left"] ** 2 + v["station_right"] ** 2) / v["rotor_inertia"]
    assert divergence_integral(system, orbit.period, orbit.z0, orbit.t0, orbit.n_steps) == \
        pytest.approx(trace * orbit.period_s, rel=1e-12)
    assert liouville_error(orbit) < 2e-5


def test_classify_sections_every_state():
    ds = simulate("rotor-housing", duration=1.2, transient=1.0, **HOUSING_PERIODIC)
    c = classify(ds)
    assert c.section == "vc" and c.nature == "periodic-1"
    pts = poincare_section(ds, "vc")
    assert list(pts.data_vars) == list(ds.data_vars) and pts.sizes["k"] == c.n_points
    points, size = _normalised_points(pts, {name: float(np.ptp(ds[name].values))
                                            for name in ds.data_vars})
    assert points.shape == (c.n_points, 8) and size == pytest.approx(
        max(np.ptp(ds[v].values) for v in ("x_rotor", "y_rotor", "x_housing", "y_housing")))


def test_classify_mathieu_on_the_forcing_period():
    """Undamped outside the tongue: the section points of (x, vx) lie on a closed curve
    (the Floquet rotation number is irrational): quasi-periodic, largest exponent ≈ 0."""
    period = 2 * math.pi
    ds = simulate("mathieu", duration=200 * period, transient=0.0, dt=period / 200,
                  stiffness_mean=0.4, **MATHIEU)
    assert default_section(ds) == "param:forcing_period"
    pts = poincare_section(ds, "param:forcing_period")
    # section times fall on samples: the points are the samples at t = kT
    np.testing.assert_array_equal(pts.x.values, ds.x.values[::200])
    np.testing.assert_array_equal(pts.vx.values, ds.vx.values[::200])
    c = classify(ds)
    assert c.nature == "quasi-periodic" and abs(c.largest_exponent) < 2e-3
