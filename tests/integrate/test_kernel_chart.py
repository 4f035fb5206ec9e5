"""Chart points on the member kernels (``points.chart_points`` → ``kernel_points``) against
the one-pass point (``points.chart_point``, interpolated sections at h = dt): non-chaotic
points keep their class and λ1 within its interval; blow-ups are the point's own; without a
CPU build the points run one by one, as ``chart_point``."""

from __future__ import annotations

import re

import numpy as np
import pytest

from analysis.errors import SimulationError
from analysis.integrate.kernels import cpu, members, section_step, source
from analysis.model import as_system
from analysis.sweeps.grid import Setting
from analysis.sweeps.points import chart_point, chart_points

CALM = {"radial_load": 50.0}
CASES = [  # (model, N_b, values, nature)
    ("balanced-rotor", 8, {**CALM, "speed_rpm": 3000.0}, "periodic-1"),
    ("vakharia2015", 8, {**CALM, "speed_rpm": 3000.0}, "quasi-periodic"),
]
DUFFING = Setting("duffing", None, {"linear_stiffness": 1.0, "damping": 0.2,
                                    "forcing_amplitude": 0.3},
                  transient=5.0, samples=30, lyapunov=True, dt=0.01)
CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
        for k in a)


@pytest.mark.parametrize(("model", "n_balls", "values", "nature"), CASES)
def test_non_chaotic_points_keep_class_and_lambda_within_interval(model, n_balls, values,
                                                                   nature):
    setting = Setting(model, None, {}, transient=0.5, samples=40, lyapunov=True)
    system = as_system(model, n_balls, None, **values)
    old = chart_point(setting, system)
    new = chart_points(setting, [system])[0]
    assert old["nature"] == new["nature"] == nature
    assert old["period"] == new["period"]
    assert abs(new["lyapunov"] - old["lyapunov"]) <= old["ci95"]
    for key in (k for k in old if k.startswith("amplitude_")):
        assert new[key] == pytest.approx(old[key], rel=1e-4), key


def test_a_point_does_not_depend_on_the_points_beside_it():
    speeds = (2000.0, 4000.0, 6100.0)
    points = [CHART.system_at(n_balls=8, speed_rpm=v) for v in speeds]
    together = chart_points(CHART, points)
    for system, got in zip(points, together, strict=True):
        assert _same(got, chart_points(CHART, [system])[0])


def test_a_point_that_blows_up_leaves_its_neighbour_alone():
    """Softening Duffing escapes its well at the larger forcing: that point is a
    ``SimulationError`` saying when, after the transient's start; the other is its own
    result alone."""
    points = [DUFFING.system_at(cubic_stiffness=1.0),
              DUFFING.system_at(cubic_stiffness=-1.0, forcing_amplitude=2.0)]
    good, bad = chart_points(DUFFING, points)
    assert _same(good, chart_points(DUFFING, points[:1])[0])
    assert isinstance(bad, SimulationError)
    when = float(re.search(r"t = ([0-9.e+-]+) s", str(bad)).group(1))
    assert 0 < when < DUFFING.seconds(points[1])
    with pytest.raises(SimulationError):
        chart_point(DUFFING, points[1])


def test_without_a_cpu_build_the_points_run_one_by_one(monkeypatch):
    monkeypatch.delitem(source.UNARY, "SQRT")
    cpu.cpu_library.cache_clear()
    members._self_test.cache_clear()
    try:
        points = [CHART.system_at(n_balls=8, speed_rpm=v) for v in (3000.0, 3100.0)]
        for system, got in zip(points, chart_points(CHART, points), strict=True):
            assert _same(got, chart_point(CHART, system))
    finally:
        cpu.cpu_library.cache_clear()
        members._self_test.cache_clear()


def test_section_step_divides_the_period():
    for period, dt in ((1 / 199.0, 1e-5), (0.005, 1e-5), (2 * np.pi / 1.4, 0.01)):
        h, steps = section_step(period, dt)
        assert h <= dt and steps * h == pytest.approx(period, rel=1e-12)
        assert period / (steps - 1) > dt or steps == 1
    assert section_step(0.015, 1e-5) == (1e-5, 1500)  # whole steps: dt itself


def test_section_points_are_poincare_section_of_the_samples():
    """The points built directly equal ``poincare_section`` of the same states as a run
    sampled at t = k·T (values, coordinates and attrs)."""
    import xarray as xr

    from analysis.provenance import to_dataset
    from analysis.signal.poincare import poincare_section
    from analysis.sweeps import points as P

    setting = Setting("vakharia2015", None, {}, transient=0.1, samples=20, lyapunov=True)
    for speed in (3000.0, 4321.0):
        system = setting.system_at(n_balls=8, speed_rpm=speed)
        point = P._kernel_point(system, setting.seconds(system), setting.transient,
                                setting.step(), None)
        states = np.random.default_rng(0).standard_normal((point.count, 4))
        times = (0.0 + np.arange(point.first, point.first + point.count)) * point.period
        want = poincare_section(to_dataset(times, states.T, point.attrs, system.model),
                                point.section)
        xr.testing.assert_identical(want, P._section_dataset(point, states))
