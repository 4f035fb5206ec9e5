"""Waviness against the classical result (Wardle 1988; Aktürk 1999; Harsha et al. 2004): on
a preloaded bearing without radial load, a wavy outer race of order k = N_b ± 1 drives the
rotor at BPFO and an order k = N_b ± 2 not at all; a wavy inner race of order N_b + 1
drives it at BPFI + X; one ball with waviness of order 2 at 2·BSF ± FTF. The resultant of
the offsets Σ_i A cos(k θ_i)(cos θ_i, sin θ_i) is what decides, independently of the model:
it vanishes unless k ± 1 is a multiple of N_b."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
import tomli_w

from analysis.integrate.simulate import simulate
from analysis.model import load_model
from analysis.signal.spectrum import find_peaks
from tests.conftest import SPECS

FS = 5000.0 / 60.0
D_B, D_M, N_B = 4.762e-3, 23.5e-3, 9
AMPLITUDE = 0.1e-6  # m


def textbook(n: int = N_B) -> dict[str, float]:
    g = D_B / D_M
    return {"X": FS, "FTF": FS / 2 * (1 - g), "BPFO": n * FS / 2 * (1 - g),
            "BPFI": n * FS / 2 * (1 + g), "BSF": D_M / (2 * D_B) * FS * (1 - g * g)}


@pytest.fixture
def wavy(tmp_path, monkeypatch):
    """A preloaded (γ_0 = −2 µm), unloaded 6205 of the shipped specs with one waviness term."""
    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    load_model.cache_clear()

    def make(kind: str, orders: list[int], ball: int | None = None) -> str:
        data = tomllib.loads((SPECS / "6205-outer-defect.toml").read_text())
        name = f"wavy-{kind.split('_')[0]}-{'-'.join(map(str, orders))}"
        data["model"]["name"] = name
        data["terms"] = [t for t in data["terms"] if t["kind"] != "localized_defect"]
        for gone in ("defect_depth", "defect_length", "defect_angle"):
            del data["parameters"][gone]
        data["parameters"]["radial_clearance"]["value"] = -2e-6
        data["parameters"]["radial_load"]["value"] = 0.0
        data["simulation"]["initial"] = {"x_rotor": 0.0}  # the spec's rotor, at rest
        amplitudes = [f"waviness_{k}" for k in orders]
        for a in amplitudes:
            data["parameters"][a] = {"value": AMPLITUDE, "unit": "m", "source": "test",
                                     "low": 0.0, "high": 1e-4}
        term = {"kind": kind, "orders": orders, "amplitudes": amplitudes}
        if ball is not None:
            term["ball"] = ball
        data["terms"].append(term)
        path = tmp_path / f"{name}.toml"
        path.write_text(tomli_w.dumps(data))
        return str(path)

    yield make
    load_model.cache_clear()


def _run(path: str):
    return simulate(path, duration=0.6, transient=0.1, save_every=5)


def _names(peak) -> list[str]:
    return [peak.label, *peak.also] if peak.label else []


def _resultant(k: int, n: int = N_B) -> float:
    """|Σ_i cos(k θ_i) e^{iθ_i}| over a turn of the cage (largest over 64 cage angles)."""
    best = 0.0
    for psi in np.linspace(0, 2 * math.pi, 64):
        theta = 2 * math.pi * np.arange(n) / n + psi
        best = max(best, abs(np.sum(np.cos(k * theta) * np.exp(1j * theta))))
    return best


def test_outer_race_orders_next_to_n_balls_drive_bpfo_and_others_nothing(wavy):
    assert _resultant(N_B + 1) == pytest.approx(N_B / 2) and _resultant(N_B + 2) < 1e-12
    driven, silent = _run(wavy("outer_race_waviness", [N_B + 1])), \
        _run(wavy("outer_race_waviness", [N_B + 2]))
    top = find_peaks(driven, "x_rotor", max_peaks=1, vocabulary="fault")[0]
    bin_hz = 1 / 0.5
    assert "BPFO" in _names(top) and abs(top.frequency_hz - textbook()["BPFO"]) <= bin_hz
    assert np.ptp(silent["x_rotor"].values) < 1e-5 * np.ptp(driven["x_rotor"].values)


def test_inner_race_order_n_plus_one_drives_bpfi_plus_x(wavy):
    top = find_peaks(_run(wavy("inner_race_waviness", [N_B + 1])), "x_rotor", max_peaks=1,
                     vocabulary="fault")[0]
    f = textbook()
    assert "BPFI+X" in _names(top)
    assert abs(top.frequency_hz - (f["BPFI"] + f["X"])) <= 1 / 0.5


def test_one_wavy_ball_of_order_two_drives_2bsf_with_ftf_sidebands(wavy):
    ds = _run(wavy("ball_waviness", [2], ball=1))
    peaks = find_peaks(ds, "x_rotor", max_peaks=2, vocabulary="fault")
    f = textbook()
    found = {name: p.frequency_hz for p in peaks for name in _names(p)}
    for label, sign in (("2BSF+FTF", 1), ("2BSF-FTF", -1)):
        assert label in found, found
        assert abs(found[label] - (2 * f["BSF"] + sign * f["FTF"])) <= 1 / 0.5


def test_odd_ball_orders_do_nothing_and_zero_amplitude_is_bit_for_bit(wavy):
    path = wavy("ball_waviness", [3], ball=1)
    odd = simulate(path, duration=0.02, transient=0.0)
    flat = simulate(path, duration=0.02, transient=0.0, waviness_3=0.0)
    assert np.array_equal(odd["x_rotor"].values, flat["x_rotor"].values)
    outer = wavy("outer_race_waviness", [N_B + 1])
    zero = simulate(outer, duration=0.02, transient=0.0, **{f"waviness_{N_B + 1}": 0.0})
    assert np.array_equal(zero["x_rotor"].values, flat["x_rotor"].values)


def test_waviness_spec_errors_are_one_line_each(tmp_path):
    from modelgen.errors import SpecError
    from modelgen.spec import parse_spec

    data = tomllib.loads((SPECS / "6205-outer-defect.toml").read_text())
    data["terms"].append({"kind": "outer_race_waviness", "orders": [10, 11],
                          "amplitudes": ["wav_a"]})
    with pytest.raises(SpecError, match="orders and amplitudes must be as long as each other"):
        parse_spec(data)
    data["terms"][-1] = {"kind": "outer_race_waviness", "orders": [10],
                         "amplitudes": ["wav_a"]}
    last = len(data["terms"]) - 1  # the appended term's index in the spec
    with pytest.raises(SpecError, match=rf"parameters\.wav_a: missing; terms\[{last}\] "
                                        r"\(outer_race_waviness\) needs it"):
        parse_spec(data)
