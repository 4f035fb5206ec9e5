"""Fault names that can be trusted, and fault signatures that survive measurement noise.

References independent of the code under test: the defect frequencies computed here from the
bearing's geometry (Randall & Antoni 2011, Eqs. 1-4), white noise drawn here, the noise floor
of the envelope spectrum recomputed here, and the X/VC combinations listed here.

The 2.5 s records of the outer-race defect (the shipped spec, with its 8 kHz housing
resonator) and of the same spec with ``defect_depth = 0`` are simulated once for the module
(about 5 s each on one core).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from analysis.integrate.simulate import simulate
from analysis.signal.envelope import envelope, envelope_peaks
from analysis.signal.noise import add_noise
from analysis.signal.spectrum import (
    SIGNIFICANCE_DB,
    amplitude_spectrum,
    fault_names,
    run_defects,
)

pytestmark = pytest.mark.xdist_group(__name__)
"""This module's tests on one xdist worker (``--dist loadgroup``: tests/conftest.py), so its
module fixtures run once, not once per worker."""
FS = 5000.0 / 60.0  # the 6205 specs' shaft frequency, Hz
D_B, D_M, N_B = 4.762e-3, 23.5e-3, 9
SEEDS = range(5)
RINGING = (3906.25, 11718.75)
"""The band the kurtogram picks on the noisy defect record (fs/128 … 3·fs/128): 8 kHz."""


def textbook(fs: float = FS, d: float = D_B, big_d: float = D_M, n: int = N_B) -> dict:
    """Randall & Antoni 2011, Eqs. 1-4 (outer race stationary, contact angle 0), Hz."""
    g = d / big_d
    return {"FTF": fs / 2 * (1 - g), "BPFO": n * fs / 2 * (1 - g),
            "BPFI": n * fs / 2 * (1 + g), "BSF": big_d / (2 * d) * fs * (1 - g * g)}


@pytest.fixture(scope="module")
def records():
    """The 2.5 s outer-defect record and the same with defect_depth = 0 (after 0.2 s)."""
    hit = simulate("6205-outer-defect", duration=2.7, transient=0.2)
    free = simulate("6205-outer-defect", duration=2.7, transient=0.2, defect_depth=0.0)
    return hit, free


@pytest.fixture(scope="module")
def noisy_envelopes(records):
    """Per seed the named envelope peaks and the band of the defect record at 0 dB, and the
    bin (Hz) of the envelope spectrum (the same band for every seed)."""
    hit, _ = records
    found = {seed: envelope_peaks(add_noise(hit, 0.0, seed, ("x_housing",)), "x_housing",
                                  max_peaks=12) for seed in SEEDS}
    band = found[0][1]
    env, _ = envelope(add_noise(hit, 0.0, 0, ("x_housing",)), "x_housing",
                      (band.low_hz, band.high_hz))
    return found, _bin_hz(env)


def _names(peak) -> list[str]:
    return [peak.label, *peak.also] if peak.label else []


def _bin_hz(ds: xr.Dataset) -> float:
    return 1.0 / (ds.sizes["t"] * float(ds.t[1] - ds.t[0]))


@pytest.mark.parametrize("seed", SEEDS)
def test_bpfo_is_named_within_one_bin_at_zero_db(records, noisy_envelopes, seed):
    hit, _ = records
    noisy = add_noise(hit, 0.0, seed, ("x_housing",))
    x, clean = noisy["x_housing"].values, hit["x_housing"].values
    assert np.std(x - clean) == pytest.approx(np.std(clean), rel=0.01)  # 0 dB: equal stds
    (peaks, band), bin_hz = noisy_envelopes[0][seed], noisy_envelopes[1]
    bpfo = textbook()["BPFO"]
    found = [p for p in peaks if "BPFO" in _names(p)]
    assert found, [(p.name, round(p.frequency_hz, 2)) for p in peaks]
    assert abs(found[0].frequency_hz - bpfo) <= bin_hz
    assert band.resonances_hz and band.low_hz < 8000 < band.high_hz  # the resonance band
    assert (band.low_hz, band.high_hz) == pytest.approx(RINGING) and band.kurtosis > 3
    assert "structural resonance" in band.note


@pytest.mark.parametrize("seed", SEEDS)
def test_no_bpfo_without_the_defect_in_the_same_noise(records, seed):
    _, free = records
    noisy = add_noise(free, 0.0, seed, ("x_housing",))
    peaks, band = envelope_peaks(noisy, "x_housing", max_peaks=10)
    assert not [p for p in peaks if any("BPFO" in n for n in _names(p))], \
        [(p.name, p.also) for p in peaks]
    assert run_defects(noisy.attrs) == ()  # depth 0: no defect, VC and X only
    # where the defect's impacts ring the housing (8 kHz) the defect-free record holds
    # Gaussian noise only: no line at BPFO (= VC) or anywhere else stands above the floor
    ringing = RINGING  # the band chosen on the defect's record
    peaks, band = envelope_peaks(noisy, "x_housing", band=ringing, max_peaks=10)
    assert abs(band.kurtosis) < 0.1 and not [p.label for p in peaks if p.label]


def test_the_noise_is_reproducible_and_recorded(records):
    hit, _ = records
    a = add_noise(hit, 3.0, 7, ("x_housing", "y_housing"))
    b = add_noise(hit, 3.0, 7, ("x_housing", "y_housing"))
    c = add_noise(hit, 3.0, 8, ("x_housing", "y_housing"))
    assert np.array_equal(a["x_housing"].values, b["x_housing"].values)
    assert not np.array_equal(a["x_housing"].values, c["x_housing"].values)
    assert np.array_equal(a["x_rotor"].values, hit["x_rotor"].values)  # not asked for
    assert (a.attrs["noise_seed"], a.attrs["noise_snr_db"]) == (7, 3.0)
    assert a.attrs["noise_variables"] == "x_housing y_housing"
    rng = np.random.default_rng(7)  # the documented stream: variables in order
    expected = hit["x_housing"].values + hit["x_housing"].values.std() * 10 ** (-3 / 20) \
        * rng.standard_normal(hit.sizes["t"])
    np.testing.assert_allclose(a["x_housing"].values, expected, rtol=0, atol=1e-20)


def test_harmonics_beyond_the_fourth_are_named_on_the_long_record(noisy_envelopes):
    bpfo = textbook()["BPFO"]
    (peaks, _), bin_hz = noisy_envelopes[0][0], noisy_envelopes[1]
    named = {p.label: p.frequency_hz for p in peaks if p.label}
    high = [n for n in range(5, 8) if f"{n}BPFO" in named]
    assert high, named
    for n in high:
        assert abs(named[f"{n}BPFO"] - n * bpfo) <= bin_hz


def test_the_nearest_name_wins_not_the_lowest_order():
    """3 x BPFO 0.03 Hz away and 2 x BPFI 4.9 Hz away, both within a 0.3 s record's
    tolerance (1.5 bins = 5 Hz): the line is 3BPFO, 2BPFI kept in ``also``."""
    f = textbook()
    faults = {"": f}
    line = 3 * f["BPFO"] + 0.03
    assert abs(line - 2 * f["BPFI"]) < 5.0
    names = [n for n, _ in fault_names(line, FS, faults, 5.0)]
    assert names[0] == "3BPFO" and "2BPFI" in names


def test_the_3bpfo_line_of_a_short_record_is_named_3bpfo():
    ds = simulate("6205-outer-defect", duration=0.4, transient=0.1, save_every=5)
    peaks, _ = envelope_peaks(ds, max_peaks=10)
    line = [p for p in peaks if abs(p.frequency_hz - 3 * textbook()["BPFO"]) < 2.0]
    assert line and line[0].label == "3BPFO", [(p.name, p.frequency_hz) for p in peaks]


def _combinations(shaft: float, vc: float, top: float) -> np.ndarray:
    """Every m·X + n·VC (|m| <= 2 with n >= 1, or any kX) up to ``top`` Hz."""
    out = [k * shaft for k in range(1, int(top / shaft) + 2)]
    out += [n * vc + m * shaft for n in range(1, int(top / vc) + 2) for m in range(-2, 3)]
    return np.array([f for f in out if f > 0])


def test_the_defect_free_paper_model_names_only_lines_that_exist():
    """The band of the search (the top band: numerical noise, nothing named) and a band
    holding the rotor's own response (1-6 kHz: X, VC, VC-X named)."""
    ds = simulate("vakharia2015", duration=0.3, transient=0.0)
    assert run_defects(ds.attrs) == ()
    for given in (None, (1000.0, 6000.0)):
        peaks, band = envelope_peaks(ds, band=given, max_peaks=12)
        env, _ = envelope(ds, None, (band.low_hz, band.high_hz))
        spectrum = amplitude_spectrum(env, str(env.attrs["state_names"])).values
        bin_hz = _bin_hz(env)
        lines = _combinations(float(ds.attrs["shaft_hz"]), float(ds.attrs["vc_hz"]),
                              band.high_hz - band.low_hz)
        for p in peaks:
            assert not any(word in n for n in _names(p) for word in ("BPFI", "BSF", "FTF")), p
            if p.label:
                assert np.min(np.abs(lines - p.frequency_hz)) <= 1.5 * bin_hz, p
                k = round(p.frequency_hz / bin_hz)
                around = np.concatenate([spectrum[max(1, k - 100):k - 1],
                                         spectrum[k + 2:k + 101]])
                assert p.amplitude >= 10 ** (SIGNIFICANCE_DB / 20) * np.median(around), p
        if given is not None:
            assert {"X", "VC", "VC-X"} <= {p.label for p in peaks}, peaks


def test_pure_noise_names_nothing():
    rng = np.random.default_rng(11)
    n, fs = 200_000, 100_000.0
    ds = xr.Dataset({"x": ("t", rng.standard_normal(n), {"units": "m"})},
                    coords={"t": np.arange(n) / fs},
                    attrs={"shaft_hz": 83.3, "ftf_hz": 33.2, "bpfo_hz": 299.0,
                           "bpfi_hz": 451.0, "bsf_hz": 197.2})
    peaks, _ = envelope_peaks(ds, "x", max_peaks=12)
    assert peaks and not [p.label for p in peaks if p.label]


def test_the_defect_families_of_the_shipped_models():
    for race in ("outer", "inner", "ball"):
        attrs = simulate(f"6205-{race}-defect", duration=0.002, transient=0.0).attrs
        assert run_defects(attrs) == (race,)
        assert run_defects({**attrs, "defect_depth": 0.0}) == ()
    assert run_defects({"model": "no-such-model"}) is None  # unknown: every family
    assert math.isclose(textbook()["BPFO"], N_B * textbook()["FTF"])


def test_the_housing_rings_at_the_frequency_of_its_parameters(records):
    """The clean defect record's housing displacement peaks (Welch PSD, 2-50 kHz) at
    the spec's housing_resonance_hz (the support's √(k/m)/2π), within its half-power
    bandwidth (5 % damping: ±5 %)."""
    import scipy.signal

    hit, _ = records
    fs = 1.0 / float(hit.t[1] - hit.t[0])
    f, psd = scipy.signal.welch(hit["x_housing"].values, fs=fs, nperseg=2**14)
    band = (f > 2000) & (f < 50_000)
    natural = float(hit.attrs["housing_resonance_hz"])
    assert natural == pytest.approx(8000.0, rel=1e-6)
    assert f[band][np.argmax(psd[band])] == pytest.approx(natural, rel=0.05)


def test_noise_through_the_cli(tmp_path):
    import json

    from tests.conftest import run_cli

    run = tmp_path / "r.nc"
    done = run_cli("simulate", "6205-outer-defect", "-o", str(run), "--duration", "0.2",
                   "--transient", "0.05", "--save-every", "5")
    assert done.returncode == 0, done.stderr
    for bad, word in (("nan", "--noise: must be an SNR in dB in [-60, 200], got nan"),
                      ("300", "--noise: must be an SNR in dB in [-60, 200], got 300.0")):
        done = run_cli("spectrum", str(run), "--envelope", "--noise", bad)
        assert done.returncode == 2 and done.stderr.strip() == f"error: {word}", done.stderr
    done = run_cli("spectrum", str(run), "--envelope", "--noise", "0", "--noise-seed", "-1")
    assert done.returncode == 2
    assert done.stderr.strip() == "error: --noise-seed: must be a whole number >= 0, got -1"
    done = run_cli("spectrum", str(run), "--envelope", "--noise", "10", "--noise-seed", "4",
                   "--json")
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["provenance"]["noise_seed"] == 4
    assert report["provenance"]["noise_snr_db"] == 10.0
    assert report["envelopes"][0]["note"] and report["envelopes"][0]["edge_s"] > 0


def test_band_resonance_judges_in_the_resonance_band(records):
    """--band resonance: asked for the resonance, the band holds 8 kHz and BPFO is named
    there; the default band does the same where the model has a resonance (issue 32: it
    picked a band far above it, where only the impacts have energy). A model without a
    structural resonance is refused in one line."""
    hit, _ = records
    anywhere = envelope_peaks(hit, "x_housing", max_peaks=4)[1]
    peaks, band = envelope_peaks(hit, "x_housing", band="resonance", max_peaks=6)
    assert anywhere.low_hz <= 8000 <= anywhere.high_hz and anywhere.chosen == "resonance"
    assert band.chosen == "resonance" and band.low_hz <= 8000 <= band.high_hz
    assert (band.low_hz, band.high_hz) == (anywhere.low_hz, anywhere.high_hz)
    assert any(p.label == "BPFO" and abs(p.frequency_hz - textbook()["BPFO"]) < 0.5
               for p in peaks)
    paper = simulate("vakharia2015", duration=0.1, transient=0.0)
    from analysis.errors import InputError

    with pytest.raises(InputError, match="'resonance' needs a structural resonance"):
        envelope_peaks(paper, band="resonance")
