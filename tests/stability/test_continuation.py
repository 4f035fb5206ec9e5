"""Continuation on the Duffing oscillator against brute-force sweeps (a second method)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from analysis.integrate.simulate import simulate
from analysis.io import open_result, save_dataset
from analysis.provenance import state_at
from analysis.signal.poincare import poincare_section
from analysis.stability.classify import _normalised_points, repeat_period
from analysis.stability.continuation import (
    continue_from_orbit,
    continue_orbits,
    switch_period_doubling,
)

RPM = 30 / math.pi  # rad/s -> rpm
RESONANCE = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
DOUBLING = dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2, forcing_amplitude=20.0)


def sweep(omegas, params, periods=60, keep=1):
    """Brute force: settle at each ω from the previous end state; return the final state,
    half the peak-to-peak x over the last period and the last ``keep`` section points."""
    state, out = (0.0, 0.0, 0.0, 0.0), []
    for w in omegas:
        period = 2 * math.pi / w
        ds = simulate("duffing", None, duration=periods * period,
                      transient=(periods - keep) * period, dt=period / 100,
                      initial_state=state, speed_rpm=w * RPM, **params)
        state = tuple(state_at(ds, -1))
        out.append((w, float(np.ptp(ds.x.values)) / 2, ds))
    return out


@pytest.fixture(scope="module")
def resonance_branch():
    return continue_orbits("duffing", param="speed_rpm", start=1.0 * RPM, stop=1.8 * RPM,
                           period="shaft", dt=0.01, settle=200.0, max_points=400,
                           **RESONANCE)


def test_folds_match_the_jumps_of_up_and_down_sweeps(resonance_branch):
    br = resonance_branch
    folds = sorted(br.speed_rpm.values[br.special.values == "LP"] / RPM)
    assert len(folds) == 2
    lower_fold, upper_fold = folds
    up = sweep(np.r_[np.arange(1.0, 1.45, 0.05), np.arange(1.45, 1.65, 0.0025)], RESONANCE)
    down = sweep(np.r_[np.arange(1.8, 1.35, -0.05), np.arange(1.35, 1.15, -0.0025)],
                 RESONANCE)

    def jump(runs, factor):
        for (w0, a0, _), (w1, a1, _) in itertools.pairwise(runs):
            if a1 > factor * a0 or a1 < a0 / factor:
                return (w0 + w1) / 2
        raise AssertionError("no jump in the sweep")

    assert jump(up, 1.5) == pytest.approx(upper_fold, rel=0.01)
    assert jump(down, 1.5) == pytest.approx(lower_fold, rel=0.01)


def test_branch_stability_and_file_round_trip(resonance_branch, tmp_path):
    br = resonance_branch
    lp = np.nonzero(br.special.values == "LP")[0]
    middle = (lp[0] + lp[1]) // 2
    assert br.stable.values[middle] == 0 and br.multiplier_abs.values[middle].max() > 1
    assert br.stable.values[0] == 1 and br.stable.values[-1] == 1
    save_dataset(br, tmp_path / "branch.nc")
    back = open_result(tmp_path / "branch.nc")
    assert list(back.special.values) == list(br.special.values)
    np.testing.assert_array_equal(back.speed_rpm.values, br.speed_rpm.values)


def _section_points(ds):
    pts = poincare_section(ds, "shaft")
    ptp = {name: float(np.ptp(ds[name].values)) for name in ds.data_vars}
    return _normalised_points(pts, ptp)


def test_period_doubling_confirmed_by_branch_switching_and_brute_force():
    # from rest at ω = 1.2 the motion settles on the branch that doubles (at 1.15 it would
    # settle on a coexisting large-amplitude branch, which folds at ω ≈ 1.194 instead)
    br = continue_orbits("duffing", param="speed_rpm", start=1.2 * RPM, stop=1.5 * RPM,
                         period="shaft", dt=0.01, settle=200.0, **DOUBLING)
    pd = np.nonzero(br.special.values == "PD")[0]
    assert len(pd) == 2
    w_pd = br.speed_rpm.values[pd] / RPM
    assert np.abs(br.multiplier_real.values[pd].min(axis=1) + 1).max() < 1e-4

    # branch switching: a stable, genuine period-2 orbit just past the first PD
    two = switch_period_doubling(br, int(pd[0]))
    assert two.converged and two.period == "shaft:2" and two.stability == "stable"
    w_two = two.values["speed_rpm"] / RPM

    # brute force, sweeping up through the first PD with the state carried along
    runs = sweep([w_pd[0] * 0.98, (w_pd[0] * 0.98 + w_two) / 2, w_two], DOUBLING,
                 periods=400, keep=40)
    (p_before, s_before), (p_after, s_after) = (_section_points(runs[0][2]),
                                                _section_points(runs[-1][2]))
    assert repeat_period(p_before, s_before, 1e-3, 8) == 1
    assert repeat_period(p_after, s_after, 1e-3, 8) == 2
    # and its two section points are the period-2 orbit's (z0 and its image after T)
    ds = runs[-1][2]
    omega = 2 * np.pi / (2 * np.pi / w_two)
    brute = {tuple(np.round(p / s_after, 3)) for p in p_after[-2:]}
    orbit_points = [two.z0]
    half = simulate("duffing", None, duration=two.period_s / 2, transient=0.0,
                    dt=two.period_s / two.n_steps, save_every=two.n_steps // 2,
                    initial_state=tuple(two.z0), **two.values)
    orbit_points.append(state_at(half, -1))
    scale = np.array([1, 1, omega, omega])
    mine = {tuple(np.round(z / scale / s_after, 3)) for z in orbit_points}
    assert brute == mine, (brute, mine, ds.attrs["speed_rpm"])

    # the period-2 branch leaves the first PD and closes at the second
    branch2 = continue_from_orbit(two, param="speed_rpm", stop=1.5 * RPM, dt=0.01,
                                  label="period 2")
    assert branch2.speed_rpm.values.max() / RPM == pytest.approx(w_pd[1], rel=1e-3)
