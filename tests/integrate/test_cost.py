"""Costs said before they are paid (issue 32, section 3): the estimate's arithmetic, its
probe, its advice, and the commands that print it before the work."""

from __future__ import annotations

import math

import pytest

from analysis.errors import InputError
from analysis.integrate.cost import (
    CostEstimate,
    coarsest_step,
    estimate_cost,
    probe_step_seconds,
    tangent_step_factor,
)
from analysis.integrate.plan import RunPlan
from analysis.model import System
from analysis.sweeps.grid import Axis, Setting, check_grid, grid_cost


def test_the_estimate_is_steps_times_members_times_the_probe_over_workers():
    est = CostEstimate(members=120, steps=40_000, workers=4, step_seconds=2e-6, dt=1e-5)
    assert est.total_steps == 4_800_000
    assert est.seconds == pytest.approx(4_800_000 * 2e-6 / 4)
    assert CostEstimate(members=2, steps=10, workers=8, step_seconds=1.0, dt=1.0).seconds == 10
    head = est.lines()[0]
    assert head.startswith("estimate: 120 points x 40,000 RK4 steps (dt = 1e-05 s)")
    assert "about 2 s on 4 worker(s)" in head and len(est.lines()) == 1, "short: no advice"


def test_a_long_estimate_says_what_would_help():
    est = CostEstimate(members=400, steps=10**6, workers=2, step_seconds=1e-6, dt=1e-6,
                       coarsest_dt=1e-5)
    assert est.seconds == pytest.approx(200.0)
    hints = est.advice()
    assert hints[0] == "hint: --dt 1e-05 (within the run plan's checks) would take about 20 s"
    assert hints[1] == "hint: 100 points instead of 400 would take about 50 s"
    assert CostEstimate(400, 10**6, 2, 1e-6, 1e-5, coarsest_dt=1e-5).advice() == [
        "hint: 100 points instead of 400 would take about 50 s"], "no coarser step to offer"


def test_the_probe_times_the_compiled_steps_of_the_system():
    system = System.make("vakharia2015", 8, speed_rpm=5000)
    seconds = probe_step_seconds(system, 1e-5)
    assert 1e-9 < seconds < 1e-3
    est = estimate_cost(system, 10, 1000, dt=1e-5, workers=2)
    assert est.step_seconds > 0 and est.workers == 2 and est.seconds < 1.0


def test_the_coarsest_step_passes_the_plan_and_a_larger_one_does_not():
    system = System.make("vakharia2015", 8, speed_rpm=5000)
    dt = coarsest_step(system)
    assert dt is not None and dt > 1e-5  # the spec's step is finer than the plan needs
    warned = []
    RunPlan.step(system, dt, warn=warned.append)
    assert warned == []
    try:  # ten times coarser: refused or warned
        RunPlan.step(system, 10 * dt, warn=warned.append)
    except InputError:
        warned.append("refused")
    assert warned


def test_a_grid_costs_the_mean_record_of_its_points(monkeypatch):
    """Every point records ``samples`` periods of its own section: the estimate takes the
    mean of their steps (all 15 points here), not 15 times the slowest corner's; λ1 by the
    measured cost of a step with its tangent (``n + 1`` state steps where no member kernel
    can be built); the coarser step offered is one every corner accepts."""
    from analysis.integrate import cost

    monkeypatch.setattr(cost, "probe_step_seconds", lambda *a, **k: 1e-6)
    setting = Setting("vakharia2015", None, {}, 0.05, 10, lyapunov=False)
    axes = Axis.parse("speed_rpm:3000:9000:5"), Axis.parse("n_balls:6:8")
    check_grid(setting, *axes)
    est = grid_cost(setting, *axes, workers=2)
    every = [setting.seconds(setting.system_at(speed_rpm=v, n_balls=n))
             for n in (6, 7, 8) for v in axes[0].values]
    assert est.members == 15 and est.average and "(mean) RK4 steps" in est.lines()[0]
    assert est.steps == math.ceil(sum(every) / len(every) / setting.step())
    assert est.steps < math.ceil(max(every) / setting.step())
    corners = [setting.system_at(speed_rpm=v, n_balls=n) for v in (3000.0, 9000.0)
               for n in (6, 8)]
    assert est.coarsest_dt == min(coarsest_step(c) for c in corners)
    for factor, extra in ((1.7, 0.7), (None, 4.0)):  # vakharia2015: n = 4
        monkeypatch.setattr(cost, "probe_kernel", lambda *a, f=factor, **k: None if f is None
                            else cost.KernelProbe(1e-6, f))
        with_lyapunov = grid_cost(Setting("vakharia2015", None, {}, 0.05, 10), *axes,
                                  workers=2)
        assert with_lyapunov.steps == est.steps
        # the tangent's transient (0.1 s, a tenth of the spec's) spans the 0.05 s
        # transient: every step carries the tangent
        assert with_lyapunov.step_seconds == pytest.approx(1e-6 * (1 + extra))
        assert ("tangent x1.70" in with_lyapunov.lines()[0]) == (factor is not None)


def test_a_long_axis_is_sampled_evenly():
    setting = Setting("vakharia2015", 8, {}, 0.05, 10, lyapunov=False)
    axis = Axis.parse("speed_rpm:1000:10000:1000")
    check_grid(setting, axis)
    est = grid_cost(setting, axis, workers=1)
    every = [setting.seconds(setting.system_at(speed_rpm=v)) for v in axis.values]
    assert est.steps == pytest.approx(sum(every) / len(every) / setting.step(), rel=0.02)


def test_the_cost_of_a_step_with_its_tangent_is_measured():
    system = System.make("vakharia2015", 8, speed_rpm=5000)
    factor = tangent_step_factor(system, 1e-5)
    assert factor is not None and math.isfinite(factor) and factor > 0  # measured: the
    # lanes build runs its tangent variant at about a state step's cost


def test_attractors_say_their_cost_before_the_work(tmp_path, cli):
    res = cli("attractors", "vakharia2015", "--samples", "4", "--box", "x:-1e-6:1e-6", "-o",
              "a.nc", "--max-periods", "40", "--revisits", "5", "--hits", "2", "--executor",
              "serial", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines()  # a loaded machine adds a note
             if not line.startswith("note: the machine was loaded")]
    assert lines[0].startswith("estimate: 4 initial states x up to ")
    assert "on 1 worker(s)" in lines[0]
    progress = [i for i, line in enumerate(lines) if line.startswith("attractors: ")]
    assert lines[1].startswith("estimate: in all "), "the whole command (issue 41)"
    assert progress and progress[0] == 2, "the estimate comes before the progress"
    assert lines[progress[-1]].startswith("attractors: 4/4"), "progress reaches every state"
