"""Lyapunov exponents: exact sum rule, consistency with Floquet, decoupled modes."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.stability.lyapunov import lyapunov
from analysis.stability.periodic import shoot


@pytest.mark.parametrize(("model", "n_balls", "params"), [
    ("vakharia2015", 6, {}),                       # chaotic
    ("balanced-rotor", 8, {"radial_load": 50.0}),  # periodic
])
def test_sum_of_exponents_is_the_mean_divergence(model, n_balls, params):
    res = lyapunov(model, n_balls, duration=0.5, transient=0.2, **params)
    c, m = res.attrs["damping"], res.attrs["rotor_mass"]
    assert res.attrs["sum_of_exponents"] == pytest.approx(-2 * c / m, rel=1e-3)
    assert res.attrs["mean_divergence"] == pytest.approx(-2 * c / m, rel=1e-12)
    assert list(res.exponents.values) == sorted(res.exponents.values, reverse=True)


def test_largest_exponent_of_a_stable_orbit_matches_its_floquet_multiplier():
    orbit = shoot("balanced-rotor", 8, "vc", radial_load=50.0)
    want = np.log(orbit.spectral_radius) / orbit.period_s
    res = lyapunov("balanced-rotor", 8, duration=2.0, transient=0.5, radial_load=50.0)
    lam, ci = float(res.exponents[0]), float(res.ci95[0])
    assert lam < 0
    assert abs(lam - want) < max(2 * ci, 0.2 * abs(want))


def test_ueda_attractor_is_chaotic_with_exact_neutral_modes():
    """Ueda's Duffing attractor: λ1 > 0; the decoupled y motion (y'' + c y' = 0) has the
    exponents 0 and −c/M exactly."""
    res = lyapunov("duffing", dt=0.01, transient=100.0, duration=2000.0, renorm_every=10)
    lam = res.exponents.values
    assert lam[0] - res.ci95.values[0] > 0.03
    assert np.any(np.abs(lam) < 1e-12)
    assert np.any(np.abs(lam + 0.05) < 1e-9)
    assert lam.sum() == pytest.approx(-0.1, rel=1e-6)


def test_running_estimate_reports_convergence():
    res = lyapunov("vakharia2015", 6, duration=0.3, transient=0.1)
    assert res.running.dims == ("t", "index") and res.running.sizes["t"] == 300
    np.testing.assert_allclose(res.running.isel(t=-1), res.exponents)


def test_compiled_tangent_block_equals_the_vm():
    kw = dict(duration=0.2, transient=0.05)
    vm = lyapunov("vakharia2015", 7, compiled=False, **kw)
    c = lyapunov("vakharia2015", 7, compiled=True, **kw)
    np.testing.assert_array_equal(vm.exponents.values, c.exponents.values)
