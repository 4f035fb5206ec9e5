"""Issue 32, section 3: `hb` and `torus` say their cost before the work, from a short timed
probe of the method's own equations (``analysis.frequency.cost``); the arithmetic checked
with the probe replaced by a known value."""

from dataclasses import replace

import pytest

import analysis.frequency.cost as cost
from analysis.frequency.methods import PERIODIC, TORUS, Request
from analysis.integrate.cost import CostEstimate
from analysis.model import System

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3,
               speed_rpm=12.0)


def test_hb_estimate_is_the_probe_times_the_iterations(monkeypatch):
    monkeypatch.setattr(cost, "probe_newton_seconds", lambda equations: 0.25)
    monkeypatch.setattr(cost, "probe_hill_seconds", lambda equations: 0.5)
    system = System.make("duffing", **DUFFING)
    one = cost.hb_cost(system, Request(7, period="shaft"))
    assert (one.members, one.steps, one.unit) == (1, cost.NEWTON_ITERATIONS, cost.NEWTON)
    assert one.seconds == pytest.approx(0.25 * cost.NEWTON_ITERATIONS)
    assert one.lines()[0] == (f"estimate: 1 response x {cost.NEWTON_ITERATIONS} Newton "
                              f"iterations = {cost.NEWTON_ITERATIONS} iterations; expected "
                              f"about {0.25 * cost.NEWTON_ITERATIONS:.0f} s on 1 worker(s) "
                              "(0.25 s per iteration, probed)")
    branch = cost.hb_cost(system, Request(7, period="shaft", param="speed_rpm", start=10.0,
                                          stop=16.0, max_points=40))
    assert branch.members == 40 and branch.bound
    assert branch.seconds == pytest.approx(40 * cost.BRANCH_ITERATIONS * 0.25)
    assert dict(branch.also)["Hill's stability of each point"] == pytest.approx(40 * 0.5)
    assert "Hill's stability of each point" not in dict(one.also), "one response: no branch"
    assert (f"40 responses x up to {cost.BRANCH_ITERATIONS} Newton iterations"
            in branch.lines()[0])


def test_circle_estimate_is_points_steps_and_evaluations(monkeypatch):
    monkeypatch.setattr(cost, "probe_shaft_step_seconds", lambda shaft_map: 2e-5)
    system = System.make("vakharia2015", 10, speed_rpm=5000.0)
    est = cost.circle_cost(system, Request(65))
    steps = round(60 / 5000 / 1e-5)  # RK4 steps per revolution at the spec's 1e-5 s
    assert est.steps == 3 * 65 * steps * cost.CIRCLE_EVALUATIONS  # N and the 2N check
    assert est.seconds == pytest.approx(est.steps * 2e-5)
    assert est.dt == pytest.approx(1e-5) and est.members == 1
    branch = cost.circle_cost(system, Request(33, param="speed_rpm", start=5000.0,
                                              stop=5100.0, max_points=10))
    assert branch.members == 10 and branch.steps == 33 * steps * cost.CIRCLE_EVALUATIONS


def test_the_rk4_lines_are_unchanged_by_the_unit():
    est = CostEstimate(members=120, steps=40_000, workers=4, step_seconds=2e-6, dt=1e-5)
    assert est.lines()[0].startswith("estimate: 120 points x 40,000 RK4 steps (dt = 1e-05 s)"
                                     " = 4.8e+06 steps; expected")


def test_the_estimate_comes_after_the_checks_and_before_the_work():
    events = []
    system = System.make("duffing", **DUFFING)
    for method in (PERIODIC["hb"], TORUS["shooting"]):
        fake = replace(method, check=lambda s, e, r: events.append("check"),
                       estimate=lambda s, r: "estimate",
                       solve=lambda s, r: events.append("solve"))
        fake.run(system, Request(), cost=events.append)
        assert events == ["check", "estimate", "solve"]
        events.clear()


def test_hb_prints_its_probed_estimate_first(cli, tmp_path):
    out = cli("hb", "duffing", "--period", "shaft", *[f"--set={k}={v}" for k, v in
                                                       DUFFING.items()],
              "--harmonics", "5", "--param", "speed_rpm", "--from", "10", "--to", "16",
              "--ds-max", "0.5", "--max-points", "12", "-o", str(tmp_path / "b.nc"))
    assert out.returncode == 0, out.stderr
    lines = [line for line in out.stderr.splitlines()  # a loaded machine adds a note
             if not line.startswith("note: the machine was loaded")]
    assert lines[0].startswith(f"estimate: 12 responses x up to {cost.BRANCH_ITERATIONS} "
                               f"Newton iterations = {12 * cost.BRANCH_ITERATIONS} "
                               "iterations; expected at most "), lines
    assert "s per iteration, probed)" in lines[0]
    assert lines[1].startswith("estimate: in all "), "the whole command (issue 41)"
    assert lines[2].startswith("10 points, speed_rpm = "), "the progress after the estimate"
