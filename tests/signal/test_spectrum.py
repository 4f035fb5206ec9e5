"""Amplitude spectrum, peak finding and m·X + n·VC labels against analytic signals."""

from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr
from hypothesis import assume, given
from hypothesis import strategies as st

from analysis.errors import InputError
from analysis.signal.spectrum import (
    Peak,
    amplitude_spectrum,
    find_peaks,
    label_frequency,
    major_peak,
    peak_table,
)

X = 83.3333  # shaft frequency, Hz
VC = 199.34  # varying-compliance frequency, Hz
DT = 1e-5  # s
N = 200_000  # t from 1.0 s to 3.0 s: bin width 0.5 Hz
BIN = 1.0 / (N * DT)
ATTRS = {"shaft_hz": X, "vc_hz": VC, "cage_hz": 33.2234, "n_balls": 6, "model": "synthetic"}

# (frequency Hz, amplitude m, label); X sits 1/3 bin and VC+X 0.35 bin off the bin grid.
LINES = [(X, 3e-6, "X"), (VC - X, 1e-6, "VC-X"), (VC + X, 2e-7, "VC+X")]


@pytest.fixture(scope="module")
def ds() -> xr.Dataset:
    t = 1.0 + DT * np.arange(N)
    x = (3e-6 * np.sin(2 * np.pi * X * t) + 1e-6 * np.cos(2 * np.pi * (VC - X) * t)
         + 2e-7 * np.sin(2 * np.pi * (VC + X) * t) + 1e-5)
    y = 5e-7 * np.cos(2 * np.pi * 2 * X * t)
    return xr.Dataset(
        {"x": ("t", x, {"units": "m"}), "y": ("t", y, {"units": "m"}),
         "vx": ("t", np.gradient(x, DT), {"units": "m/s"})},
        coords={"t": ("t", t, {"units": "s"})},
        attrs=ATTRS,
    )


def test_bins_fall_between_lines():
    offsets = [abs(f / BIN - round(f / BIN)) for f, _, _ in LINES]
    assert max(offsets) > 0.3  # the scalloping case is really exercised


def test_amplitude_spectrum_coordinates_units_and_attrs(ds):
    spectrum = amplitude_spectrum(ds, "x")
    assert spectrum.name == "x_amplitude"
    assert spectrum.attrs["units"] == "m"
    assert spectrum.attrs["model"] == "synthetic"
    assert spectrum["frequency"].attrs["units"] == "Hz"
    assert spectrum.sizes["frequency"] == N // 2 + 1
    np.testing.assert_allclose(spectrum["frequency"].values[1], 0.5, rtol=1e-12)
    assert amplitude_spectrum(ds, "vx").attrs["units"] == "m/s"


def test_on_bin_sinusoid_has_its_amplitude():
    t = 1.0 + DT * np.arange(N)
    on_bin = 200 * BIN  # 100 Hz
    ds = xr.Dataset({"x": ("t", 4e-6 * np.cos(2 * np.pi * on_bin * t + 0.3))}, coords={"t": t})
    spectrum = amplitude_spectrum(ds, "x")
    assert float(spectrum.max()) == pytest.approx(4e-6, rel=1e-9)
    assert float(spectrum.idxmax("frequency")) == pytest.approx(100.0)


def test_peaks_found_labelled_and_measured(ds):
    peaks = find_peaks(ds, "x")
    assert [p.label for p in peaks] == ["X", "VC-X", "VC+X"]  # descending amplitude
    for peak, (frequency, amplitude, label) in zip(peaks, LINES, strict=True):
        assert (peak.direction, peak.label) == ("x", label)
        assert abs(peak.frequency_hz - frequency) < BIN
        assert peak.amplitude == pytest.approx(amplitude, rel=0.02)
        assert (peak.label, peak.shaft_order, peak.vc_order) == label_frequency(
            frequency, X, VC, 1.5 * BIN)
    # The 1e-5 m offset is five times the largest line but is not reported.
    assert all(p.frequency_hz > 1.0 for p in peaks)


def test_max_peaks_and_relative_height(ds):
    assert [p.label for p in find_peaks(ds, "x", max_peaks=2)] == ["X", "VC-X"]
    # VC+X is 2e-7 / 3e-6 = 6.7 % of the largest line.
    assert [p.label for p in find_peaks(ds, "x", min_relative_height=0.1)] == ["X", "VC-X"]


def test_peak_table_major_peak_and_as_dict(ds):
    table = peak_table(ds, max_peaks=3)
    assert [(p.direction, p.label) for p in table] == [
        ("x", "X"), ("x", "VC-X"), ("x", "VC+X"), ("y", "2X")]
    top = major_peak(ds, "y")
    assert top.label == "2X"
    assert top.amplitude == pytest.approx(5e-7, rel=0.02)
    assert top.as_dict() == {"direction": "y", "frequency_hz": top.frequency_hz,
                             "amplitude": top.amplitude, "label": "2X", "shaft_order": 2,
                             "vc_order": 0}
    assert isinstance(top, Peak)


def test_constant_signal_has_no_peak(ds):
    flat = ds.assign(y=ds["x"] * 0 + 2e-6)
    assert find_peaks(flat, "y") == []
    with pytest.raises(InputError, match="y"):
        major_peak(flat, "y")


@pytest.mark.parametrize(
    ("f_hz", "expected"),
    [
        (X, ("X", 1, 0)),
        (2 * X + 0.3, ("2X", 2, 0)),
        (3 * X, ("3X", 3, 0)),
        (VC - 0.4, ("VC", 0, 1)),
        (2 * VC, ("2VC", 0, 2)),
        (VC - X, ("VC-X", -1, 1)),
        (VC + X, ("VC+X", 1, 1)),
        (VC - 2 * X, ("VC-2X", -2, 1)),  # 32.6734 Hz
        (2 * VC + X, ("2VC+X", 1, 2)),
        (3 * VC - 4 * X, ("3VC-4X", -4, 3)),
        (50.0, None),  # nearest: VC-2X = 32.67 Hz, 2VC-4X = 65.35 Hz
        (0.2, None),  # no zero or negative combination ("-X" does not exist)
        (3 * X - VC, None),  # 50.66 Hz would need n = -1
    ],
)
def test_label_frequency_by_hand(f_hz, expected):
    assert label_frequency(f_hz, X, VC, tol_hz=0.75) == expected


def test_label_frequency_prefers_lowest_order_then_distance():
    # X = 100, VC = 301: 3X (300 Hz) is closer to 300.2 Hz, but VC has order 1.
    assert label_frequency(300.2, 100.0, 301.0, tol_hz=2.0) == ("VC", 0, 1)
    # X = 100, VC = 300.5: 2X (200) and VC-X (200.5) both order 2; VC-X is closer.
    assert label_frequency(200.3, 100.0, 300.5, tol_hz=2.0) == ("VC-X", -1, 1)
    assert label_frequency(200.2, 100.0, 300.5, tol_hz=2.0) == ("2X", 2, 0)
    # Orders beyond the limits are not candidates.
    assert label_frequency(5 * 100.0, 100.0, 301.0, tol_hz=0.5) is None
    assert label_frequency(5 * 100.0, 100.0, 301.0, tol_hz=0.5, max_shaft_order=5) == (
        "5X", 5, 0)


_LABEL = re.compile(r"^(?:(\d*)VC)?(?:([+-]?)(\d*)X)?$")


def _parse(label: str) -> tuple[int, int]:
    """(m, n) read back from a label such as "2VC-X"."""
    match = _LABEL.match(label)
    assert match and label
    vc_part = "VC" in label
    n = int(match.group(1) or 1) if vc_part else 0
    m = 0
    if "X" in label:
        m = int(match.group(3) or 1) * (-1 if match.group(2) == "-" else 1)
    return m, n


def _min_separation(ratio: float) -> float:
    """min |Δm + Δn·ratio| over the differences of two distinct candidate combinations."""
    return min(abs(dm + dn * ratio) for dm in range(-8, 9) for dn in range(-3, 4)
               if (dm, dn) != (0, 0))


@given(m=st.integers(-4, 4), n=st.integers(0, 3), shaft_hz=st.floats(20.0, 200.0),
       ratio=st.floats(1.2, 4.8))
def test_label_frequency_recovers_combination(m, n, shaft_hz, ratio):
    # Combinations are distinct by more than 0.04·X when the VC/X ratio stays clear of the
    # rationals p/q with |p| <= 8, q <= 3; then, with tol = 0.01·X, the label is unique.
    assume(_min_separation(ratio) > 0.04)
    vc_hz = ratio * shaft_hz
    f_hz = m * shaft_hz + n * vc_hz
    assume(f_hz > 0)
    result = label_frequency(f_hz, shaft_hz, vc_hz, tol_hz=0.01 * shaft_hz)
    assert result is not None
    label, m_found, n_found = result
    assert (m_found, n_found) == (m, n)
    assert _parse(label) == (m, n)


@given(m=st.integers(1, 4), n=st.integers(0, 3), shaft_hz=st.floats(20.0, 200.0),
       ratio=st.floats(0.5, 6.0), tol_frac=st.floats(0.0, 0.2))
def test_label_frequency_any_ratio_returns_a_valid_alias(m, n, shaft_hz, ratio, tol_frac):
    # Without the separation, a lower-order alias may win, but it must be a real candidate.
    vc_hz = ratio * shaft_hz
    tol = tol_frac * shaft_hz
    f_hz = m * shaft_hz + n * vc_hz
    result = label_frequency(f_hz, shaft_hz, vc_hz, tol_hz=tol)
    assert result is not None
    label, m_found, n_found = result
    assert abs(m_found) + n_found <= m + n
    assert abs(m_found) <= 4 and 0 <= n_found <= 3
    combination = m_found * shaft_hz + n_found * vc_hz
    assert combination > 0
    assert abs(combination - f_hz) <= tol * (1 + 1e-12) + 1e-9
    assert _parse(label) == (m_found, n_found)

