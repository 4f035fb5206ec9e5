"""Issue 41: every cost estimate covers the whole command, not its Newton iterations or
circle steps alone. With the probes replaced by known values, the parts of `torus --method
hb` (its two error-estimate solves, λ1 and the drift run, the figure's run, the file) and the
start-up already spent add up to the whole that the second line says."""

import pytest

import analysis.frequency.cost as cost
from analysis.frequency.methods import Request
from analysis.integrate.cost import CostEstimate, duration_text
from analysis.model import System


def test_torus_hb_estimate_counts_every_part(monkeypatch):
    monkeypatch.setattr(cost, "probe_newton_seconds", lambda equations: 0.5)
    monkeypatch.setattr("analysis.integrate.cost.probe_step_seconds",
                        lambda system, dt, **kw: 1e-6)
    monkeypatch.setattr("analysis.integrate.cost.process_seconds", lambda: 3.0)
    system = System.make("vakharia2015", 10, speed_rpm=5000.0)
    est = cost.hb_cost(system, Request("8,4", lyapunov_duration=2.0, figure=2.0), torus=True)
    parts = dict(est.also)
    errors = cost.NEWTON_ITERATIONS * 0.5 * (cost.DOUBLED_ITERATION[True] + 2)
    assert parts["the two error-estimate solves (2H, 2x samples)"] == pytest.approx(errors)
    steps = 2.0 / 1e-5  # λ1's seconds at the spec's step
    assert parts["lambda1 and the drift run"] == pytest.approx(
        1e-6 * steps * (1.1 * (1 + system.n_state) + 1))
    assert parts["the figure"] == pytest.approx(1e-6 * 3.0 / 1e-5 + cost.FILE_SECONDS)
    assert parts["the file"] == cost.FILE_SECONDS
    assert est.spent == 3.0
    whole = 3.0 + 6 * 0.5 + sum(parts.values())
    assert est.whole_seconds == pytest.approx(whole)
    assert est.lines()[-1].startswith(f"estimate: in all {duration_text(whole)} for the "
                                      "whole command (3 s start-up and probes so far")
    assert est.whole_seconds > 5 * est.seconds  # what was said before was the least of it


def test_no_parts_no_second_line():
    est = CostEstimate(members=1, steps=10, workers=1, step_seconds=0.1, dt=1e-5)
    assert len(est.lines()) == 1 and est.whole_seconds == pytest.approx(1.0)
