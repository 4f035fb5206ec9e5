"""Order lines within a bin of a combination are named honestly (issue 32, section 4): a
peak off its named line by more than half a bin says "within a bin of", with the line's own
order; other names within the tolerance are given too."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.signal.orders import OrderPeak, order_peaks

SHAFT, VC = 100.0, 318.9  # VC + 2X = 5.189 orders


def _spectrum(peak_orders: list[float], step: float) -> xr.DataArray:
    order = np.arange(0, 12, step)
    values = np.full(order.size, 1e-12)
    for where in peak_orders:
        values += 1e-7 * np.exp(-0.5 * ((order - where) / (0.6 * step)) ** 2)
    return xr.DataArray(values, dims="order", coords={"order": order},
                        attrs={"order_bin": step, "shaft_hz": SHAFT, "vc_hz": VC})


def test_a_peak_off_its_line_says_within_a_bin():
    step = 0.008
    peaks = order_peaks(_spectrum([5.184], step), max_peaks=1)
    (peak,) = peaks
    assert peak.name == "VC+2X"
    assert abs(peak.named_order - 5.189) < 1e-9
    assert not peak.in_its_bin
    assert peak.text == "within a bin of VC+2X (5.189)"
    assert peak.as_dict()["in_its_bin"] is False


def test_a_peak_on_its_line_keeps_the_plain_name():
    step = 0.008
    (peak,) = order_peaks(_spectrum([5.189], step), max_peaks=1)
    assert peak.in_its_bin and peak.text == "VC+2X"


def test_other_names_within_the_tolerance_are_given():
    peak = OrderPeak(5.188, 1e-7, "VC+2X", 5.189, 0.008, ("BPFI+X",))
    assert peak.text == "VC+2X or BPFI+X"
    assert OrderPeak(3.3, 1e-7, None).text == ""
