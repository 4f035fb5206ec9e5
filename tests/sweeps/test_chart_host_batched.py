"""The chart's host side batched across points: ``points.chart_grid_points`` plans a group's
grid points as arrays (``_grid_batch``: one parameter matrix, one evaluation of the
frequencies, no System per point) and gives the rows of the per-point path
(``chart_points`` of ``setting.system_at`` Systems) bit for bit; ``classes.graph_ratios``
taken one component at a time equals its direct form and ``classify.graph_ratio``."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.stability.classify import classify_section, graph_ratio
from analysis.sweeps import classes
from analysis.sweeps import points as chart
from analysis.sweeps.grid import Setting

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
ROTOR = Setting("balanced-rotor", None, {"radial_load": 50.0}, transient=0.3, samples=40,
                lyapunov=True)
SHAFT = Setting("vakharia2015", "shaft", {"unbalance_force": 20.0}, transient=0.3,
                samples=40, lyapunov=True)
DUFFING = Setting("duffing", None, {"linear_stiffness": 1.0, "damping": 0.2},
                  transient=5.0, samples=30, lyapunov=True, dt=0.01)
"""Softening Duffing escapes its well at the larger forcing (a failed point)."""
SPEEDS = ("speed_rpm", "n_balls")


def _identical(a, b) -> bool:
    if isinstance(a, SimulationError) or isinstance(b, SimulationError):
        return type(a) is type(b) and str(a) == str(b)
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
        for k in a)


def _per_point(setting: Setting, names: tuple[str, ...], values: list[tuple]) -> list:
    systems = [setting.system_at(**dict(zip(names, row, strict=True))) for row in values]
    return chart.chart_points(setting, systems)


@pytest.mark.parametrize(("setting", "names", "values"), [
    (CHART, SPEEDS, [(v, 8.0) for v in (2000.0, 4000.0, 6100.0, 9000.0)]),
    (CHART, SPEEDS, [(v, 11.0) for v in (3000.0, 3050.0, 8000.0)]),
    (ROTOR, SPEEDS, [(v, 5.0) for v in (3000.0, 8000.0)]),
    (SHAFT, SPEEDS, [(v, 9.0) for v in (3000.0, 7000.0)]),
    (SHAFT, ("n_balls", "unbalance_force"), [(7.0, f) for f in (0.0, 5.0, 20.0)]),
    (DUFFING, ("cubic_stiffness", "forcing_amplitude"),
     [(1.0, 0.3), (-1.0, 2.0), (0.5, 0.3)]),
])
def test_batched_rows_equal_the_per_point_path(setting, names, values):
    """Varied speeds, balls, sections (the model's own, shaft with the graph ratio, an
    unbalance axis that switches it off) and a point that blows up: every field equal,
    not approximately, and the arrays did plan the points (no per-point fallback)."""
    assert chart._grid_batch(setting, names, values) is not None
    got = chart.chart_grid_points(setting, names, values)
    want = _per_point(setting, names, values)
    assert all(map(_identical, got, want)), (got, want)
    if setting is DUFFING:
        assert isinstance(got[1], SimulationError) and isinstance(got[0], dict)


@pytest.mark.parametrize("setting", [CHART, ROTOR, SHAFT])
def test_batch_plan_equals_the_points_planned_one_by_one(setting):
    """The arrays' periods, steps and schedules equal those of ``_kernel_point`` at 300
    speeds of each balls (no kernel call): the same float operations."""
    for balls in (5.0, 8.0, 12.0):
        values = [(v, balls) for v in np.linspace(1000.0, 10000.0, 300).tolist()]
        batch = chart._grid_batch(setting, SPEEDS, values)
        systems = [setting.system_at(speed_rpm=v, n_balls=balls) for v, _ in values]
        points = [chart._kernel_point(s, setting.seconds(s), setting.transient,
                                      setting.step(), setting.section,
                                      full_check=i in (0, len(systems) - 1))
                  for i, s in enumerate(systems)]
        one_by_one = chart._Batch.of(points)
        for name in ("p", "period", "h", "every", "first", "count", "skip", "averaged",
                     "steps_from", "steps_to", "graph", "vc_hz"):
            a, b = getattr(batch, name), getattr(one_by_one, name)
            assert a.dtype.kind == b.dtype.kind and np.array_equal(a, b), name
        assert batch.shown == one_by_one.shown
        schedules = (batch.schedule(), one_by_one.schedule())
        assert all(np.array_equal(*(s.counts(f) for s in schedules)) for f in (
            "transient_steps", "steps_per_section", "n_sections", "lyapunov_skip",
            "extremes_from", "extremes_to"))


def test_what_the_arrays_cannot_plan_goes_point_by_point():
    """An axis over the balls' fit is planned one System at a time; a record too short
    for λ1's batches is refused with the per-point path's own message."""
    values = [(0.0046, 8.0), (0.0049, 8.0)]
    names = ("ball_diameter", "n_balls")
    assert chart._grid_batch(CHART, names, values) is None
    assert all(map(_identical, chart.chart_grid_points(CHART, names, values),
                   _per_point(CHART, names, values)))
    short = Setting("vakharia2015", None, {}, transient=0.3, samples=2, lyapunov=True)
    speeds = [(3000.0, 8.0), (4000.0, 8.0)]
    assert chart._grid_batch(short, SPEEDS, speeds) is None
    with pytest.raises(InputError) as batched:
        chart.chart_grid_points(short, SPEEDS, speeds)
    with pytest.raises(InputError) as per_point:
        _per_point(short, SPEEDS, speeds)
    assert str(batched.value) == str(per_point.value)
    outside = [(3000.0, 8.0), (-1.0, 8.0), (-2.0, 8.0)]  # the first refused is the middle
    with pytest.raises(InputError) as batched:
        chart.chart_grid_points(CHART, SPEEDS, outside)
    with pytest.raises(InputError) as per_point:
        _per_point(CHART, SPEEDS, outside)
    assert str(batched.value) == str(per_point.value) and "-1" in str(batched.value)


@pytest.mark.parametrize(("count", "n"), [(48, 4), (49, 4), (201, 4), (31, 2), (40, 6),
                                          (40, 8), (3, 4)])
def test_graph_ratios_by_component_equal_the_direct_form(monkeypatch, count, n):
    """Scattered, toroidal and repeated points at scales 1e-6-1e3, a row with a NaN and a
    row at one point: the ratios by component equal the direct form's and
    ``classify.graph_ratio``'s, bit for bit (odd and even counts, n below and at 8)."""
    rng = np.random.default_rng(count * 10 + n)
    m = 300
    points = rng.normal(size=(m, count, n)) * rng.choice([1e-6, 1.0, 1e3], size=(m, 1, n))
    k = np.arange(count)[None, :, None]
    points[::3] = np.cos(0.37 * k + np.arange(n)) * rng.uniform(1e-6, 1.0, (m, 1, 1))[::3]
    points[5, count // 2, 0] = np.nan
    points[7] = 1.0
    phase = rng.random((m, count))
    got = classes.graph_ratios(points, phase)
    monkeypatch.setattr(classes, "_sums_in_order", lambda n: False)
    direct = classes.graph_ratios(points, phase)
    assert np.array_equal(got, direct, equal_nan=True)
    for row in range(0, m, 7):
        assert np.array_equal(got[row], graph_ratio(points[row], phase[row]), equal_nan=True)
    assert np.isnan(got[5])


def test_classes_with_a_tilt_equal_classify_section():
    """Positions of two units (a tilt in rad beside x, y in m: rescaled to the orbit
    size), velocities over the section's ω: class, period and graph ratio equal
    ``classify_section``'s on 120 made-up sections."""
    rng = np.random.default_rng(11)
    names = ("x", "y", "tx", "vx", "vy", "vtx")
    units = {"x": "m", "y": "m", "tx": "rad", "vx": "m/s", "vy": "m/s", "vtx": "rad/s"}
    m, count = 120, 40
    k = np.arange(count)[:, None]
    sections = np.stack([
        (np.cos(0.3 * k + np.arange(6)) if i % 3 == 0 else
         np.tile(rng.normal(size=(1 + i % 4, 6)), (count, 1))[:count] if i % 3 == 1 else
         rng.normal(size=(count, 6))) * [1e-5, 1e-5, 1e-3, 1e-2, 1e-2, 1.0]
        for i in range(m)])
    ptp = np.ptp(sections, axis=1)
    period = 1.0 / rng.uniform(20.0, 200.0, m)
    times = (0.0 + np.arange(5, 5 + count)) * period[:, None]
    vc_hz = rng.uniform(5.0, 80.0, m)
    lam, ci = rng.normal(0.0, 30.0, m), rng.uniform(0.1, 4.0, m)
    graph = np.ones(m, dtype=bool)
    natures, periods, ratios = classes.chart_classes(sections, ptp, names, units, period,
                                                     times, graph, vc_hz, lam, ci)
    for i in range(m):
        attrs = {"section": "shaft", "section_period_s": period[i],
                 "state_names": " ".join(names), "unbalance_force": 20.0, "vc_hz": vc_hz[i]}
        pts = xr.Dataset({v: ("k", sections[i, :, c], {"units": units[v]})
                          for c, v in enumerate(names)},
                         coords={"t": ("k", times[i])}, attrs=attrs)
        got = classify_section(pts, dict(zip(names, ptp[i].tolist(), strict=True)),
                               lambda i=i: (float(lam[i]), float(ci[i])))
        assert (natures[i], periods[i]) == (got.nature, got.period or 0), i
        assert (ratios[i] == got.graph_ratio if got.graph_ratio is not None
                else np.isnan(ratios[i])), i
