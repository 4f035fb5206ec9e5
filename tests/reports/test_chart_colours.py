"""Chart classes have colours that stay distinct for colour-blind readers, and the legend
sits outside the cells (issue 32, section 4)."""

from __future__ import annotations

import itertools

import numpy as np
import xarray as xr

from analysis.reports.plots import chart_figure
from analysis.stability.classify import NATURE_COLORS

# Machado, Oliveira and Fernandes (2009), severity 1, on linear RGB
CVD = {
    "normal": np.eye(3),
    "protanopia": np.array([[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216],
                            [-0.003882, -0.048116, 1.051998]]),
    "deuteranopia": np.array([[0.367322, 0.860646, -0.227968],
                              [0.280085, 0.672501, 0.047413],
                              [-0.011820, 0.042940, 0.968881]]),
    "tritanopia": np.array([[1.255528, -0.076749, -0.178779], [-0.078411, 0.930809, 0.147602],
                            [0.004733, 0.691367, 0.303900]]),
}
MIN_DELTA_E = 12.0
"""Smallest CIE76 difference between two classes' colours under every vision (about 2.3 is a
just-noticeable difference; 12 tells two chart cells apart at a glance)."""


def _lab(hex_colour: str, matrix: np.ndarray) -> np.ndarray:
    srgb = np.array([int(hex_colour[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    linear = np.clip(matrix @ linear, 0, 1)
    xyz = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                    [0.0193, 0.1192, 0.9505]]) @ linear / np.array([0.9505, 1.0, 1.089])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def test_every_two_classes_stay_apart_under_every_vision():
    worst = {}
    for vision, matrix in CVD.items():
        for (a, ca), (b, cb) in itertools.combinations(NATURE_COLORS.items(), 2):
            delta = float(np.linalg.norm(_lab(ca, matrix) - _lab(cb, matrix)))
            worst[vision] = min(worst.get(vision, np.inf), delta)
            assert delta >= MIN_DELTA_E, (vision, a, b, delta)
    assert set(worst) == set(CVD)


def test_the_old_palette_would_fail():  # the measure can fail: grey and teal were too close
    failed, periodic_1 = "#9e9e9e", "#2a9d8f"
    delta = np.linalg.norm(_lab(failed, CVD["protanopia"]) - _lab(periodic_1, CVD["protanopia"]))
    assert delta < MIN_DELTA_E


def _chart() -> xr.Dataset:
    speeds, loads = np.linspace(3000, 9000, 7), np.linspace(2.0, 12.0, 6)
    codes = np.arange(42).reshape(6, 7) % 6
    return xr.Dataset({"nature_code": (("radial_load", "speed_rpm"), codes),
                       "lyapunov": (("radial_load", "speed_rpm"), np.linspace(-50, 20, 42)
                                    .reshape(6, 7))},
                      coords={"speed_rpm": ("speed_rpm", speeds, {"units": "rpm"}),
                              "radial_load": ("radial_load", loads, {"units": "N"})},
                      attrs={"x": "speed_rpm", "y": "radial_load", "model": "vakharia2015"})


def test_the_legend_is_outside_the_cells():
    fig = chart_figure(_chart())
    fig.canvas.draw()
    ax = fig.axes[0]
    legend = ax.get_legend()
    assert legend is not None and len(legend.get_texts()) == 6
    box, cells = legend.get_window_extent(), ax.get_window_extent()
    assert box.y1 <= cells.y0 or box.x0 >= cells.x1, (box, cells)
