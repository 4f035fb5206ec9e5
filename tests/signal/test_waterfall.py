"""Waterfall and order tracking of a run-up: each named order line lies on its order
within one bin (on the waterfall's own data and on the order spectrum), order tracking of a
synthetic chirp against its known orders, the command and its bad inputs."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.signal
import xarray as xr

from analysis import simulate
from analysis.errors import InputError
from analysis.integrate.speed_profile import SpeedProfile
from analysis.signal.orders import order_lines, order_peaks, order_spectrum
from analysis.signal.waterfall import waterfall

MODEL, DAMPING = "vakharia2015-consistent", 1000.0  # as tests/integrate/test_speed_profile.py
RAMP = SpeedProfile.ramp(1000, 10000)


@pytest.fixture(scope="module")
def run_up() -> xr.Dataset:
    """1000 → 10000 rpm in 8 s, N_b = 8, kept every 4th step (25 kHz)."""
    return simulate(MODEL, 8, duration=8.0, transient=0.0, save_every=4, damping=DAMPING,
                    speed_rpm=RAMP)


def test_each_named_line_lies_on_its_order_within_one_bin(run_up):
    """Every peak of every window (``scipy.signal.find_peaks``, 20x the window's median, 5
    bins clear of DC, whose skirt holds the slow drift of the static deflection) that has
    exactly one line m·X + n·VC (|m| <= 3, n <= 2, named or not) within 2 bins belongs to
    that line; when it is a named one (the defect orders FTF, BPFI, BSF hold no line
    without a defect) up to the order of VC+X, the peak (refined between bins as
    ``find_peaks`` refines it) lies within one bin of it (the default window makes the smear of
    those lines one bin; higher orders smear over more, docs/run-ups.md), for every line
    found in at least 20 % of the windows (a weak line seen in a few windows only, 3X, can
    sit 1.6 bins off). X, VC and VC±X are each found in over 40 % of the windows."""
    wf = waterfall(run_up)
    amp, df = wf["amplitude"].values, float(wf.attrs["bin_hz"])
    lines = wf["line_hz"].values / df  # in bins
    names = [str(name) for name in wf["line"].values]
    orders = dict(zip(names, wf["order"].values, strict=True))
    d_i, d_o = load_geometry()
    vc = 8 * d_i / (d_i + d_o)  # VC/X from the geometry
    # every line the response may hold, named or not: m·X + n·VC, |m| <= 3, n <= 2
    candidates = np.array(sorted({m + n * vc for m in range(-3, 4) for n in range(3)
                                  if m + n * vc > 0}))
    shaft = np.nonzero(wf["line_kind"].values == "shaft")[0]  # defect orders: no line
    found: dict[str, list[float]] = {names[i]: [] for i in shaft}  # without a defect
    for j in range(amp.shape[0]):
        x_bins = float(wf["shaft_hz"].values[j]) / df
        peaks, _ = scipy.signal.find_peaks(amp[j], height=20 * np.median(amp[j]))
        for m in peaks[peaks >= 5]:
            near = candidates[np.abs(candidates * x_bins - m) <= 2]
            if len(near) != 1:
                continue  # two lines within 2 bins: the peak is not one line's
            line = shaft[np.abs(wf["order"].values[shaft] - near[0]) < 1e-9]
            if len(line) == 1:  # the peak's bin refined by a parabola through log |A|
                a, b, c = np.log(amp[j, m - 1:m + 2])
                where = m + 0.5 * (a - c) / (a - 2 * b + c)
                found[names[line[0]]].append(abs(lines[line[0], j] - where))
    top, windows = orders["VC+X"], amp.shape[0]
    counts = {name: len(d) for name, d in found.items()}
    for name, distances in found.items():  # lines the response holds (in 20 % of windows)
        if orders[name] <= top + 1e-9 and len(distances) > 0.2 * windows:
            assert max(distances) <= 1.0, (name, max(distances))
    for name in ("X", "VC", "VC-X", "VC+X"):
        assert counts[name] > 0.4 * windows, counts


def test_the_order_spectrum_has_its_lines_at_fixed_orders(run_up):
    """The largest peaks of the order spectrum are the named lines, each within one order
    bin of its order (the orders from the model's X and VC at t = 0, VC/X = N_b·D_i/(D_i +
    D_o) here computed from the geometry)."""
    spectrum = order_spectrum(run_up)
    bin_ = float(spectrum.attrs["order_bin"])
    geometry = load_geometry()
    vc_order = 8 * geometry[0] / (geometry[0] + geometry[1])
    named = {line.name: line.order for line in order_lines(run_up.attrs)}
    assert named["VC"] == pytest.approx(vc_order, rel=1e-12)
    peaks = order_peaks(spectrum, max_peaks=8)
    by_name = {p.name: p for p in peaks}
    assert {"X", "VC", "VC-X", "VC+X"} <= set(by_name)
    for name, order in (("X", 1.0), ("VC", vc_order), ("VC-X", vc_order - 1),
                        ("VC+X", vc_order + 1)):
        assert abs(by_name[name].order - order) <= bin_, by_name[name]
    combos = np.array([m + n * vc_order for m in range(-4, 5) for n in range(4)])
    for p in peaks:  # every large peak is a line m·X + n·VC, within one order bin
        assert p.name is not None
        assert np.min(np.abs(combos - p.order)) <= bin_, p


def load_geometry() -> tuple[float, float]:
    from analysis.model import load_model

    values = load_model(MODEL).defaults
    return values["inner_race_diameter"], values["outer_race_diameter"]


def test_order_tracking_of_a_synthetic_chirp():
    """x = A cos(3φ) + B cos(7φ) on a 600 → 3000 rpm table: the order spectrum has
    A at order 3 and B at 7, each in its own bin, whatever the sweep."""
    profile = SpeedProfile.table([0.0, 1.0, 2.0], [600.0, 3000.0, 1200.0])
    dt, duration = 1e-4, 2.0
    t = np.arange(0, round(duration / dt) + 1) * dt
    phi = profile.shaft_angle(t, duration)
    attrs = {"model": "synthetic", "shaft_hz": 10.0, "speed_rpm": 600.0, "dt": dt,
             "duration": duration, **profile.attrs(duration)}
    ds = xr.Dataset({"x": ("t", 2e-6 * np.cos(3 * phi) + 5e-7 * np.cos(7.0 * phi),
                           {"units": "m"})}, coords={"t": t}, attrs=attrs)
    spectrum = order_spectrum(ds, "x")
    order = spectrum["order"].values
    for where, amplitude in ((3.0, 2e-6), (7.0, 5e-7)):
        k = int(np.argmin(np.abs(order - where)))
        assert abs(order[k] - where) <= 0.5 * float(spectrum.attrs["order_bin"])
        # Hann scalloping: at most 2 % at a tenth of a bin off its centre
        assert spectrum.values[k] == pytest.approx(amplitude, rel=2e-2)
    # off the lines (3 bins away and more), nothing: below 1e-3 of a line (-60 dB)
    off = np.ones(order.size, bool)
    for where in (3.0, 7.0):
        off &= np.abs(order - where) > 0.05
    assert spectrum.values[off].max() < 1e-3 * 2e-6


def test_a_constant_speed_run_has_no_waterfall():
    ds = simulate("vakharia2015", 8, duration=0.2, transient=0.0, speed_rpm=5000)
    with pytest.raises(InputError, match="waterfall: the run is at a constant speed"):
        waterfall(ds)


def test_the_command_figure_json_and_orders(cli, tmp_path):
    res = cli("simulate", MODEL, "--n-balls", "8", "--speed-rpm", "2000:6000", "--set",
              f"damping={DAMPING}", "--duration", "1", "--transient", "0", "--save-every",
              "4", "-o", "up.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = cli("waterfall", "up.nc", "-o", "wf.png", "--json", "--orders", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    assert (tmp_path / "wf.png").stat().st_size > 10_000
    names = [line["name"] for line in report["lines"]]
    assert {"X", "2X", "VC", "VC-X", "VC+X"} <= set(names)
    x = report["lines"][names.index("X")]
    assert x["order"] == 1.0
    assert x["speed_rpm"][0] > 2000 and x["speed_rpm"][-1] < 6000
    assert np.allclose(np.array(x["frequency_hz"]), np.array(x["speed_rpm"]) / 60)
    assert report["orders"]["peaks"][0]["name"] is not None
    assert report["provenance"]["speed_profile"] == "ramp"
    res = cli("waterfall", "up.nc", cwd=tmp_path)
    assert res.returncode == 0 and "VC+X" in res.stdout


def test_bad_inputs_one_line_exit_2_nothing_written(cli, tmp_path):
    from analysis.integrate.simulate import simulate_to_file

    simulate_to_file("vakharia2015", tmp_path / "flat.nc", duration=0.2, transient=0.0)
    simulate_to_file("vakharia2015", tmp_path / "up.nc", duration=0.2, transient=0.0,
                     speed_rpm=SpeedProfile.ramp(2000, 3000))
    res = cli("waterfall", "flat.nc", "-o", "wf.png", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.strip().count("\n") == 0
    assert "waterfall: the run is at a constant speed (5000 rpm)" in res.stderr
    assert not (tmp_path / "wf.png").exists()
    for args, words in ((["--window", "5"], "--window: must be in"),
                        (["--var", "q"], "--var: no state variable 'q'"),
                        (["--orders", "--samples-per-rev", "2"],
                         "--samples-per-rev: must be a whole number >= 4")):
        res = cli("waterfall", "up.nc", "-o", "wf.png", *args, cwd=tmp_path)
        assert res.returncode == 2, res.stderr
        assert res.stderr.strip().count("\n") == 0 and words in res.stderr
        assert not (tmp_path / "wf.png").exists()
