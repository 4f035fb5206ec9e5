"""Shooting and Floquet multipliers against exact identities and a second method."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.flow import Period, evaluate, flow_map
from analysis.integrate.simulate import simulate
from analysis.model import load_model
from analysis.provenance import state_at
from analysis.stability.periodic import commensurate, shoot
from tests.html_rows import table_rows

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)


@pytest.fixture(scope="module")
def rotor_orbit():
    """The balanced rotor at 50 N radial load: a stable VC-periodic orbit."""
    return shoot("balanced-rotor", 8, "vc", radial_load=50.0)


def _liouville_error(model, period, orbit, n_steps) -> float:
    values = orbit.values
    p = model.parameter_vector(values)
    _, mono, _ = evaluate(flow_map(model, orbit.structure, Period.parse(period), n_steps),
                          orbit.z0, orbit.t0, p)
    exact = np.exp(-2 * values["damping"] * orbit.period_s / values["rotor_mass"])
    return abs(np.linalg.det(mono) / exact - 1)


@pytest.mark.parametrize("load", [6.0, 50.0])
def test_liouville_balanced_rotor(load):
    """det(monodromy) = exp(−2cT/M) for the flow; the RK4 map at Δt = 1e-5 s to 1e-6,
    and the error falls at (nearly) fourth order as Δt halves."""
    model = load_model("balanced-rotor")
    orbit = shoot(model, 8, "vc", radial_load=load)  # any state works; an orbit is natural
    assert orbit.n_steps == 377  # T/Δt with Δt <= 1e-5 s
    assert _liouville_error(model, "vc", orbit, 377) < 1e-6
    e1, e2 = (_liouville_error(model, "vc", orbit, n) for n in (754, 1508))
    assert e1 / e2 > 12  # 16 for exact fourth order


def test_liouville_duffing():
    model = load_model("duffing")
    orbit = shoot(model, None, "shaft", dt=0.01, settle=200.0, **DUFFING)
    assert orbit.converged and orbit.stability == "stable"
    errors = [_liouville_error(model, "shaft", orbit, n) for n in (200, 400, 800)]
    assert errors[0] < 1e-6
    assert errors[0] / errors[1] > 12 and errors[1] / errors[2] > 12


def test_shooting_reproduces_the_simulated_orbit(rotor_orbit):
    orbit = rotor_orbit
    assert orbit.converged and orbit.residual < 1e-10 and orbit.stability == "stable"
    # the stable orbit attracts a long simulation: compare at a whole number of periods
    n_periods = 400
    ds = simulate("balanced-rotor", 8, duration=n_periods * orbit.period_s, transient=0.0,
                  dt=orbit.period_s / orbit.n_steps, save_every=orbit.n_steps,
                  radial_load=50.0)
    end = state_at(ds, -1)
    scale = np.array([1, 1, 0, 0]) * np.abs(orbit.z0[:2]).max() + np.array(
        [0, 0, 1, 1]) * np.abs(orbit.z0[2:]).max()
    assert np.max(np.abs(end - orbit.z0) / scale) < 1e-6


def test_multipliers_match_finite_differences(rotor_orbit):
    """AD monodromy vs central differences of the same RK4 flow map."""
    orbit = rotor_orbit
    model = load_model("balanced-rotor")
    flow = flow_map(model, (8,), Period.parse("vc"), orbit.n_steps)
    p = model.parameter_vector(orbit.values)
    fd = np.zeros((4, 4))
    for j in range(4):
        h = 1e-6 * max(abs(orbit.z0[j]), np.abs(orbit.z0[2 * (j // 2):2 * (j // 2) + 2]).max())
        e = np.zeros(4)
        e[j] = h
        fd[:, j] = (evaluate(flow, orbit.z0 + e, 0.0, p)[0]
                    - evaluate(flow, orbit.z0 - e, 0.0, p)[0]) / (2 * h)
    want = np.sort_complex(np.linalg.eigvals(fd))
    got = np.sort_complex(orbit.multipliers)
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_multiple_shooting_equals_single_shooting(rotor_orbit):
    dt = rotor_orbit.period_s / 380  # 380 steps: divisible by 4 segments
    single = shoot("balanced-rotor", 8, "vc", dt=dt, radial_load=50.0)
    multi = shoot("balanced-rotor", 8, "vc", dt=dt, segments=4, radial_load=50.0)
    assert multi.converged and multi.n_steps == single.n_steps == 380
    np.testing.assert_allclose(multi.z0, single.z0, rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(np.sort_complex(multi.multipliers),
                               np.sort_complex(single.multipliers), atol=1e-8)


def test_ratio_period_makes_the_forcing_commensurate():
    model = load_model("vakharia2015")
    values = commensurate(model, 8, model.defaults, Period.parse("ratio:16/5").ratio)
    f = model.frequencies(8, values)
    assert f.vc_hz / f.shaft_hz == pytest.approx(16 / 5, rel=1e-13)
    assert values["outer_race_diameter"] == pytest.approx(28.262e-3, rel=1e-2)  # < 1 % nudge
    orbit = shoot(model, 8, "ratio:16/5", radial_load=50.0, settle=0.3)
    assert orbit.converged, orbit.message
    assert orbit.period_s == pytest.approx(5 / f.shaft_hz)


def test_bad_period_and_segments():
    with pytest.raises(InputError, match="period"):
        shoot("balanced-rotor", 8, "weekly")
    with pytest.raises(InputError, match="segments"):
        shoot("balanced-rotor", 8, "vc", segments=0)


def test_the_orbit_in_a_notebook_shows_its_multipliers(rotor_orbit):
    """``PeriodicOrbit._repr_html_``: the multipliers read back from the table multiply to
    Liouville's exp(−2cT/M) (to the table's six digits), their moduli give the verdict
    shown, and the state rows are the orbit's z0 with the model's units."""
    rows = table_rows(rotor_orbit._repr_html_())
    facts = {row[0]: row[1] for row in rows if len(row) == 2}
    table = [row for row in rows if len(row) == 5 and row[0].isdigit()]
    mu = np.array([float(re_) + 1j * float(im) for _, re_, im, _, _ in table])
    values = rotor_orbit.values
    liouville = np.exp(-2 * values["damping"] * rotor_orbit.period_s / values["rotor_mass"])
    assert np.prod(mu).real == pytest.approx(liouville, rel=1e-5)
    verdict = "stable" if np.abs(mu).max() < 1 else "unstable"
    assert facts["stability"].startswith(verdict)
    states = {row[0]: (float(row[1]), row[2]) for row in rows
              if len(row) == 3 and row[0] != "state"}
    assert list(states) == ["x", "y", "vx", "vy"]
    for name, z in zip(states, rotor_orbit.z0, strict=True):
        assert states[name][0] == pytest.approx(z, rel=1e-5)
    assert [u for _, u in states.values()] == ["m", "m", "m/s", "m/s"]
