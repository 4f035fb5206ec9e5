"""A followed bifurcation diagram against an independent Floquet analysis of the same case.

The balanced rotor at 50 N, N_b = 8, VC section, 7700–8600 rpm: continuation finds the
period-1 orbit stable except between period doublings near 8142 and 8342 rpm, and a stable
period-3 orbit coexists at 7872–8424 rpm. A followed sweep that restarted each value at
t = 0 (a kick of about the orbit's size) fell onto the period-3 orbit at scattered speeds in
both directions. Here the up and down sweeps must show, at every grid value, the orbit the
shooting API says is the stable continuation of period 1: the period-1 orbit where its
Floquet multipliers lie inside the unit circle, the period-2 orbit born at the doubling
where a real multiplier is below −1, point for point (every section point within
``TOLERANCE`` of the orbit's size of a shooting orbit point, every orbit point met).

The reference is computed without the sweep code: ``continue_orbits`` for the doublings,
``shoot`` (period ``vc``, chained from value to value) for the period-1 orbit and its
multipliers at each grid value, ``shoot`` (period ``vc:2``) from the period-1 orbit kicked
along its multiplier's eigenvector and settled for the period-2 orbit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import xarray as xr

from analysis.integrate.flow import Period, evaluate, flow_map
from analysis.integrate.simulate import simulate
from analysis.stability.continuation import continue_orbits
from analysis.stability.periodic import PeriodicOrbit, shoot
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting

LOAD = {"radial_load": 50.0}
"""Radial load (N) of the case."""
AXIS = Axis.linear("speed_rpm", 7700.0, 8600.0, 10)
"""Shaft speeds (rpm), 100 rpm apart: at least 42 rpm from either period doubling."""
SETTING = Setting("balanced-rotor", 8, LOAD, transient=0.1, samples=24, section="vc")
"""0.1 s transient (about 110 VC periods): enough after a phase-consistent start."""
TOLERANCE = 1e-3
"""Distance of a section point from an orbit point, per state variable, as a fraction of
the period-1 orbit's peak-to-peak size (the period-2 orbit's two points are 2–3 % apart)."""
PD_MARGIN = 20.0
"""Nearest a grid value may come to a period doubling (rpm)."""


@dataclass(frozen=True)
class Reference:
    """The stable continuation of period 1 at one speed (rpm): its points on the VC
    section (one or two rows, the model's state order) and the period-1 orbit's size."""

    speed: float
    period_one: PeriodicOrbit
    points: np.ndarray
    size: np.ndarray


def orbit_size(orbit: PeriodicOrbit) -> np.ndarray:
    """Peak-to-peak of every state variable over one period of ``orbit`` (m, m/s)."""
    run = simulate(orbit.system, duration=orbit.period_s, transient=0.0,
                   dt=orbit.period_s / orbit.n_steps, initial_state=orbit.z0)
    return np.array([np.ptp(run[name].values) for name in orbit.state_names])


def period_two(one: PeriodicOrbit, size: np.ndarray) -> np.ndarray:
    """The stable period-2 orbit next to the unstable period-1 orbit ``one``: its two VC
    section points. Found by a 1 % kick along the eigenvector of the multiplier below −1,
    0.3 s of settling and shooting over two VC periods."""
    mu, vectors = np.linalg.eig(one.monodromy)
    e = np.real(vectors[:, int(np.argmin(mu.real))])
    kicked = one.z0 + 0.01 * size * e / np.max(np.abs(e / size))
    two = shoot(one.system.replace(state=kicked), None, "vc:2", settle=0.3)
    half = evaluate(flow_map(one.system.model, one.structure, Period.parse("vc"), one.n_steps),
                    two.z0, two.t0, one.system.p)[0]
    assert two.converged and two.stability == "stable", two.message
    assert np.max(np.abs(half - two.z0) / size) > 10 * TOLERANCE  # not period 1 again
    return np.array([two.z0, half])


@pytest.fixture(scope="module")
def doublings() -> list[float]:
    """Speeds (rpm) of the period doublings continuation finds on the period-1 branch."""
    branch = continue_orbits("balanced-rotor", 8, param="speed_rpm", start=AXIS.values[0],
                             stop=AXIS.values[-1], ds_max=0.1, **LOAD)
    return [float(branch.speed_rpm[i]) for i in range(branch.sizes["point"])
            if branch.special.values[i] == "PD"]


@pytest.fixture(scope="module")
def references() -> list[Reference]:
    """Shooting at every grid value, each period-1 solve from the previous orbit."""
    out, guess = [], None
    for speed in AXIS.values:
        one = shoot("balanced-rotor", 8, "vc", guess, None if guess is None else 0.0,
                    speed_rpm=speed, **LOAD)
        assert one.converged, one.message
        guess, size = one.z0, orbit_size(one)
        points = one.z0[None, :] if one.stability == "stable" else period_two(one, size)
        out.append(Reference(speed, one, points, size))
    return out


@pytest.fixture(scope="module")
def diagram(tmp_path_factory) -> xr.Dataset:
    """The followed sweep, up and down (serial: one chain after the other)."""
    return bifurcation_diagram(SETTING, AXIS, tmp_path_factory.mktemp("d") / "d.nc",
                               direction="both", follow=True)


def section_period(points: np.ndarray, size: np.ndarray, most: int = 6) -> int:
    """Smallest n <= ``most`` with every point equal to the one n later (to ``TOLERANCE``
    of ``size``); 0 when there is none."""
    scaled = points / size
    for n in range(1, most + 1):
        if np.max(np.abs(scaled[n:] - scaled[:-n])) < TOLERANCE:
            return n
    return 0


def test_reference_has_the_doublings_of_the_issue(doublings, references):
    """Continuation: doublings near 8142 and 8342 rpm, no grid value within 20 rpm of them;
    shooting: period 1 stable outside, a real multiplier below −1 inside."""
    assert len(doublings) == 2 and abs(doublings[0] - 8142) < 5 and abs(doublings[1] - 8342) < 5
    for ref in references:
        assert min(abs(ref.speed - pd) for pd in doublings) > PD_MARGIN
        inside = doublings[0] < ref.speed < doublings[1]
        mu = ref.period_one.multipliers
        assert ref.period_one.stability == ("unstable" if inside else "stable"), ref.speed
        assert (mu.real.min() < -1) == inside and len(ref.points) == (2 if inside else 1)


@pytest.mark.parametrize("direction", ["up", "down"])
def test_followed_sweep_shows_the_floquet_orbit_point_for_point(diagram, references,
                                                                direction):
    names = list(references[0].period_one.state_names)
    for ref in references:
        at = diagram.sel(direction=direction, speed_rpm=ref.speed)
        points = np.stack([at[name].values for name in names], axis=1)
        assert section_period(points, ref.size) == len(ref.points), (direction, ref.speed)
        distance = np.abs(points[:, None, :] - ref.points[None, :, :]) / ref.size
        nearest = distance.max(axis=2)  # section point × orbit point
        assert nearest.min(axis=1).max() < TOLERANCE, (direction, ref.speed)
        assert nearest.min(axis=0).max() < TOLERANCE, (direction, ref.speed)
