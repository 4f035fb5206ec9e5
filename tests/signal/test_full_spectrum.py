"""The full spectrum of x + i·y: forward whirl at positive frequencies, backward at negative,
checked on synthetic whirls whose spectra are known analytically, against a direct FFT
written here, and its lines named as the one-sided spectra name theirs."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError
from analysis.signal.full_spectrum import full_spectrum, full_spectrum_peaks, whirl_components

X_HZ, VC_HZ, DT = 83.3333, 199.34, 1e-4


def _run(x, y, t, **attrs):
    return xr.Dataset({"x": ("t", x, {"units": "m"}), "y": ("t", y, {"units": "m"}),
                       "vx": ("t", np.gradient(x, t), {"units": "m/s"}),
                       "vy": ("t", np.gradient(y, t), {"units": "m/s"})},
                      coords={"t": t}, attrs={"shaft_hz": X_HZ, "vc_hz": VC_HZ,
                                              "state_names": "x y vx vy", **attrs})


def _times(duration=2.4):  # 200 shaft periods: X and VC far from bin edges matter little
    return np.arange(0.0, duration, DT)


@pytest.mark.parametrize("direction", [+1, -1])
def test_a_circular_whirl_is_one_line_on_its_side(direction):
    t = _times()
    r = 3e-6
    ds = _run(r * np.cos(2 * np.pi * X_HZ * t), direction * r * np.sin(2 * np.pi * X_HZ * t), t)
    spectrum = full_spectrum(ds)
    at = spectrum.frequency.values
    here = np.argmin(np.abs(at - direction * X_HZ))
    mirror = np.argmin(np.abs(at + direction * X_HZ))
    # the line's peak bin holds r up to the Hann scalloping (<= 15 %); the mirror nothing
    assert 0.84 * r <= spectrum.values[here - 1:here + 2].max() <= 1.0001 * r
    assert spectrum.values[mirror - 2:mirror + 3].max() < 1e-6 * r
    peaks = full_spectrum_peaks(ds)
    assert [p.whirl for p in peaks] == ["forward" if direction > 0 else "backward"]
    peak = peaks[0]
    assert peak.label == "X"
    assert peak.name == ("X" if direction > 0 else "-X")
    assert peak.signed_frequency_hz == pytest.approx(direction * X_HZ, abs=0.02)
    assert peak.amplitude == pytest.approx(r, rel=1e-3)


def test_an_ellipse_splits_into_half_sum_and_half_difference_of_its_axes():
    """x = a cos ωt, y = b sin ωt is ((a+b)/2) e^{iωt} + ((a−b)/2) e^{−iωt}."""
    t = _times()
    a, b = 4e-6, 1e-6
    ds = _run(a * np.cos(2 * np.pi * X_HZ * t) + 0.8e-6 * np.cos(2 * np.pi * VC_HZ * t),
              b * np.sin(2 * np.pi * X_HZ * t) - 0.8e-6 * np.sin(2 * np.pi * VC_HZ * t), t)
    peaks = {p.name: p for p in full_spectrum_peaks(ds)}
    assert set(peaks) == {"X", "-X", "-VC"}
    assert peaks["X"].amplitude == pytest.approx((a + b) / 2, rel=1e-3)
    assert peaks["-X"].amplitude == pytest.approx((a - b) / 2, rel=1e-3)
    assert peaks["-VC"].amplitude == pytest.approx(0.8e-6, rel=1e-3)
    assert peaks["-VC"].signed_frequency_hz == pytest.approx(-VC_HZ, abs=0.02)
    assert peaks["-VC"].as_dict()["whirl"] == "backward"


def test_the_spectrum_is_the_direct_fft_of_the_windowed_complex_orbit():
    rng = np.random.default_rng(3)
    t = _times(0.5)
    x, y = rng.normal(size=t.size) * 1e-6, rng.normal(size=t.size) * 1e-6
    ds = _run(x, y, t)
    z = (x - x.mean()) + 1j * (y - y.mean())
    n = z.size
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)  # periodic Hann, written here
    j = np.arange(n)
    for f in (-1000.0, -40.0, 0.0, 260.0, 4000.0):  # on the bin grid (df = 2 Hz)
        direct = abs(np.sum(w * z * np.exp(-2j * np.pi * f * j * DT))) / w.sum()
        got = float(full_spectrum(ds).sel(frequency=f, method="nearest"))
        assert got == pytest.approx(direct, rel=1e-9, abs=1e-20)


def test_the_components_add_up_to_the_orbit():
    rng = np.random.default_rng(5)
    t = _times(0.2)
    ds = _run(rng.normal(size=t.size), rng.normal(size=t.size), t)
    parts = whirl_components(ds)
    from scipy.signal import hilbert

    # Re z+ + Re z- = x − mean; z+ is analytic: its imaginary part is Re z+'s Hilbert pair
    assert np.allclose(parts.forward + parts.backward, ds.x - ds.x.mean(), atol=1e-12)
    assert np.allclose(hilbert(parts.forward.values).imag,
                       np.imag(np.fft.ifft(np.fft.fft((ds.x - ds.x.mean()).values
                                                      + 1j * (ds.y - ds.y.mean()).values)
                                           * (np.fft.fftfreq(t.size) > 0))), atol=1e-9)


def test_a_missing_coordinate_is_refused_in_one_line():
    t = _times(0.1)
    ds = _run(np.cos(t), np.sin(t), t)
    with pytest.raises(InputError, match="no state variable 'z'"):
        full_spectrum(ds, "x", "z")
    with pytest.raises(InputError, match="give both"):
        full_spectrum(ds, "x", None)
