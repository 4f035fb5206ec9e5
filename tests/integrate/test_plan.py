"""The run plan: one set of checks of a run's times, step and structure, used by every path.

Each path that integrates is asked the same wrong question and must give the same answer:
before the plan, ``lyapunov`` without a transient took an RK4-unstable step, the chart took
a step that does not resolve the forcing, and sweeps and charts ran at 1e-5 s whatever the
spec's step."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.checks import stable_step
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import System


@pytest.fixture(scope="module")
def rotor() -> System:
    return System.make("vakharia2015", 8)


@pytest.mark.parametrize("duration, transient, dt, save_every", [
    (0.01, 0.0, 1e-5, 1), (0.01, 0.003, 1e-5, 7), (0.02, 0.0137, 2e-5, 3),
    (0.01, 0.00999, 1e-5, 1)])
def test_the_plans_times_are_the_runs_times(rotor, duration, transient, dt, save_every):
    plan = RunPlan.make(rotor, duration=duration, transient=transient, dt=dt,
                        save_every=save_every)
    ds = simulate(rotor, duration=duration, transient=transient, dt=dt,
                  save_every=save_every)
    assert np.array_equal(plan.times()[plan.first:], ds["t"].values)
    assert plan.settings() == {k: ds.attrs[k] for k in plan.settings()}


def test_a_plan_defaults_to_the_specs_times():
    system = System.make("6205-outer-defect")
    plan = RunPlan.make(system)
    sim = system.model.simulation_defaults
    assert (plan.dt, plan.duration, plan.transient) == (sim["dt"], sim["duration"],
                                                        sim["transient"])
    assert RunPlan.step(system).dt == sim["dt"] == 2e-6


def test_a_step_only_plan_refuses_an_unstable_step(rotor):
    limit, _ = stable_step(rotor)
    warnings.simplefilter("ignore", RuntimeWarning)  # 13 steps per VC period: coarse
    assert RunPlan.step(rotor, limit * 0.99).dt == limit * 0.99
    with pytest.raises(InputError, match=r"^dt: must be in \(0, .*\] s for RK4"):
        RunPlan.step(rotor, limit * 1.01)
    with pytest.raises(InputError, match="a step-only plan has no duration"):
        _ = RunPlan.step(rotor).n_steps


@pytest.mark.parametrize("kwargs, message", [
    (dict(duration=0.0, dt=0.0), r"^duration: must be a finite number > 0 s"),
    (dict(duration=0.1, dt=-1.0, method="euler"), r"^dt: must be a finite number > 0 s"),
    (dict(duration=0.1, method="euler", save_every=0), r"^method: must be 'rk4' or"),
    (dict(duration=0.1, save_every=0, dt=1.0), r"^dt: must be <= duration"),
    (dict(duration=0.1, save_every=0, dt=0.05), r"^save_every: must be a whole number >= 1"),
    (dict(duration=0.1, dt=0.05), r"^dt: must resolve the fastest forcing"),
    (dict(duration=0.1, dt=8e-4), r"^dt: must be in \(0, .*\] s for RK4"),
    (dict(duration=1e4, dt=1e-5, save_every=1, in_memory=True), r"^save_every: the run "),
])
def test_the_first_failing_check_is_the_one_reported(rotor, kwargs, message):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(InputError, match=message):
            RunPlan.make(rotor, transient=0.0, **kwargs)


def test_lyapunov_without_a_transient_checks_the_rk4_step(rotor):
    from analysis.stability.lyapunov import lyapunov

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for transient in (0.0, 0.01):
            with pytest.raises(InputError, match=r"^dt: must be in \(0, .*\] s for RK4"):
                lyapunov(rotor, transient=transient, duration=1.0, dt=5e-4)


def test_shooting_checks_the_rk4_step():
    from analysis.stability.periodic import shoot

    system = System.make("balanced-rotor", 8, radial_load=50.0)
    with pytest.raises(InputError, match=r"^dt: must be in \(0, .*\] s for RK4"):
        shoot(system, guess=system.state, t0=0.0, dt=5e-4)
