"""Integration: RK4 against CVODES, the settled state against the static Hertz balance."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import fsolve

from analysis.errors import InputError
from analysis.integrate.simulate import simulate
from analysis.model import load_model


def _rel_max(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_rk4_agrees_with_cvodes():
    """0.2 s from the paper's initial state, in a non-chaotic setting.

    At the paper's light load the motion is sensitive to initial conditions (rattling in
    the clearance): there no two integrators agree past a few ms, which is physics, not
    error. Here (damping 2000 N·s/m) the rotor settles, and fixed-step RK4 (Δt = 1e-5 s)
    must match CVODES at rtol 1e-10 to better than 1e-6 relative over the whole run.
    """
    kw = dict(n_balls=8, duration=0.2, transient=0.0, damping=2000.0)
    rk4 = simulate("vakharia2015", **kw)
    ref = simulate("vakharia2015", method="cvodes", rtol=1e-10, **kw)
    assert rk4.sizes["t"] == ref.sizes["t"] == 20001
    for var in ("x", "y"):
        assert _rel_max(rk4[var].values, ref[var].values) < 1e-6


def test_rk4_and_cvodes_agree_before_the_predictability_horizon():
    """The paper's own case (N_b = 6): both methods coincide over the first millisecond."""
    kw = dict(n_balls=6, duration=0.001, transient=0.0)
    rk4 = simulate("vakharia2015", **kw)
    ref = simulate("vakharia2015", method="cvodes", rtol=1e-12, atol=1e-18, **kw)
    assert _rel_max(rk4.x.values, ref.x.values) < 1e-9


def _static_balance(n_balls: int, load: float, k: float, gamma: float) -> np.ndarray:
    """Root of Σ_i k·max(0, x cos φ_i + y sin φ_i − γ)^1.5 (cos φ_i, sin φ_i) = (P_r, 0)."""
    phi = 2 * np.pi * np.arange(n_balls) / n_balls

    def residual(q):
        delta = np.maximum(0.0, q[0] * np.cos(phi) + q[1] * np.sin(phi) - gamma)
        f = k * delta**1.5
        return [f @ np.cos(phi) - load, f @ np.sin(phi)]

    return fsolve(residual, [gamma + (load / k) ** (2 / 3), 0.0], xtol=1e-12)


@pytest.mark.parametrize(("n_balls", "load"), [(6, 6.0), (8, 500.0), (9, 2000.0)])
def test_settled_state_is_the_static_hertz_balance(n_balls, load):
    model = load_model("balanced-rotor")
    k, gamma = model.defaults["contact_stiffness"], model.defaults["radial_clearance"]
    want = _static_balance(n_balls, load, k, gamma)
    ds = simulate(model, n_balls, duration=0.4, transient=0.3, speed_rpm=0.0,
                  radial_load=load, initial_state=(want[0] * 0.9, 0.0, 0.0, 0.0))
    assert float(ds.x[-1]) == pytest.approx(want[0], rel=1e-3)
    assert abs(float(ds.y[-1])) < 1e-3 * want[0]
    assert float(np.ptp(ds.x.values)) < 1e-6 * want[0]  # settled


def test_result_carries_provenance():
    ds = simulate("vakharia2015-consistent", 7, duration=0.02, transient=0.01, damping=150.0)
    model = load_model("vakharia2015-consistent")
    assert ds.attrs["model"] == "vakharia2015-consistent"
    assert ds.attrs["spec_sha256"] == model.spec_sha256
    assert ds.attrs["n_balls"] == 7 and ds.attrs["damping"] == 150.0
    assert set(model.parameter_names) <= set(ds.attrs)
    assert ds.attrs["vc_hz"] == pytest.approx(7 * ds.attrs["cage_hz"])
    assert float(ds.t[0]) == pytest.approx(0.01) and ds.t.attrs["units"] == "s"
    assert ds.x.attrs["units"] == "m" and ds.vx.attrs["units"] == "m/s"


def test_save_every_keeps_every_nth_step():
    full = simulate("balanced-rotor", 8, duration=0.01, transient=0.0)
    thin = simulate("balanced-rotor", 8, duration=0.01, transient=0.0, save_every=10)
    np.testing.assert_array_equal(thin.x.values, full.x.values[::10])


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"dt": 0.0}, "dt"), ({"dt": -1e-5}, "dt"), ({"duration": 0.1, "transient": 0.2},
                                                  "transient"),
    ({"n_balls": 2}, "n_balls"), ({"rotor_mass": -1.0}, "rotor_mass"),
    ({"dampin": 1.0}, "dampin"), ({"method": "euler"}, "method"),
])
def test_bad_arguments_name_the_field(kwargs, field):
    kwargs = {"duration": 0.01, "transient": 0.0, **kwargs}
    with pytest.raises(InputError, match=field):
        simulate("vakharia2015", **kwargs)


def test_rk4_converges_through_contact_switching():
    """Halving Δt shrinks the RK4 error at least 4× (order >= 2) through contact closings.

    The Hertz force max(0, δ)^1.5 has a discontinuous second derivative where a ball meets
    the race, so RK4 does not reach its smooth-case order 4 there (observed ~2.2-2.7).
    """
    kw = dict(n_balls=8, duration=0.05, transient=0.0, damping=1000.0)
    ref = simulate("vakharia2015", method="cvodes", rtol=1e-13, atol=1e-19, **kw)
    errors = []
    for dt, every in ((2e-5, 1), (1e-5, 1), (5e-6, 2)):
        run = simulate("vakharia2015", dt=dt, save_every=every, **kw)
        want = ref.x.values[:: 2 if dt == 2e-5 else 1]
        errors.append(_rel_max(run.x.values, want))
    assert errors[0] / errors[1] > 4 and errors[1] / errors[2] > 4
