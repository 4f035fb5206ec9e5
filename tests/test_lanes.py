"""Chart tangents in vector lanes (``analysis.integrate.lanes``) against the scalar CasADi
blocks they are written from: bit for bit, whatever point shares a lane's call, through a
blow-up in the other lane, and with the scalar path when no kernel can be written."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.integrate import lanes
from analysis.integrate.lanes import LANES, Unsupported, kernel, vector_c
from analysis.integrate.tangent import tangent_block
from analysis.model import load_model
from analysis.sweeps.grid import Setting
from analysis.sweeps.points import chart_point, chart_points

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
DUFFING = Setting("duffing", None, {"linear_stiffness": 1.0, "damping": 0.2,
                                    "forcing_amplitude": 0.3},
                  transient=5.0, samples=30, lyapunov=True, dt=0.01)


def _same(a: dict, b: dict) -> bool:
    """Two chart results equal field by field, NaN equal to NaN."""
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
        for k in a)


def test_each_lane_is_the_casadi_block_bit_for_bit_whatever_its_neighbour():
    """Three renormalisations of 100 steps from different states, step counters and speeds:
    each lane's state, tangent and logs equal ``tangent_block``'s (the CasADi VM), and a
    lane's numbers do not change when the point beside it changes."""
    model = load_model("vakharia2015")
    kern = kernel(model, (8,), 100)
    assert kern is not None
    block = tangent_block(model, (8,), 1, 100, 3)
    rng = np.random.default_rng(3)

    def start(k):
        z = np.array([1.2e-5, 3e-6, 0.004, -0.002]) * (1 + 0.2 * rng.standard_normal(4))
        return np.concatenate([z, [1000.0 * k + 17], [1.0, 0, 0, 0]])

    runs = []
    for trial in range(2):
        starts = [start(k) for k in range(LANES)]
        if trial == 1:
            starts[0] = runs[0][0][0]  # the same first lane, a new neighbour
        params = [model.parameter_vector({**model.defaults, "speed_rpm": 3000.0 + 900 * k
                                          + 50 * trial * k}) for k in range(LANES)]
        s = np.ascontiguousarray(np.stack(starts, axis=1))
        logs, states = kern.run(s, np.stack(params, axis=1), np.full(LANES, 1e-5),
                                np.zeros(LANES), 3, 100)
        for k in range(LANES):
            want_s, want_logs = (np.asarray(x).ravel()
                                 for x in block(starts[k], params[k], 1e-5, 0.0)[:2])
            assert np.array_equal(s[:, k], want_s) and np.array_equal(logs[:, k], want_logs)
        runs.append((starts, s.copy(), logs.copy(), states.copy()))
    assert np.array_equal(runs[0][1][:, 0], runs[1][1][:, 0])
    assert np.array_equal(runs[0][3][0], runs[1][3][0])


def test_chart_points_in_lanes_are_chart_point_bit_for_bit():
    """Five speeds (records of different lengths, an odd count: the last group is one point)
    give chart_point's class, period, λ1, interval and amplitudes exactly."""
    points = [CHART.system_at(n_balls=8, speed_rpm=v)
              for v in (2000.0, 2100.0, 4000.0, 6100.0, 9000.0)]
    together = chart_points(CHART, points)
    for system, got in zip(points, together, strict=True):
        assert _same(got, chart_point(CHART, system)), dict(system.parameters)


def test_a_lane_that_blows_up_leaves_its_neighbour_alone():
    """Duffing with a softening spring escapes its well at the larger forcing, after its
    tangent has started (so inside the lanes): that lane is a SimulationError with the time
    a lone run reports, and the other lane's result is chart_point's exactly."""
    import re

    from analysis.errors import SimulationError
    from analysis.stability.lyapunov import default_lengths
    from analysis.sweeps.points import _schedule

    points = [DUFFING.system_at(cubic_stiffness=1.0),
              DUFFING.system_at(cubic_stiffness=-1.0, forcing_amplitude=2.0)]
    good, bad = chart_points(DUFFING, points)
    assert _same(good, chart_point(DUFFING, points[0]))
    with pytest.raises(SimulationError) as alone:
        chart_point(DUFFING, points[1])
    assert isinstance(bad, SimulationError) and str(bad) == str(alone.value)
    system = points[1]
    plan = _schedule(DUFFING.plan(system), default_lengths(system.model)[2])
    when = float(re.search(r"t = ([0-9.e+-]+) s", str(bad)).group(1))
    assert when > plan.start * DUFFING.dt


def test_without_a_kernel_the_points_run_one_by_one(monkeypatch):
    """An operation the writer does not know (here: sqrt taken away) means no kernel; the
    points then take the scalar blocks, with the same results."""
    monkeypatch.delitem(lanes.UNARY, "SQRT")
    kernel.cache_clear()
    try:
        model = load_model("vakharia2015")
        from analysis.integrate.tangent import lyapunov_step

        with pytest.raises(Unsupported, match="SQRT"):
            vector_c(lyapunov_step(model, (8,), 1).step, "step")
        assert kernel(model, (8,), 100) is None
        points = [CHART.system_at(n_balls=8, speed_rpm=v) for v in (3000.0, 3100.0)]
        for system, got in zip(points, chart_points(CHART, points), strict=True):
            assert _same(got, chart_point(CHART, system))
    finally:
        kernel.cache_clear()


def test_a_lane_that_blows_up_before_its_tangent_leaves_its_neighbour_alone():
    """A 1 nm clearance and a 100 kN unbalance leave the bounds in the first step, in the
    states-alone part (the state lane kernel): that lane is chart_point's SimulationError,
    word for word, and its neighbour is chart_point's result exactly."""
    from analysis.errors import SimulationError

    points = [CHART.system_at(n_balls=8, speed_rpm=3000.0),
              CHART.system_at(n_balls=8, speed_rpm=3100.0, radial_clearance=1e-9,
                              unbalance_force=1e5)]
    good, bad = chart_points(CHART, points)
    assert _same(good, chart_point(CHART, points[0]))
    with pytest.raises(SimulationError) as alone:
        chart_point(CHART, points[1])
    assert isinstance(bad, SimulationError) and str(bad) == str(alone.value)


def test_the_angle_addition_step_in_lanes_is_its_casadi_block_bit_for_bit():
    """The step of ``Carry.angle_addition`` (not the chart's: see points.ANGLE_ADDITION):
    it differs from rk4_step by rounding only, and its lanes equal its CasADi block bit for
    bit."""
    from analysis.integrate.tangent import angle_addition

    model = load_model("vakharia2015")
    rk4 = model.functions((8,)).rk4_step
    p = model.parameter_vector({**model.defaults, "speed_rpm": 7000.0})
    z = np.array([1.2e-5, 3e-6, 0.004, -0.002])
    for t in (0.0, 0.37, 4.3):
        want, got = (np.asarray(f(t, z, p, 1e-5)).ravel() for f in (rk4, angle_addition(rk4)))
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=0)
    kern = kernel(model, (8,), 100, True)
    assert kern is not None
    block = tangent_block(model, (8,), 1, 100, 2, angle_addition=True)
    start = np.concatenate([z, [12345.0], [1.0, 0, 0, 0]])
    s = np.ascontiguousarray(np.repeat(start[:, None], LANES, axis=1))
    logs, _ = kern.run(s, np.repeat(p[:, None], LANES, axis=1), np.full(LANES, 1e-5),
                       np.zeros(LANES), 2, 100)
    want_s, want_logs = (np.asarray(x).ravel() for x in block(start, p, 1e-5, 0.0)[:2])
    for k in range(LANES):
        assert np.array_equal(s[:, k], want_s) and np.array_equal(logs[:, k], want_logs)
