"""Model against measurement (issue 37, part 5): the defect models' housing resonance and a
run's sample rate as settings, the order-domain comparison of a record with a run, its
command, and the defect model of a diagnosis simulated and compared."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.errors import InputError
from analysis.integrate.plan import steps_for_rate
from analysis.integrate.simulate import simulate
from analysis.measured.compare import SPECTRA, compare, differentiate
from analysis.measured.records import read_record
from tests.conftest import ROOT
from tests.measured.cwru import IR, needs_cwru

RPM = 1797.0
FS = 12000.0
RESONANCE = 3000.0
"""A 12 kHz record's housing resonance (below its 6 kHz Nyquist frequency)."""


def write_csv(path, t, values, unit: str = "m") -> None:
    """A record as the csv module writes it: a time column and one channel."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["t", f"x [{unit}]"])
        for ti, xi in zip(t - t[0], values, strict=True):
            writer.writerow([repr(float(ti)), repr(float(xi))])


@pytest.fixture(scope="module")
def run():
    """The inner-defect model at 1797 rpm, saved at 12 kHz, resonance 3 kHz: 1 s kept."""
    dt, every = steps_for_rate(FS, 2e-6)
    return simulate("6205-inner-defect", duration=1.2, transient=0.2, dt=dt, save_every=every,
                    speed_rpm=RPM, housing_resonance_hz=RESONANCE)


@pytest.fixture(scope="module")
def self_record(run, tmp_path_factory):
    path = tmp_path_factory.mktemp("compare") / "self.csv"
    write_csv(path, run.t.values, run.x_housing.values)
    return path


def test_the_run_is_saved_at_the_record_rate(run):
    t = run.t.values
    assert run.attrs["save_every"] * run.attrs["dt"] == 1 / FS and run.attrs["dt"] <= 2e-6
    assert np.allclose(np.diff(t), 1 / FS, rtol=1e-9, atol=0)


def test_a_run_against_itself_as_a_record_shares_every_line(run, self_record):
    record = read_record(self_record, rpm=RPM)
    comparison = compare(record, run, channel="x")
    for kind in SPECTRA:
        assert len(comparison.lines(kind, "both")) >= 6, kind
        assert not comparison.lines(kind, "record only") and \
            not comparison.lines(kind, "model only"), comparison.as_dict()["matches"]
    names = [m.name for m in comparison.lines("envelope", "both")]
    assert {"BPFI", "BPFI-X", "BPFI+X", "2BPFI"} <= set(names), names
    assert comparison.units == {"record": "m/s^2", "model": "m/s^2"}
    assert comparison.notes == []  # the same geometry: the run's own


def test_a_line_added_to_the_record_is_the_record_s_only(run, tmp_path):
    """A sine at 4X (in no line of the model's raw spectrum) added to the record at a
    twentieth of the model's largest raw line (as acceleration: amplitude/(2πf)² in m)."""
    x = run.x_housing.values
    t = run.t.values - run.t.values[0]
    plain = compare(read_record(_csv(tmp_path / "a.csv", t, x), rpm=RPM), run, channel="x")
    assert "4X" not in [ln.name for ln in plain.model["raw"].lines]
    a_top = _largest_raw_line(x)
    w = 2 * np.pi * 4 * RPM / 60
    added = x + 0.05 * a_top / w**2 * np.sin(w * t)
    record = read_record(_csv(tmp_path / "b.csv", t, added), rpm=RPM)
    comparison = compare(record, run, channel="x")
    only = comparison.lines("raw", "record only")
    assert [m.name for m in only] == ["4X"]
    assert only[0].record.order == pytest.approx(4.0, abs=0.01)
    assert only[0].record.level_db == pytest.approx(20 * math.log10(0.05), abs=1.0)
    assert not comparison.lines("raw", "model only")


def _csv(path, t, values):
    write_csv(path, t, values)
    return path


def _largest_raw_line(x: np.ndarray) -> float:
    """Largest line (m/s²) of the Hann amplitude spectrum of x's acceleration, orders
    0.3-12, as (2πf)²·|X| (the compare module's own conversion left out)."""
    from analysis.signal.orders import amplitude

    amp = amplitude(x)
    f = np.arange(amp.size) * FS / x.size
    keep = (f >= 0.3 * RPM / 60) & (f <= 12 * RPM / 60)
    return float(np.max(amp[keep] * (2 * np.pi * f[keep]) ** 2))


def test_acceleration_of_a_sine_is_minus_omega_squared_times_it():
    """x = A sin ωt -> a = −A ω² sin ωt to 1e-5 of A ω² (v = A ω cos ωt to 1e-4) away from the
    record's ends (100 samples at 12 kHz: the smooth continuation across the FFT's wrap
    takes the ends' slope and curvature from finite differences), for whole periods and for
    73.5… periods; a line of the spectrum (Hann, whole record) within 1e-3 of A ω²."""
    from analysis.signal.orders import amplitude

    amp, fs = 2e-6, 12000.0
    for n, hz in ((12000, 250.0), (12345, 437.3)):
        t = np.arange(n) / fs
        w = 2 * np.pi * hz
        a = differentiate(amp * np.sin(w * t), fs, 2)
        assert np.max(np.abs(a + amp * w**2 * np.sin(w * t))[100:-100]) < 1e-5 * amp * w**2
        assert amplitude(a).max() == pytest.approx(amp * w**2, rel=1e-3 if n == 12000 else 2e-2)
        v = differentiate(amp * np.sin(w * t), fs, 1)
        assert np.max(np.abs(v - amp * w * np.cos(w * t))[100:-100]) < 1e-4 * amp * w


OLD_SUPPORT = {
    "support": 'support = { stiffness = "housing_stiffness", damping = "housing_damping" }\n',
    "stiffness": 'housing_stiffness = { value = 2.5266187e9, unit = "N/m", source = "old" }\n',
    "damping": 'housing_damping = { value = 5026.5, unit = "N*s/m", source = "old" }\n',
}


def old_spec(race: str) -> str:
    """The defect model as it was before the resonance became a parameter: the support of
    the housing given by the stiffness 2.5266187e9 N/m and damping 5026.5 N·s/m."""
    text = (ROOT / "modelgen" / "specs" / f"6205-{race}-defect.toml").read_text()
    head, _, terms = text.partition("\n[[terms]]\nkind = \"expression\"")
    assert terms, "the housing support is the spec's last term, an expression"
    head = head.replace('name = "housing"\n', 'name = "housing"\n' + OLD_SUPPORT["support"], 1)
    lines = [ln for ln in head.splitlines(keepends=True)
             if not ln.startswith(("housing_resonance_hz = ", "housing_damping_ratio = "))]
    at = next(i for i, ln in enumerate(lines) if ln.startswith("housing_mass"))
    lines[at + 1:at + 1] = [OLD_SUPPORT["stiffness"], OLD_SUPPORT["damping"]]
    return "".join(lines)


def test_the_resonance_parameter_leaves_the_default_run_unchanged(tmp_path, user_cache):
    """The inner-defect model's default run (0.05 s of impacts) against the same spec with
    the former support (stiffness and damping given): equal to round-off (1e-12 of each
    state's largest value: the force is now -m(2πf)²x, the same number computed in
    another order); and the resonance set to 3 kHz moves the housing's resonance there."""
    from analysis.model import load_model

    path = tmp_path / "6205-inner-defect.toml"
    path.write_text(old_spec("inner"))
    new = simulate("6205-inner-defect", duration=0.05, transient=0.0, compiled=False)
    old = simulate(path, duration=0.05, transient=0.0, compiled=False)  # no C build
    assert "housing_stiffness" in old.attrs and "housing_stiffness" not in new.attrs
    for var in new.data_vars:
        scale = float(np.abs(old[var]).max())
        assert float(np.abs(new[var] - old[var]).max()) <= 1e-12 * scale, var
    model = load_model("6205-inner-defect")
    assert model.support_resonances()[0] == pytest.approx(8000.0, rel=1e-8)
    assert model.support_resonances({"housing_resonance_hz": RESONANCE})[0] == \
        pytest.approx(RESONANCE, rel=1e-12)


def test_the_defect_model_of_a_verdict_matches_the_record(run, self_record):
    """simulate_matching picks the inner-defect model for 'inner-race', runs it at the
    record's speed and rate with a resonance at a quarter of the rate, and compares."""
    from analysis.measured.model_check import simulate_matching

    record = read_record(self_record, rpm=RPM)
    comparison = simulate_matching("inner-race", record, channel="x")
    sim = comparison.provenance["simulation"]
    assert sim["model"] == "6205-inner-defect" and sim["housing_resonance_hz"] == FS / 4
    assert sim["speed_rpm"] == pytest.approx(RPM, rel=2e-3)
    assert sim["save_every"] * sim["dt_s"] == 1 / FS
    assert "BPFI" in [m.name for m in comparison.lines("envelope", "both")]
    with pytest.raises(InputError, match="no defect model for the verdict 'none'"):
        simulate_matching("none", record, channel="x")


def invoke(*args):
    from analysis.cli import app

    return CliRunner().invoke(app, list(map(str, args)))


@pytest.fixture(scope="module")
def run_file(run, tmp_path_factory):
    from analysis.io import save_dataset

    path = tmp_path_factory.mktemp("compare_run") / "run.nc"
    save_dataset(run, path)
    return path


def test_the_command_prints_and_writes_the_comparison(self_record, run_file, tmp_path):
    figure = tmp_path / "compare.png"
    done = invoke("compare", self_record, run_file, "--channel", "x", "--rpm", RPM, "--json",
                  "-o", figure)
    assert done.exit_code == 0, done.output
    report = json.loads(done.stdout[done.stdout.index("{"):])
    assert "BPFI" in report["shared"]["envelope"] and report["record_only"]["raw"] == []
    assert figure.stat().st_size > 10_000
    done = invoke("compare", self_record, run_file, "--rpm", RPM)
    assert done.exit_code == 0 and "both" in done.stdout and "BPFI" in done.stdout


def test_the_command_refuses_bad_input_in_one_line(self_record, run_file, tmp_path):
    from analysis.io import save_dataset

    figure = tmp_path / "no.png"
    record_nc = tmp_path / "record.nc"
    save_dataset(read_record(self_record, rpm=RPM), record_nc)
    for args, words in (
            ((self_record, run_file, "--channel", "DE", "--rpm", RPM), "channels: x"),
            ((self_record, self_record, "--rpm", RPM), "result file: "),
            ((self_record, record_nc, "--rpm", RPM), "not a bearingdyn result"),
            ((self_record, run_file, "--var", "z_housing", "--rpm", RPM), "--var"),
            ((self_record, run_file, "--rpm", "0"), "--rpm")):
        done = invoke("compare", *args, "-o", figure)
        assert done.exit_code == 2, (args, done.output)
        lines = done.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], \
            done.output
        assert not figure.exists()


@needs_cwru
def test_diagnose_model_simulates_the_verdict_s_model_and_compares(tmp_path):
    """diagnose --model auto on the CWRU inner-race record: the inner-defect model at the
    record's speed, 12 kHz, the CWRU 6205's geometry and a resonance in the diagnosis's band;
    BPFI and its X sidebands shared. A folder with --model is refused in one line."""
    done = invoke("diagnose", IR, "--channel", "DE", "--bearing", "6205-cwru", "--model",
                  "auto", "--json")
    assert done.exit_code == 0, done.output
    report = json.loads(done.stdout[done.stdout.index("{"):])
    assert report["verdict"] == "inner-race"
    check = report["model_check"]
    sim = check["provenance"]["simulation"]
    assert sim["model"] == "6205-inner-defect" and sim["sample_rate_hz"] == FS
    assert sim["ball_diameter"] == pytest.approx(0.3126 * 0.0254)
    low, high = report["band"]["low_hz"], report["band"]["high_hz"]
    assert sim["housing_resonance_hz"] == pytest.approx((low + high) / 2)
    assert {"BPFI", "BPFI-X", "BPFI+X"} <= set(check["shared"]["envelope"])
    done = invoke("diagnose", tmp_path, "--bearing", "6205-cwru", "--model", "auto")
    assert done.exit_code == 2 and done.output.count("\n") == 1 and "--model" in done.output


def test_lines_are_named_by_the_defect_lines_present():
    """The CWRU fan-end outer-race record's envelope lines (orders of its 6203, BPFO 3.053
    in theory, 3.066 measured): BPFO's X sidebands name the lines near them, not the
    sidebands of a ball line that only the 2X line falls near (BSF 1.994)."""
    from analysis.measured.bearings import lookup
    from analysis.measured.compare import name_lines, vocabulary

    shaft = 29.94
    words = vocabulary(lookup("6203-cwru").frequencies(shaft), shaft, 12.0)
    orders = [1.0, 2.066, 3.066, 2.0, 5.132, 5.066]
    windows = [max(0.015 * o, 0.0067) for o in orders]
    assert name_lines(orders, words, windows) == ["X", "BPFO-X", "BPFO", "2X", "2BPFO-X",
                                                  "BPFO+2X"]
    assert abs(words["2xBSF+3FTF"] - 5.132) < abs(words["2BPFO-X"] - 5.132)  # nearer, absent
    assert name_lines([7.0], words, [0.01]) == ["7X"] and name_lines([6.7], words, [0.01]) \
        == [""]


def test_simulate_sample_rate_refusals(tmp_path):
    out = tmp_path / "r.nc"
    for args, words in ((("--sample-rate", "12000", "--save-every", "3"),
                         "--sample-rate: sets --save-every itself"),
                        (("--sample-rate", "0"), "--sample-rate: must be a rate in Hz > 0"),
                        (("--sample-rate", "nan"), "--sample-rate: must be a rate in Hz > 0")):
        done = invoke("simulate", "6205-inner-defect", "-o", out, "--duration", "0.01", *args)
        assert done.exit_code == 2 and done.output.startswith(f"error: {words}"), done.output
        assert not out.exists()
