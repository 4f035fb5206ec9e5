"""The paper's case end to end: frequencies from Table 1, and the spectrum of a real run."""

from __future__ import annotations

import pytest

from analysis.integrate.simulate import simulate
from analysis.model import load_model
from analysis.signal.spectrum import find_peaks

# Table 1 of the paper, by hand: r = D_i/2, R = D_o/2, Eq. 1 ω_cage = ω r/(R + r)
D_I, D_O = 18.738e-3, 28.262e-3
X_HZ = 5000 / 60


@pytest.mark.parametrize("n_balls", [5, 6, 7, 8, 9, 10, 12])
def test_characteristic_frequencies(n_balls):
    f = load_model("vakharia2015").frequencies(n_balls)
    assert f.shaft_hz == pytest.approx(83.333333, rel=1e-7)
    assert f.vc_hz == pytest.approx(n_balls * X_HZ * (D_I / 2) / (D_I / 2 + D_O / 2), rel=1e-12)
    if n_balls == 6:
        assert f.vc_hz == pytest.approx(199.3, abs=0.05)  # the paper's "VC (= 199 Hz)"


def test_simulated_spectrum_finds_vc_and_vc_minus_x():
    ds = simulate("vakharia2015", 6, duration=2.0, transient=1.0)
    bin_hz = 1.0 / (float(ds.t[-1] - ds.t[0]) + float(ds.t[1] - ds.t[0]))
    vc, x = ds.attrs["vc_hz"], ds.attrs["shaft_hz"]
    found = {p.label: p.frequency_hz for p in find_peaks(ds, "x") + find_peaks(ds, "y")}
    assert abs(found["VC"] - vc) <= bin_hz
    assert abs(found["VC-X"] - (vc - x)) <= bin_hz
    assert abs(found["X"] - x) <= bin_hz
