"""The chart's host side after the member kernels: ``chart_points`` classifies each point on
a ``SectionView`` of its section arrays (no Dataset), with results identical to the
Dataset path (``kernel_points(datasets=True)``, ``chart_row`` of each)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.sweeps import points as chart
from analysis.sweeps.grid import Setting

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
ROTOR = Setting("balanced-rotor", None, {"radial_load": 50.0}, transient=0.3, samples=40,
                lyapunov=True)


def _identical(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(
        a[k] == b[k] or (isinstance(a[k], float) and np.isnan(a[k]) and np.isnan(b[k]))
        for k in a)


def test_section_view_gives_the_dataset_path_results(monkeypatch):
    """Same kernel output (one ``run_members`` call, replayed) through both host paths:
    every field equal, not approximately."""
    real, seen = chart.run_members, {}

    def replay(*args, **kwargs):
        key = len(args[1])
        if key not in seen:
            seen[key] = real(*args, **kwargs)
        return seen[key]

    monkeypatch.setattr(chart, "run_members", replay)
    for setting, n_balls, speeds in ((CHART, 8, (2000.0, 4000.0, 6100.0, 9000.0)),
                                     (ROTOR, 8, (3000.0, 8000.0))):
        seen.clear()
        systems = [setting.system_at(n_balls=n_balls, speed_rpm=v) for v in speeds]
        durations = [setting.seconds(s) for s in systems]
        args = (systems, durations, setting.transient, setting.step(), setting.section)
        light = chart.kernel_points(*args, datasets=False)
        full = chart.kernel_points(*args)
        assert all(isinstance(p.points, chart.SectionView) for p in light)
        assert all(isinstance(p.points, xr.Dataset) for p in full)
        rows = chart.chart_points(setting, systems)
        for a, b, row in zip(light, full, rows, strict=True):
            assert _identical(chart.chart_row(a), chart.chart_row(b))
            assert _identical(row, chart.chart_row(b))
            assert a.classification == b.classification
            view = a.points
            for name in b.points.data_vars:
                assert np.array_equal(view[name].values, b.points[name].values)
                assert view[name].attrs["units"] == b.points[name].attrs["units"]
            assert np.array_equal(view.t.values, b.points.t.values)
            assert view.attrs == b.points.attrs
