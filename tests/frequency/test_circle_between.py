"""Issue 32: the default torus (the invariant circle, N = 65, run integrated from each
section's circle point as `torus --run` writes it) is within 1e-3 of the amplitude at every
time, not only at the shaft sections, against a simulation started on the circle at a step
fine enough to be the flow (1.25e-6 s: within 2e-5 of one at 6.25e-7 s; at the spec's
1e-5 s the simulation itself is 1.5e-3 off, benchmarks/bench_torus.py --between 20)."""

import numpy as np
import pytest

from analysis.frequency.circle.solve import DEFAULT_POINTS, circle_dataset, solve_circle
from analysis.frequency.circle_run import circle_states
from analysis.integrate.simulate import simulate

SPAN = 1.0
"""Seconds compared (after half of them: the start's own offset decays at λ1 ≈ −35 1/s)."""


@pytest.fixture(scope="module")
def run_and_reference():
    circle = solve_circle("vakharia2015", 10, "shaft,vc", DEFAULT_POINTS, convergence=False,
                          stability=False, speed_rpm=5000.0)
    assert circle.converged
    t, z = circle_states(circle_dataset(circle), SPAN)
    sim = simulate(circle.system.replace(state=z[0]), duration=SPAN, transient=0.0,
                   dt=1.25e-6, save_every=round(float(t[1] - t[0]) / 1.25e-6))
    ref = np.column_stack([sim[n].values for n in circle.system.state_names])
    return t, z, ref[:len(z)], circle.steps


def test_default_circle_run_is_within_1e_3_at_every_time(run_and_reference):
    t, z, ref, steps = run_and_reference
    assert len(ref) == len(z)
    late = t >= SPAN / 2
    amp = np.ptp(z, axis=0) / 2
    error = np.max(np.abs(z - ref) / amp, axis=1)
    sections = np.arange(len(t)) % steps == 0
    assert error[late].max() < 1e-3, "between the sections"  # measured 2.3e-4 over 20 s
    assert error[late & sections].max() < 1e-3  # measured 2.3e-4
    assert error[late & ~sections].max() > 0, "a real comparison"
