"""hb and continue plot displacements in µm like every other figure (issue 32, section 4)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.cli.frequency import response_figure
from analysis.reports.plots import branch_figure


def _ticks(ax) -> list[float]:
    ax.figure.canvas.draw()
    return [float(t.get_text().replace("−", "-")) for t in ax.get_yticklabels()
            if t.get_text()]


def test_hb_response_is_in_micrometres():
    lam = np.linspace(4000, 6000, 5)
    amp = np.linspace(2e-6, 8e-6, 5)[:, None]
    data = xr.Dataset({"amplitude": (("point", "state"), amp),
                       "stable": ("point", np.array([1, 1, 0, 0, 1])),
                       "special": ("point", np.array(["", "", "LP", "", ""], dtype=object)),
                       "state": ("state", ["x"]), "state_units": ("state", ["m"]),
                       "speed_rpm": ("point", lam, {"units": "rpm"})},
                      attrs={"param": "speed_rpm", "model": "vakharia2015", "period": "T",
                             "harmonics": 8})
    ax = response_figure(data).axes[0]
    assert "(µm)" in ax.get_ylabel()
    ticks = _ticks(ax)
    assert 1.0 <= max(ticks) <= 20.0, ticks  # µm numbers, not 1e-6 m


def test_continue_branch_is_in_micrometres():
    lam = np.linspace(4000, 6000, 5)
    branch = xr.Dataset({"amplitude": ("point", np.linspace(2e-6, 8e-6, 5)),
                         "stable": ("point", np.array([True, True, False, False, True])),
                         "special": ("point", np.array(["", "", "PD", "", ""], dtype=object)),
                         "speed_rpm": ("point", lam, {"units": "rpm"})},
                        attrs={"param": "speed_rpm", "model": "vakharia2015", "period": "T"})
    ax = branch_figure([branch]).axes[0]
    assert "(µm)" in ax.get_ylabel()
    assert 1.0 <= max(_ticks(ax)) <= 20.0
