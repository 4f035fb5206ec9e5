"""A figure's PNG carries every parameter value, as the .nc does (issue 32, section 4)."""

from __future__ import annotations

import numpy as np
from PIL import Image

from analysis import simulate
from analysis.reports.plots import save_figure, spectrum_figure


def test_the_png_holds_every_scalar_attribute_of_the_run(tmp_path):
    ds = simulate("vakharia2015", n_balls=7, duration=0.05, transient=0.0,
                  speed_rpm=6123.5, damping=187.25)
    path = tmp_path / "spectrum.png"
    save_figure(spectrum_figure(ds), path)
    text = Image.open(path).text
    checked = 0
    for key, value in ds.attrs.items():
        if isinstance(value, str):
            assert text[key] == value, key
        elif np.ndim(value) == 0:
            assert float(text[key]) == float(value), key  # every digit kept
        checked += 1
    assert checked >= 30
    assert float(text["speed_rpm"]) == 6123.5 and float(text["damping"]) == 187.25
    assert text["n_balls"] == "7"
