"""The Bode and polar plots mark where the response is not periodic (issue 32, section 4):
there the 1X amplitude and phase are one line of a broad spectrum, not the response."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.reports.bode_plots import NOT_PERIODIC, bode_figure, periodic_values, polar_figure

SPEEDS = np.linspace(4000, 8000, 9)
CHAOTIC = {5, 6}  # the indices whose section samples never repeat


def _diagram() -> xr.Dataset:
    rng = np.random.default_rng(1)
    k = 40
    x = np.zeros((1, SPEEDS.size, k))
    y = np.zeros((1, SPEEDS.size, k))
    for i in range(SPEEDS.size):
        if i in CHAOTIC:
            x[0, i], y[0, i] = 1e-5 * rng.standard_normal((2, k))
        elif i == 2:  # period 2
            x[0, i] = 1e-5 * np.tile([1.0, -0.5], k // 2)
            y[0, i] = 2e-6
        else:  # period 1
            x[0, i], y[0, i] = 3e-6, -1e-6
    amp = (2e-6 + 1e-6 * np.sin(SPEEDS / 1000))[None, :]
    lag = np.linspace(0.1, 2.0, SPEEDS.size)[None, :]
    return xr.Dataset(
        {"x": (("direction", "speed_rpm", "k"), x, {"units": "m"}),
         "y": (("direction", "speed_rpm", "k"), y, {"units": "m"}),
         "amplitude1x_x": (("direction", "speed_rpm"), amp, {"units": "m"}),
         "phase1x_x": (("direction", "speed_rpm"), lag, {"units": "rad"})},
        coords={"direction": ["up"], "speed_rpm": ("speed_rpm", SPEEDS, {"units": "rpm"}),
                "k": np.arange(k)},
        attrs={"kind": "diagram", "param": "speed_rpm", "model": "vakharia2015",
               "n_balls": 8})


def test_periodic_values_finds_the_chaotic_stretch():
    periodic = periodic_values(_diagram(), 0)
    assert [i for i, p in enumerate(periodic) if not p] == sorted(CHAOTIC)


def test_bode_and_polar_ring_the_values_that_are_not_periodic():
    fig = bode_figure(_diagram())
    top = fig.axes[0]
    rings = [line for line in top.get_lines() if line.get_label() == NOT_PERIODIC]
    assert len(rings) == 1
    assert sorted(rings[0].get_xdata()) == sorted(SPEEDS[list(CHAOTIC)])
    assert NOT_PERIODIC in [t.get_text() for t in top.get_legend().get_texts()]
    polar = polar_figure(_diagram())
    marked = [line for ax in polar.axes for line in ax.get_lines()
              if line.get_label() == NOT_PERIODIC]
    assert len(marked) == 1 and len(marked[0].get_xdata()) == len(CHAOTIC)
