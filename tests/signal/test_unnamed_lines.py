"""The strongest unnamed lines of a full spectrum are listed with a word on why they have
no name (issue 32, section 4)."""

from __future__ import annotations

import dataclasses

import numpy as np
import xarray as xr

from analysis.signal.full_spectrum import UNNAMED_WHY, unnamed_lines, unnamed_reason

X, VC = 83.3333, 199.34


def _run(extra_hz: float) -> xr.Dataset:
    t = np.arange(0, 3.0, 1e-4)
    w = 2 * np.pi
    x = 1e-6 * np.cos(w * X * t) + 5e-7 * np.cos(w * VC * t) + 3e-7 * np.cos(w * extra_hz * t)
    y = 1e-6 * np.sin(w * X * t) + 5e-7 * np.sin(w * VC * t) + 3e-7 * np.sin(w * extra_hz * t)
    attrs = {"shaft_hz": X, "vc_hz": VC, "cage_hz": VC / 6, "n_balls": 6, "model": "test",
             "dt": 1e-4}
    return xr.Dataset({"x": ("t", x, {"units": "m"}), "y": ("t", y, {"units": "m"})},
                      coords={"t": t}, attrs=attrs)


def test_an_incommensurate_line_is_listed_with_its_reason():
    ds = _run(140.35)
    lines = unnamed_lines(ds)
    assert lines and abs(lines[0].signed_frequency_hz - 140.35) < 0.2
    assert unnamed_reason(lines[0], ds) == UNNAMED_WHY
    assert all(p.label is None for p in lines)  # X and VC are named, so not listed


def test_a_line_below_the_resolution_says_so():
    ds = _run(140.35)
    (line,) = unnamed_lines(ds, count=1)
    slow = dataclasses.replace(line, frequency_hz=0.4)
    assert "below two bins of the 3 s record" in unnamed_reason(slow, ds)
    assert unnamed_reason(dataclasses.replace(line, label="X"), ds) is None
