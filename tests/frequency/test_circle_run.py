"""Issue 32: an invariant circle's run is integrated between the shaft sections (RK4 from
each section's circle point), and is closer to a simulation than the interpolated series."""

import math

import numpy as np
import pytest

from analysis.frequency.circle.solve import circle_dataset, interpolate_circle, solve_circle
from analysis.frequency.circle_run import between_error, circle_run, circle_states
from analysis.frequency.torus.dataset import torus_of
from analysis.frequency.torus.equations import omegas_of
from analysis.integrate.simulate import simulate


@pytest.fixture(scope="module")
def circle():
    response = solve_circle("vakharia2015", 10, "shaft,vc", 17, convergence=False,
                            stability=False, speed_rpm=5000.0)
    assert response.converged
    return circle_dataset(response)


def test_run_starts_each_revolution_on_the_circle(circle):
    ts, _ = torus_of(circle)
    w1, w2 = omegas_of(ts.system, ts.frequencies)
    period = 2 * math.pi / w1
    t, z = circle_states(circle, 3 * period)
    steps = int(circle.attrs["steps"])
    assert np.allclose(np.diff(t), period / steps)
    for k in range(3):
        at = interpolate_circle(circle.circle.values.T, np.array([np.mod(w2 * k * period,
                                                                         2 * math.pi)]))
        assert np.allclose(z[k * steps], at[0], rtol=0, atol=1e-12 * np.abs(z).max())
    run = circle_run(circle, 3 * period)
    assert run.attrs["reconstruction"].startswith("RK4") and run.sizes["t"] == len(t)


def test_integrated_run_beats_the_series_against_a_simulation(circle):
    ts, coeffs = torus_of(circle)
    duration = 1.0
    t, z = circle_states(circle, duration)
    sim = simulate(ts.system.replace(state=z[0]), duration=duration, transient=0.0,
                   dt=float(t[1] - t[0]))
    zs = np.stack([sim[n].values for n in ts.system.state_names], axis=1)
    m = min(len(t), len(zs))
    late = t[:m] > duration / 2
    amp = np.ptp(z, axis=0) / 2
    integrated = np.max(np.abs(zs[:m] - z[:m])[late] / amp)
    series = np.max(np.abs(zs[:m] - ts.at_times(coeffs, t[:m]))[late] / amp)
    assert integrated < series / 2
    assert 0 < between_error(circle) < 1
