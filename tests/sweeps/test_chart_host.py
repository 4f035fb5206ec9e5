"""The chart's host side after the member kernels: ``kernel_points(datasets=False)`` (what
``chart_points`` uses) gives each point's chart row with the class computed with numpy over
the points (``classes.chart_classes``), identical to the Dataset path
(``kernel_points(datasets=True)``, ``chart_row`` of each, ``classify_section``)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.stability.classify import classify_section
from analysis.sweeps import points as chart
from analysis.sweeps.classes import chart_classes
from analysis.sweeps.grid import Setting

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
ROTOR = Setting("balanced-rotor", None, {"radial_load": 50.0}, transient=0.3, samples=40,
                lyapunov=True)
SHAFT = Setting("vakharia2015", "shaft", {"unbalance_force": 20.0}, transient=0.3,
                samples=40, lyapunov=True)


def _identical(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
        for k in a)


@pytest.mark.parametrize(("setting", "speeds"), [
    (CHART, (2000.0, 4000.0, 6100.0, 9000.0)), (ROTOR, (3000.0, 8000.0)),
    (SHAFT, (3000.0, 7000.0))])
def test_rows_equal_the_dataset_path(monkeypatch, setting, speeds):
    """Same kernel output (one ``run_members`` call, replayed) through both host paths:
    every field equal, not approximately."""
    real, seen = chart.run_members, []

    def replay(*args, **kwargs):
        if not seen:
            seen.append(real(*args, **kwargs))
        return seen[0]

    monkeypatch.setattr(chart, "run_members", replay)
    systems = [setting.system_at(n_balls=8, speed_rpm=v) for v in speeds]
    durations = [setting.seconds(s) for s in systems]
    args = (systems, durations, setting.transient, setting.step(), setting.section)
    rows = chart.kernel_points(*args, datasets=False)
    full = chart.kernel_points(*args)
    assert all(isinstance(p, xr.Dataset) for p in (f.points for f in full))
    for row, point in zip(rows, full, strict=True):
        assert _identical(row, chart.chart_row(point)), (row, chart.chart_row(point))
    assert all(map(_identical, rows, chart.chart_points(setting, systems)))


def _sections(rng: np.random.Generator, kind: str, count: int) -> np.ndarray:
    """count × 4 states (x, y, vx, vy; m, m/s) of one made-up section."""
    k = np.arange(count)[:, None]
    if kind.startswith("periodic"):
        n = int(kind.split("-")[1])
        base = rng.normal(size=(n, 4)) * [1e-5, 1e-5, 1e-2, 1e-2]
        noise = rng.choice([0.0, 1e-12, 3e-9, 1e-8])
        return base[k[:, 0] % n] + noise * rng.normal(size=(count, 4))
    if kind == "torus":
        phase = 2 * np.pi * (0.1 + 0.5 * rng.random()) * k
        return np.hstack([np.cos(phase), np.sin(phase), -np.sin(phase), np.cos(phase)]) \
            * [1e-5, 1e-5, 1e-2, 1e-2]
    return rng.normal(size=(count, 4)) * [1e-5, 2e-5, 1e-2, 3e-2]


def test_chart_classes_equal_classify_section_on_varied_sections():
    """Four hundred made-up sections (periodic 1-20 with noise about the tolerance, tori,
    scatter; λ1 on both sides of its interval and of the chaos floor; half of them judged
    by the graph ratio on the shaft section): class, period and graph ratio equal."""
    rng = np.random.default_rng(7)
    count, m = 48, 400
    kinds = [f"periodic-{n}" for n in range(1, 21)] + ["torus", "scatter"]
    sections = np.stack([_sections(rng, kinds[i % len(kinds)], count) for i in range(m)])
    ptp = np.ptp(sections, axis=1) * rng.choice([1.0, 0.5, 2.0], size=(m, 1))
    period = 1.0 / rng.uniform(20.0, 200.0, m)
    times = (0.0 + np.arange(10, 10 + count)) * period[:, None]
    graph = rng.random(m) < 0.5
    vc_hz = rng.uniform(5.0, 80.0, m)
    lam = rng.normal(0.0, 3.0, m) * rng.choice([1.0, 30.0], m)
    ci = rng.uniform(0.1, 4.0, m)
    natures, periods, ratios = chart_classes(sections, ptp, ("x", "y", "vx", "vy"),
                                             dict.fromkeys(("x", "y", "vx", "vy"), "m"),
                                             period, times, graph, vc_hz, lam, ci)
    seen = set()
    for i in range(m):
        attrs = {"section": "shaft" if graph[i] else "vc", "section_period_s": period[i],
                 "state_names": "x y vx vy", "unbalance_force": 20.0, "vc_hz": vc_hz[i]}
        pts = xr.Dataset({v: ("k", sections[i, :, c], {"units": "m"})
                          for c, v in enumerate(("x", "y", "vx", "vy"))},
                         coords={"t": ("k", times[i])}, attrs=attrs)
        got = classify_section(pts, dict(zip(("x", "y", "vx", "vy"), ptp[i].tolist(),
                                              strict=True)),
                               lambda i=i: (float(lam[i]), float(ci[i])))
        assert natures[i] == got.nature, i
        assert periods[i] == (got.period or 0), i
        assert (ratios[i] == got.graph_ratio if got.graph_ratio is not None
                else np.isnan(ratios[i])), i
        seen.add(got.nature if not got.period else "periodic")
        seen.add("ratio" if got.graph_ratio is not None else "no ratio")
    assert seen >= {"periodic", "quasi-periodic", "chaotic", "ratio", "no ratio"}


def test_lambda_over_rows_equals_lambda_point_by_point():
    """λ1 and its interval of many points at once (one interval per row), as the rows take
    them, equal to those of each point alone."""
    from analysis.stability.lyapunov import batch_ci95, running_mean

    rng = np.random.default_rng(1)
    for length in (10, 40, 200):
        logs = rng.normal(size=(100, length)) * rng.choice([1e-3, 1.0, 50.0], (100, 1))
        interval = rng.uniform(1e-3, 0.1, 100)
        lam = running_mean(logs, interval[:, None])[:, -1]
        ci = batch_ci95(logs, interval[:, None])
        for r in range(100):
            assert lam[r] == running_mean(logs[r][None, :], interval[r])[0, -1]
            assert ci[r] == batch_ci95(logs[r][None, :], interval[r])[0]
