"""A brute-force diagram of many values draws its structure, not solid bands: its dots shrink
and fade with the density beyond ``DENSE_VALUES`` values (the 20 000-speed diagram of the
Scale page), and keep their size below it (every earlier figure unchanged)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.reports.plots import DENSE_VALUES, diagram_figure, dot_size


def test_dots_keep_their_size_up_to_the_dense_limit_and_shrink_beyond():
    assert dot_size(10) == dot_size(DENSE_VALUES) == (2.0, 0.6)
    sizes = [dot_size(n) for n in (DENSE_VALUES + 1, 4 * DENSE_VALUES, 10**6)]
    assert sizes[1] == (1.0, 0.3)  # the square root of a 4 x density
    assert sizes[0] > sizes[1] > sizes[2] == (0.5, 0.15)


def _diagram(values: int) -> xr.Dataset:
    rpm = np.linspace(1000.0, 2000.0, values)
    points = np.sin(np.outer(rpm, np.arange(4)))[None] * 1e-6
    return xr.Dataset({v: (("direction", "speed_rpm", "k"), points, {"units": "m"})
                       for v in ("x", "y")},
                      coords={"speed_rpm": rpm, "direction": ["up"]},
                      attrs={"param": "speed_rpm", "section": "shaft", "model": "duffing",
                             "state_names": "x y vx vy", "kind": "diagram"})


def test_the_figure_draws_with_the_size_of_its_density():
    for values in (50, 8 * DENSE_VALUES):
        fig = diagram_figure(_diagram(values))
        dots = [line for line in fig.axes[0].get_lines() if len(line.get_xdata())]
        assert (dots[0].get_markersize(), dots[0].get_alpha()) == dot_size(values)
