"""Continuation never jumps between branches silently (step guards), checked against shooting;
branch switching at a symmetry-breaking pitchfork (BP), checked against brute force.

Defect case: the period-3 orbit (period ``vc:3``) of the balanced rotor (N_b = 8, 50 N) at
7989.9 rpm, continued towards 7600 rpm. Without the guards, large steps pass its fold and
land on the period-1 orbit (also a fixed point of the three-period map) with no LP label.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.integrate.flow import Period, evaluate, flow_map
from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.provenance import state_at, system_of_attrs
from analysis.stability.continuation import (
    StepGuards,
    continue_from_orbit,
    continue_orbits,
    first_point,
    switch_branch_point,
)
from analysis.stability.periodic import PeriodicOrbit, shoot

RPM = 30 / math.pi
ROTOR = dict(radial_load=50.0)
TRAP = dict(ds=0.05, ds_max=0.3, dt=5e-6)
"""Steps large enough to jump over the period-3 fold when unguarded."""
SUBHARMONIC = dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.05,
                   forcing_amplitude=3.0)


def one_period_gap(system: System, z0: np.ndarray, period: Period, n_steps: int) -> float:
    """max |Φ_{T/k}(z0) − z0| / max |z0| for a k-period orbit (T = k base periods): 0 for
    an orbit of the base period, O(1) for a genuine period-k orbit."""
    base = Period(period.kind, 1, name=period.name)
    flow = flow_map(system.model, system.structure, base, n_steps // period.count)
    return float(np.max(np.abs(evaluate(flow, z0, 0.0, system.p)[0] - z0))
                 / np.max(np.abs(z0)))


def branch_gaps(br) -> np.ndarray:
    param, per = br.attrs["param"], Period.parse(br.attrs["period"])
    return np.array([one_period_gap(system_of_attrs({**br.attrs, param: float(lam)}), z0,
                                    per, int(br.attrs["steps_per_period"]))
                     for lam, z0 in zip(br[param].values, br.z0.values, strict=True)])


def rotor_period3(**kw):
    return continue_orbits("balanced-rotor", 8, param="speed_rpm", start=7989.9, stop=7600.0,
                           period="vc:3", **TRAP, **kw, **ROTOR)


def genuine(orbit: PeriodicOrbit) -> bool:
    return orbit.converged and one_period_gap(orbit.system, orbit.z0,
                                              Period.parse(orbit.period),
                                              orbit.n_steps) > 1e-2


def test_unguarded_steps_jump_onto_the_period1_orbit():
    """The trap is real: the old step control lands on period 1 and calls the run fine."""
    br = rotor_period3(guards=StepGuards(active=False))
    assert "LP" not in set(br.special.values)
    assert br.attrs["status"] == "reached the end of the range"
    assert br.stable.values.all()
    assert branch_gaps(br)[-1] < 1e-5  # the last orbit repeats after one VC period


def test_period3_fold_is_labelled_and_the_branch_stays_period3():
    br = rotor_period3()
    lam = br.speed_rpm.values
    lp = lam[br.special.values == "LP"]
    assert len(lp) == 1 and 7871.6 < lp[0] < 7871.9  # measured 7871.756
    assert br.attrs["refused_steps"] > 0
    assert br.tangent_angle.values.max() <= 30.0
    # it turns back at the fold: nothing below it, and it ends above it, unstable
    assert lam.min() >= lp[0] - 1e-6 and lam[-1] > lp[0] + 50
    assert not br.stable.values[-1]
    # every orbit is genuinely period-3: its state after one VC period is not z0
    assert branch_gaps(br).min() > 1e-2  # measured 0.078

    # independent check by shooting (its own step count per period) from the orbit found
    # at 7880 rpm: a period-3 orbit just above the fold, none just below it
    base = System.make("balanced-rotor", 8, **ROTOR)
    near = np.argmin(np.abs(lam - 7880.0))
    guess = br.z0.values[near]

    def at(speed: float) -> PeriodicOrbit:
        return shoot(base.replace(speed_rpm=speed), None, "vc:3", guess, 0.0, dt=TRAP["dt"])

    assert genuine(at(lp[0] + 0.3))
    assert not genuine(at(lp[0] - 0.3))


def test_duffing_subharmonic_guards_fire_and_label_the_fold():
    """The 1/3 subharmonic of a hardening Duffing oscillator (period 3T) folds at
    ω ≈ 3.248 rad/s: the guards refuse steps that turn too far, the fold is labelled, and
    shooting confirms it (a period-3 orbit above, none below)."""
    guess = np.array([-0.6044, 0.0, 0.412, 0.0])  # a period-3 orbit at ω = 3.3 rad/s
    common = dict(param="speed_rpm", start=3.3 * RPM, stop=2.5 * RPM, period="shaft:3",
                  guess=guess, t0=0.0, dt=0.01, ds=0.1, ds_max=0.3, **SUBHARMONIC)
    loose = continue_orbits("duffing", guards=StepGuards(active=False), **common)
    br = continue_orbits("duffing", **common)
    assert loose.tangent_angle.values.max() > 30.0  # measured 60°
    assert br.attrs["refused_steps"] >= 1 and br.tangent_angle.values.max() <= 30.0
    lp = br.speed_rpm.values[br.special.values == "LP"] / RPM
    assert len(lp) == 1 and lp[0] == pytest.approx(3.2482, abs=1e-3)
    assert branch_gaps(br).min() > 0.1

    base = System.make("duffing", None, **SUBHARMONIC)

    def at(omega: float) -> PeriodicOrbit:
        return shoot(base.replace(speed_rpm=omega * RPM), None, "shaft:3", guess, 0.0,
                     dt=0.01)

    assert genuine(at(lp[0] + 0.01))
    assert not genuine(at(lp[0] - 0.01))


# --------------------------------------------------------------------------- branch points

PITCHFORK = dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2, forcing_amplitude=20.0)
"""Duffing, hardening: the large symmetric orbit (x(t + T/2) = −x(t)) loses stability in a
supercritical symmetry-breaking pitchfork near ω = 1.1557 rad/s."""
SYMMETRIC_GUESS = np.array([4.19, 0.0, 0.15, 0.0])  # near the symmetric orbit at ω = 1.12


def simulated(omega: float, state, periods: int = 400, n: int = 600):
    """Brute force: the state after ``periods`` forcing periods (n RK4 steps each) and x
    over the last period (n samples)."""
    period = 2 * math.pi / omega
    ds = simulate("duffing", None, duration=periods * period,
                  transient=(periods - 1) * period, dt=period / n, initial_state=tuple(state),
                  speed_rpm=omega * RPM, **PITCHFORK)
    return state_at(ds, -1), ds.x.values[:-1]


@pytest.fixture(scope="module")
def symmetric_branch():
    return continue_orbits("duffing", param="speed_rpm", start=1.12 * RPM, stop=1.3 * RPM,
                           period="shaft", guess=SYMMETRIC_GUESS, t0=0.0, dt=0.01,
                           **PITCHFORK)


def test_bp_on_the_symmetric_branch_matches_the_brute_force_pitchfork(symmetric_branch):
    """The BP of continuation against the pitchfork of simulated attractors: their mean x
    (zero on a symmetric orbit) grows as √(ω − ω_BP); a line through the squares meets
    zero at ω_BP."""
    br = symmetric_branch
    bp = first_point(br, "BP")
    assert bp is not None and "LP" not in set(br.special.values)
    omega_bp = br.speed_rpm.values[bp] / RPM
    assert np.abs(br.multiplier_real.values[bp] - 1).min() < 1e-3
    omegas = np.array([1.16, 1.165, 1.17])
    means = np.array([simulated(w, (4.15, 0.0, 0.8, 0.0))[1].mean() for w in omegas])
    slope, intercept = np.polyfit(omegas, means**2, 1)
    assert omega_bp == pytest.approx(-intercept / slope, abs=3e-4)  # measured 1.15567


def test_bp_switching_finds_the_simulated_asymmetric_orbit(symmetric_branch):
    br = symmetric_branch
    bp = first_point(br, "BP")
    orbit = switch_branch_point(br, bp)
    assert orbit.converged and orbit.period == "shaft" and orbit.stability == "stable"
    omega = orbit.values["speed_rpm"] / RPM
    period = 2 * math.pi / omega
    # asymmetric: the mirror image of its state half a period on, −z(T/2), is not z(0) ...
    half = simulate("duffing", None, duration=period / 2, transient=0.0, dt=period / 600,
                    save_every=300, initial_state=tuple(orbit.z0), speed_rpm=omega * RPM,
                    **PITCHFORK)
    mirror = -state_at(half, -1)
    size = np.abs(orbit.z0).max()
    assert np.abs(mirror - orbit.z0).max() > 0.02 * size  # measured 0.048
    # ... and brute force from the unstable symmetric orbit, nudged either way, settles on
    # the orbit one way and on its mirror image the other
    symmetric = shoot(br.attrs["model"], None, "shaft", br.z0.values[bp], 0.0, dt=period / 600,
                      **{**PITCHFORK, "speed_rpm": omega * RPM})
    assert symmetric.converged and symmetric.stability == "unstable"
    ends = [simulated(omega, symmetric.z0 + np.array([s * 1e-3, 0, 0, 0]))[0] for s in (1, -1)]
    gaps = np.array([[np.abs(end - z).max() / size for z in (orbit.z0, mirror)]
                     for end in ends])
    assert gaps.min(axis=1).max() < 1e-6  # measured 1.6e-8 and 6.9e-8
    assert set(gaps.argmin(axis=1)) == {0, 1}  # one nudge each way: the orbit and its mirror
    # the asymmetric branch goes on to the period doubling of test_continuation (1.2093)
    asym = continue_from_orbit(orbit, param="speed_rpm", stop=1.3 * RPM, dt=0.01)
    pd = asym.speed_rpm.values[asym.special.values == "PD"] / RPM
    assert len(pd) >= 1 and pd[0] == pytest.approx(1.2093, abs=2e-4)
