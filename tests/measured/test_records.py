"""Measured records (``analysis.measured.records``): each reader against a file its own
library wrote (the values read equal the values written), the CWRU records of
``../shared/data/cwru`` where they are, the bad inputs (one ``InputError`` line naming the
option), and ``bearingdyn record info``."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.errors import InputError
from analysis.measured.records import (
    channels,
    is_record,
    pick_channel,
    read_record,
    record_speed_hz,
    tacho_pulses,
    to_si,
)
from tests.measured.cwru import BALL, IR, OR, needs_cwru

FS = 2000.0
N = 1000


def signals(k: int = 2) -> np.ndarray:
    """``k`` channels of N samples: tones and seeded noise (independent of the readers)."""
    t = np.arange(N) / FS
    rng = np.random.default_rng(7)
    return np.stack([np.sin(2 * np.pi * (50 + 30 * i) * t) * (i + 1) + 0.1 *
                     rng.standard_normal(N) for i in range(k)], axis=1)


# ------------------------------------------------------------------------- readers


def test_csv_with_a_time_column_and_units(tmp_path):
    data = signals()
    path = tmp_path / "rec.csv"
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time (s)", "DE [g]", "probe x (um)"])
        for i, row in enumerate(data):
            writer.writerow([repr(i / FS), *(repr(float(v)) for v in row)])
    rec = read_record(path)
    assert is_record(rec) and channels(rec) == ["DE", "probe_x"]
    assert rec.attrs["sample_rate_hz"] == pytest.approx(FS, rel=1e-12)
    np.testing.assert_array_equal(rec["DE"].values, data[:, 0])
    np.testing.assert_array_equal(rec["probe_x"].values, data[:, 1])
    assert (rec["DE"].attrs["units"], rec["probe_x"].attrs["units"]) == ("g", "um")
    assert json.loads(rec.attrs["original_names"]) == ["DE", "probe x"]
    values, unit = to_si(rec, "probe")
    np.testing.assert_allclose(values, data[:, 1] * 1e-6, rtol=1e-15)
    assert unit == "m"


def test_a_time_column_in_ms_that_starts_late(tmp_path):
    data = signals(1)[:, 0]
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([1000 * (2.5 + np.arange(N) / FS), data]), delimiter=",",
               header="time (ms),acc [m/s^2]", comments="", fmt="%.12g")
    rec = read_record(path)
    assert rec.attrs["sample_rate_hz"] == pytest.approx(FS, rel=1e-9)
    assert rec.attrs["time_offset_s"] == pytest.approx(2.5) and rec["t"].values[0] == 0.0
    np.testing.assert_array_equal(rec["acc"].values, np.array([float(f"{v:.12g}")
                                                               for v in data]))


def test_tsv_without_header_needs_fs(tmp_path):
    data = signals(3)
    path = tmp_path / "rec.tsv"
    with open(path, "w", newline="") as handle:
        csv.writer(handle, delimiter="\t").writerows(data.tolist())
    with pytest.raises(InputError, match=r"^record: .* states no sampling rate; give --fs HZ$"):
        read_record(path)
    rec = read_record(path, fs=FS, units="m/s^2")
    assert channels(rec) == ["c1", "c2", "c3"]
    np.testing.assert_array_equal(np.stack([rec[c].values for c in channels(rec)], 1), data)
    assert rec.attrs["sample_rate_source"] == "--fs"
    assert rec["t"].values[-1] == pytest.approx((N - 1) / FS)


def test_wav_int16_is_scaled_to_full_scale_times_scale(tmp_path):
    from scipy.io import wavfile

    pcm = (signals() / 4 * 32767).astype(np.int16)
    path = tmp_path / "rec.wav"
    wavfile.write(path, int(FS), pcm)
    rec = read_record(path, scale=50.0, units="g")
    assert channels(rec) == ["ch1", "ch2"] and rec.attrs["sample_rate_hz"] == FS
    np.testing.assert_array_equal(rec["ch2"].values, pcm[:, 1] / 32768.0 * 50.0)
    assert rec["ch1"].attrs["units"] == "g" and rec.attrs["reader"] == "scipy.io.wavfile.read"


def test_wav_float32_is_taken_as_it_is(tmp_path):
    from scipy.io import wavfile

    data = signals(1)[:, 0].astype(np.float32)
    path = tmp_path / "rec.wav"
    wavfile.write(path, int(FS), data)
    rec = read_record(path)
    np.testing.assert_array_equal(rec["ch1"].values, data.astype(np.float64))
    assert rec["ch1"].attrs["units"] == "1"


@pytest.mark.parametrize("version", ["5", "4"])
def test_mat_v5_and_v4(tmp_path, version):
    from scipy.io import savemat

    data = signals()
    path = tmp_path / "rec.mat"
    savemat(path, {"X200_DE_time": data[:, :1], "X200_FE_time": data[:, 1:],
                   "X200RPM": np.array([[1750.0]]), "fs": np.array([[FS]])}, format=version)
    rec = read_record(path)
    assert channels(rec) == ["DE", "FE"]
    np.testing.assert_array_equal(rec["FE"].values, data[:, 1])
    assert rec["DE"].attrs["units"] == "g" and rec["DE"].attrs["original_name"] == "X200_DE_time"
    assert rec.attrs["sample_rate_hz"] == FS
    assert rec.attrs["speed_rpm"] == 1750.0 and rec.attrs["speed_source"] == "file: X200RPM"
    assert record_speed_hz(rec) == pytest.approx(1750 / 60)


def test_a_cwru_file_with_a_second_records_variables(tmp_path):
    """A few CWRU files hold another record's variables beside their own: the record the
    file name ends with keeps DE, FE and its speed."""
    from scipy.io import savemat

    data = signals(2)
    savemat(tmp_path / "Normal_1_099.mat", {
        "X098_DE_time": data[:, :1], "X099_DE_time": data[:, 1:], "X098RPM": [[1772.0]],
        "X099RPM": [[1774.0]]})
    rec = read_record(tmp_path / "Normal_1_099.mat", fs=FS)
    assert sorted(channels(rec)) == ["DE", "X098_DE_time"]
    np.testing.assert_array_equal(rec[pick_channel(rec, "DE")].values, data[:, 1])
    assert rec.attrs["speed_rpm"] == 1774.0 and rec.attrs["speed_source"] == "file: X099RPM"


def test_mat_v73_in_matlabs_hdf5_layout(tmp_path):
    """A v7.3 MAT-file as MATLAB writes it: a 512-byte header (version 0x0200) before the
    HDF5 data, each array stored transposed (a column of N is a 1 x N dataset)."""
    import h5py

    data = signals()
    path = tmp_path / "12k_rec.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, column in (("acc_x", data[:, 0]), ("acc_y", data[:, 1])):
            f.create_dataset(name, data=column[None, :]).attrs["MATLAB_class"] = b"double"
        f.create_dataset("rpm", data=np.array([[1500.0]])).attrs["MATLAB_class"] = b"double"
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: test HDF5 schema 1.00 ."
    with open(path, "r+b") as handle:
        handle.write(header.ljust(116) + b"\0" * 8 + b"\x00\x02IM")
    rec = read_record(path)
    assert rec.attrs["reader"] == "h5py (MATLAB v7.3)"
    np.testing.assert_array_equal(rec["acc_y"].values, data[:, 1])
    assert rec.attrs["sample_rate_hz"] == 12000.0
    assert rec.attrs["sample_rate_source"] == "file name: 12k"
    assert rec.attrs["speed_rpm"] == 1500.0


@pytest.mark.parametrize("binary", [1, 0])
def test_uff58(tmp_path, binary):
    import pyuff

    data = signals()
    t = np.arange(N) / FS
    path = tmp_path / "rec.uff"
    sets = [pyuff.prepare_58(binary=binary, func_type=1, rsp_node=i + 1, rsp_dir=3,
                             ref_node=0, ref_dir=0, data=data[:, i], x=t, id1=name,
                             rsp_ent_name="acc", ref_ent_name="none", abscissa_spacing=1,
                             abscissa_spec_data_type=17, ordinate_spec_data_type=12,
                             orddenom_spec_data_type=0, ordinate_axis_units_lab="m/s^2",
                             abscissa_axis_units_lab="s", abscissa_inc=1 / FS,
                             abscissa_min=0.0)
            for i, name in enumerate(("bearing x", "bearing y"))]
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    rec = read_record(path)
    assert channels(rec) == ["bearing_x", "bearing_y"]
    assert rec.attrs["sample_rate_hz"] == pytest.approx(FS, rel=1e-9)
    assert rec["bearing_y"].attrs["units"] == "m/s^2"
    if binary:
        np.testing.assert_array_equal(rec["bearing_y"].values, data[:, 1])
    else:  # ASCII: 12 significant digits
        np.testing.assert_allclose(rec["bearing_y"].values, data[:, 1], rtol=0, atol=1e-10)


def test_tdms(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    data = signals()
    path = tmp_path / "rec.tdms"
    with TdmsWriter(str(path)) as writer:
        writer.write_segment([ChannelObject("accel", name, data[:, i],
                                            properties={"wf_increment": 1 / FS,
                                                        "unit_string": "g"})
                              for i, name in enumerate(("DE", "FE"))])
    rec = read_record(path, channel="fe")
    assert channels(rec) == ["FE"] and rec.attrs["reader"] == "nptdms.TdmsFile.read"
    np.testing.assert_array_equal(rec["FE"].values, data[:, 1])
    assert rec["FE"].attrs["units"] == "g" and rec.attrs["sample_rate_hz"] == pytest.approx(FS)


def test_a_record_saved_as_netcdf_reads_back_with_its_provenance(tmp_path):
    from scipy.io import savemat

    from analysis.io import save_dataset

    data = signals()
    mat = tmp_path / "rec.mat"
    savemat(mat, {"a": data[:, 0], "b": data[:, 1]})
    first = read_record(mat, fs=FS, rpm="1500")
    save_dataset(first, tmp_path / "rec.nc")
    back = read_record(tmp_path / "rec.nc")
    np.testing.assert_array_equal(back["b"].values, data[:, 1])
    for key in ("sha256", "reader", "source_file", "original_names", "speed_rpm",
                "speed_source", "sample_rate_hz"):
        assert back.attrs[key] == first.attrs[key], key
    assert back.attrs["saved_file"] == str(tmp_path / "rec.nc")


def test_a_simulated_run_is_not_a_record(tmp_path):
    import xarray as xr

    from analysis.io import save_dataset

    save_dataset(xr.Dataset({"x": ("t", np.zeros(4))}, coords={"t": np.arange(4.0)},
                            attrs={"model": "vakharia2015"}), tmp_path / "r.nc")
    with pytest.raises(InputError, match="is a simulated result of vakharia2015, not a "
                                         "measured record"):
        read_record(tmp_path / "r.nc")


# ------------------------------------------------------------------------- speed


def test_tacho_pulses_give_the_speed_of_a_run_up(tmp_path):
    """A once-per-revolution pulse train of a shaft from 600 to 1200 rpm (the angle is the
    exact integral of the speed): the speed read back is that ramp, within 0.5 %."""
    fs, T = 10000.0, 4.0
    t = np.arange(int(fs * T)) / fs
    rpm = 600 + 150 * t
    turns = (600 * t + 75 * t ** 2) / 60  # ∫ rpm/60 dt
    tacho = (np.mod(turns, 1.0) < 0.05).astype(float) * 5.0
    tacho += 0.05 * np.random.default_rng(1).standard_normal(t.size)
    path = tmp_path / "runup.csv"
    np.savetxt(path, np.column_stack([t, np.sin(2 * np.pi * turns), tacho]), delimiter=",",
               header="t,acc,tacho", comments="")
    rec = read_record(path, tacho="tach")
    assert rec.attrs["speed_source"] == "tacho: tacho"
    assert rec.attrs["tacho_pulses"] == 59  # turns 1 … 59 (t = 0 starts high: no edge)
    inside = (t > 0.5) & (t < 3.5)
    np.testing.assert_allclose(rec["speed_rpm"].values[inside], rpm[inside], rtol=5e-3)
    assert record_speed_hz(rec) == pytest.approx(np.mean(rpm) / 60, rel=0.01)
    pulses = tacho_pulses(tacho, fs)
    assert np.all(np.abs(np.interp(pulses, t, turns) - np.round(np.interp(pulses, t, turns)))
                  < 2e-3)


def test_a_speed_table(tmp_path):
    data = signals(1)
    path = tmp_path / "rec.csv"
    np.savetxt(path, data, delimiter=",")
    table = tmp_path / "speed.csv"
    table.write_text("t_s,speed_rpm\n0,1000\n0.5,2000\n")
    rec = read_record(path, fs=FS, rpm=str(table))
    assert rec.attrs["speed_source"] == "speed table"
    np.testing.assert_allclose(rec["speed_rpm"].values, 1000 + 2000 * rec["t"].values)
    short = tmp_path / "short.csv"
    short.write_text("t_s,speed_rpm\n0,1000\n0.2,2000\n")
    with pytest.raises(InputError, match=r"^rpm: the speed table's last t_s \(0.2 s\) must "
                                         r"reach the end of the record \(0.4995 s\)$"):
        read_record(path, fs=FS, rpm=str(short))


# ------------------------------------------------------------------------- bad input


def _csv(tmp_path, k=2):
    path = tmp_path / "rec.csv"
    np.savetxt(path, signals(k), delimiter=",", header="DE,FE", comments="")
    return path


@pytest.mark.parametrize("options, message", [
    (dict(channel="XY"), r"^channel: no channel 'XY' in '.*rec.csv'; channels: DE, FE$"),
    (dict(channel="*"), r"^channel: '\*' matches 2 channels .*; give one of DE, FE$"),
    (dict(rpm=0), r"^rpm: must be a finite number > 0 rpm, got 0$"),
    (dict(rpm="nan"), r"^rpm: must be a finite number > 0 rpm, got nan$"),
    (dict(rpm=math.inf), r"^rpm: must be a finite number > 0 rpm, got inf$"),
    (dict(fs=0), r"^fs: must be a finite number > 0 Hz, got 0$"),
    (dict(tacho="FE", rpm=1000), r"^tacho: give --rpm or --tacho, not both$"),
    (dict(units="furlong"), r"^units: units must be one of g, m/s\^2, .*got 'furlong'$"),
    (dict(scale=0), r"^scale: must be a finite number other than 0, got 0$"),
])
def test_bad_options_are_one_line_naming_the_option(tmp_path, options, message):
    with pytest.raises(InputError, match=message) as err:
        read_record(_csv(tmp_path), fs=options.pop("fs", FS), **options)
    assert err.value.field == message[1:].partition(":")[0]  # the command line names its option


def test_a_tacho_without_pulses(tmp_path):
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([signals(1)[:, 0], np.full(N, 2.5)]), delimiter=",",
               header="acc,tacho", comments="")
    with pytest.raises(InputError, match=r"^tacho: channel tacho has 0 pulse\(s\)"):
        read_record(path, fs=FS, tacho="tacho")


@pytest.mark.parametrize("speed", [0.0, math.nan])
def test_a_file_speed_of_zero_or_nan(tmp_path, speed):
    from scipy.io import savemat

    path = tmp_path / "rec.mat"
    savemat(path, {"X1_DE_time": signals(1), "X1RPM": np.array([[speed]])})
    with pytest.raises(InputError, match=r"its speed X1RPM is (0|nan) rpm; give the speed "
                                         r"with --rpm or --tacho$"):
        read_record(path, fs=FS)
    assert read_record(path, fs=FS, rpm=1000).attrs["speed_rpm"] == 1000.0


@pytest.mark.parametrize("suffix, what", [(".mat", "MATLAB"), (".wav", "WAV"),
                                          (".tdms", "TDMS"), (".uff", "UFF"),
                                          (".nc", "netCDF")])
def test_unreadable_and_truncated_files(tmp_path, suffix, what):
    from scipy.io import savemat, wavfile

    junk = tmp_path / f"junk{suffix}"
    junk.write_bytes(b"\x00\x01 not a record " * 40)
    with pytest.raises(InputError, match=r"^(record|result file): .*junk.* (not a readable|"
                                         r"holds no)"):
        read_record(junk, fs=FS)
    good = tmp_path / f"good{suffix}"
    if suffix == ".mat":
        savemat(good, {"a": signals(1)})
    elif suffix == ".wav":
        wavfile.write(good, int(FS), signals(1)[:, 0].astype(np.float32))
    else:
        return
    cut = tmp_path / f"cut{suffix}"
    cut.write_bytes(good.read_bytes()[:len(good.read_bytes()) // 2])
    with pytest.raises(InputError, match=f"^record: .*cut.* is not a readable {what} file"):
        read_record(cut, fs=FS)


def test_missing_and_unknown_files(tmp_path):
    with pytest.raises(InputError, match=r"^record: '.*none.mat' does not exist$"):
        read_record(tmp_path / "none.mat")
    (tmp_path / "a.xyz").write_text("1,2\n")
    with pytest.raises(InputError, match=r"^record: .* suffix \(.xyz\) no reader knows; "
                                         r"records are read from .csv, .tsv"):
        read_record(tmp_path / "a.xyz")


def test_a_missing_library_names_the_install_line(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pyuff", None)
    (tmp_path / "a.uff").write_text("    -1\n")
    with pytest.raises(InputError, match=r"needs the Python package pyuff; install it with "
                                         r"python3 -m pip install -e '\.\[measured\]'$"):
        read_record(tmp_path / "a.uff")


# ------------------------------------------------------------------------- CWRU


@needs_cwru
def test_cwru_records():
    rec = read_record(IR)
    assert channels(rec) == ["DE", "FE", "BA"]
    assert [rec[c].attrs["units"] for c in channels(rec)] == ["g"] * 3
    assert rec.attrs["sample_rate_hz"] == 12000.0
    assert rec.attrs["sample_rate_source"] == "file name: 12k"
    assert rec.attrs["speed_rpm"] == 1797.0 and rec.attrs["speed_source"] == "file: X105RPM"
    assert pick_channel(rec, "DE") == "DE" and pick_channel(rec, "X105_FE_time") == "FE"
    assert rec.sizes["t"] == 121265
    ball = read_record(BALL)
    assert channels(ball) == ["DE"] and record_speed_hz(ball) is None
    assert read_record(OR, channel="FE").attrs["speed_source"] == "file: X294RPM"
    assert read_record(BALL, fs=48000).attrs["sample_rate_hz"] == 48000.0


# ------------------------------------------------------------------------- CLI


def _invoke(*args):
    from analysis.cli import app

    return CliRunner().invoke(app, list(map(str, args)))


def test_record_info(tmp_path):
    path = _csv(tmp_path)
    res = _invoke("record", "info", path, "--fs", FS, "--rpm", 1500, "--units", "g")
    assert res.exit_code == 0, res.output
    assert f"{path}: 2 channel(s), 2000 Hz (--fs), {N} samples = 0.5 s" in res.output
    assert "speed: 1500 rpm (--rpm)" in res.output and "DE  g" in res.output
    res = _invoke("record", "info", path, "--fs", FS, "--json")
    report = json.loads(res.output)
    assert report["speed_rpm"] is None and report["samples"] == N
    assert [c["name"] for c in report["channels"]] == ["DE", "FE"]
    assert report["channels"][1]["max"] == pytest.approx(signals()[:, 1].max())


def test_record_info_refusals_are_one_line_exit_2(tmp_path):
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([signals(1)[:, 0], np.full(N, 2.5)]), delimiter=",",
               header="DE,FE", comments="")
    before = sorted(tmp_path.iterdir())
    for args, text in ((("--fs", 0), "error: --fs: must be a finite number > 0 Hz, got 0"),
                       ((), "error: record: '" + str(path) + "' states no sampling rate; "
                            "give --fs HZ"),
                       (("--fs", FS, "--tacho", "FE"), "error: --tacho: channel FE has")):
        res = _invoke("record", "info", path, *args)
        assert res.exit_code == 2, res.output
        assert res.output.startswith(text) and res.output.count("\n") == 1, res.output
    assert sorted(tmp_path.iterdir()) == before


# ------------------------------------------------------------------------- in the commands

BPFO_6205 = 3.5848  # the CWRU data centre's BPFO of the 6205-2RS, x shaft speed
RPM = 1800.0


def impacts(tmp_path, slip: float = 0.003, fs: float = 12000.0, seconds: float = 2.0):
    """An outer-race fault as an accelerometer sees it: impacts at BPFO (slipping by
    ``slip``) each ringing a 3 kHz resonance (damping ratio 0.05), in seeded white noise;
    written to CSV with its time column. Returns (path, the impact rate in Hz)."""
    rate = BPFO_6205 * RPM / 60 * (1 - slip)
    t = np.arange(int(fs * seconds)) / fs
    ring = np.exp(-0.05 * 2 * np.pi * 3000 * t[:120]) * np.sin(2 * np.pi * 3000 * t[:120])
    pulses = np.zeros(t.size)
    pulses[np.round(np.arange(0.01, seconds - 0.02, 1 / rate) * fs).astype(int)] = 1.0
    acc = np.convolve(pulses, ring)[:t.size] + 0.05 * np.random.default_rng(3).standard_normal(
        t.size)
    path = tmp_path / "outer.csv"
    np.savetxt(path, np.column_stack([t, acc]), delimiter=",", header="t,acc [g]",
               comments="", fmt="%.10g")
    return path, rate


def test_spectrum_envelope_of_a_record_names_bpfo(tmp_path):
    path, rate = impacts(tmp_path)
    res = _invoke("spectrum", path, "--envelope", "--bearing", "6205-cwru", "--rpm", RPM,
                  "--json", "--max-peaks", "4")
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    envelope = report["envelopes"][0]
    top = envelope["peaks"][0]
    assert top["label"] == "BPFO" and abs(top["frequency_hz"] - rate) < 0.5
    assert report["faults"][""]["BPFO"] == pytest.approx(BPFO_6205 * RPM / 60, rel=1e-4)
    assert envelope["note"].startswith("a measured record: the band is the measured signal's")
    assert envelope["band_hz"][0] < 3000 < envelope["band_hz"][1]  # the ringing resonance
    assert report["provenance"]["kind"] == "record"


def test_spectrum_of_a_record_refusals(tmp_path):
    import xarray as xr

    from analysis.io import save_dataset

    path, _ = impacts(tmp_path, seconds=0.5)
    run = tmp_path / "run.nc"
    save_dataset(xr.Dataset({"x": ("t", np.zeros(8))}, coords={"t": np.arange(8.0)},
                            attrs={"model": "vakharia2015"}), run)
    before = sorted(tmp_path.iterdir())
    for args, text in (
            ((path, "--envelope", "--bearing", "6205-cwru"),
             "error: spectrum: the defect frequencies of 6205-cwru need the shaft speed, and "
             f"'{path}' has none; give --rpm or --tacho"),
            ((path, "--faults", "--rpm", RPM), "error: --bearing: spectrum names a measured "
                                               "record's lines by a bearing's defect"),
            ((path, "--var", "x"), f"error: --var: '{path}' is a measured record: choose its "
                                   "channels with --channel"),
            ((path, "--channel", "probe", "-o", tmp_path / "f.png"),
             f"error: --channel: no channel 'probe' in '{path}'; channels: acc"),
            ((path, "--rpm", 0), "error: --rpm: must be a finite number > 0 rpm, got 0"),
            ((run, "--channel", "DE"), f"error: --channel: only for a measured record; '{run}' "
                                       "is a simulated run")):
        res = _invoke("spectrum", *args)
        assert res.exit_code == 2, res.output
        assert res.output.startswith(text) and res.output.count("\n") == 1, res.output
    assert sorted(tmp_path.iterdir()) == before


def test_spectrum_of_a_saved_record_names_x(tmp_path):
    """A record saved as netCDF and read back by `spectrum`: a 1X tone is named X."""
    from analysis.io import save_dataset

    t = np.arange(4000) / FS
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, np.sin(2 * np.pi * 25 * t)]), delimiter=",",
               header="t,acc [m/s2]", comments="")
    save_dataset(read_record(path, rpm=1500), tmp_path / "rec.nc")
    res = _invoke("spectrum", tmp_path / "rec.nc", "--json", "--max-peaks", "1")
    assert res.exit_code == 0, res.output
    peak = json.loads(res.stdout)["peaks"][0]
    assert peak["label"] == "X" and peak["amplitude"] == pytest.approx(1.0, rel=1e-3)


def _runup(tmp_path, fs=4000.0, seconds=6.0):
    """A run-up 600 -> 1800 rpm (the shaft angle is the exact integral of the speed): an
    accelerometer with a 1X line of 1 g and a line of 0.5 g at order 3.2, a once-per-revolution
    tacho, and two proximity probes x = 20 cos, y = 10 sin of the shaft angle (µm)."""
    t = np.arange(int(fs * seconds)) / fs
    turns = (600 * t + 100 * t ** 2) / 60
    acc = np.sin(2 * np.pi * turns) + 0.5 * np.sin(2 * np.pi * 3.2 * turns)
    tacho = (np.mod(turns, 1.0) < 0.05) * 5.0
    path = tmp_path / "runup.csv"
    np.savetxt(path, np.column_stack([t, acc, tacho, 20 * np.cos(2 * np.pi * turns),
                                      10 * np.sin(2 * np.pi * turns)]), delimiter=",",
               header="t,acc [g],tacho [V],px [um],py [um]", comments="", fmt="%.10g")
    return path


def test_waterfall_of_a_run_up_record_with_a_tacho(tmp_path):
    path = _runup(tmp_path)
    res = _invoke("waterfall", path, "--channel", "acc", "--tacho", "tacho", "--orders",
                  "--json", "--bearing", "6205-cwru")
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    peaks = {round(p["order"], 2): p for p in report["orders"]["peaks"]}
    assert peaks[1.0]["amplitude"] == pytest.approx(1.0, rel=0.02)
    assert peaks[3.2]["amplitude"] == pytest.approx(0.5, rel=0.02)
    names = {line["name"] for line in report["lines"]}
    assert {"X", "2X", "FTF", "BPFO", "BPFI", "BSF"} <= names
    speeds = report["lines"][0]["speed_rpm"]
    assert 600 < speeds[0] < 800 and 1600 < speeds[-1] < 1800
    res = _invoke("waterfall", path, "--channel", "acc", "--rpm", 1200)
    assert res.exit_code == 2 and "needs a speed that changes along the record" in res.output


def test_orbit_and_full_spectrum_of_two_probes(tmp_path):
    """x = 20 cos θ, y = 10 sin θ (µm) is 15 µm of forward whirl and 5 µm backward."""
    t = np.arange(8000) / FS
    theta = 2 * np.pi * 25 * t
    path = tmp_path / "probes.csv"
    np.savetxt(path, np.column_stack([t, 20 * np.cos(theta), 10 * np.sin(theta)]),
               delimiter=",", header="t,px [um],py [um]", comments="")
    res = _invoke("plot", path, "--full-spectrum", "--channel", "px", "--channel", "py",
                  "--rpm", 1500, "-o", tmp_path / "full.png")
    assert res.exit_code == 0, res.output
    lines = [line.split() for line in res.stdout.splitlines()[1:3]]
    assert lines[0][:2] == ["forward", "25.00"] and float(lines[0][2]) == pytest.approx(15e-6,
                                                                                       rel=1e-3)
    assert lines[1][:2] == ["backward", "-25.00"] and float(lines[1][2]) == pytest.approx(
        5e-6, rel=1e-3)
    res = _invoke("plot", path, "--orbit", "--channel", "px", "--channel", "py", "-o",
                  tmp_path / "orbit.png")
    assert res.exit_code == 0 and (tmp_path / "orbit.png").stat().st_size > 10_000
    res = _invoke("plot", path, "--orbit", "--channel", "px", "-o", tmp_path / "o2.png")
    assert res.exit_code == 2 and "takes two channels (--channel X --channel Y), got 1" in \
        res.output and not (tmp_path / "o2.png").exists()


@needs_cwru
def test_cwru_inner_race_envelope_names_bpfi():
    res = _invoke("spectrum", IR, "--channel", "DE", "--envelope", "--bearing", "6205-cwru",
                  "--json", "--max-peaks", "3")
    assert res.exit_code == 0, res.output
    top = json.loads(res.stdout)["envelopes"][0]["peaks"][0]
    assert top["label"] == "BPFI"
    assert top["frequency_hz"] == pytest.approx(5.4152 * 1797 / 60, rel=0.005)


def test_record_save_keeps_scale_units_speed_and_provenance(tmp_path):
    from scipy.io import wavfile

    pcm = (signals(2) / 4 * 32767).astype(np.int16)
    wavfile.write(tmp_path / "acc.wav", int(FS), pcm)
    out = tmp_path / "acc.nc"
    res = _invoke("record", "save", tmp_path / "acc.wav", "--channel", "ch2", "--scale", 100,
                  "--units", "g", "--rpm", 1800, "-o", out)
    assert res.exit_code == 0, res.output
    back = read_record(out)
    assert channels(back) == ["ch2"] and back["ch2"].attrs["units"] == "g"
    np.testing.assert_array_equal(back["ch2"].values, pcm[:, 1] / 32768.0 * 100)
    assert back.attrs["speed_rpm"] == 1800.0 and back.attrs["reader"] == "scipy.io.wavfile.read"
    res = _invoke("record", "info", out)
    assert res.output.startswith(f"{out} (saved from {tmp_path / 'acc.wav'}): 1 channel(s), "
                                 "2000 Hz (file), 1000 samples")
    res = _invoke("record", "save", tmp_path / "acc.wav", "--channel", "ch9", "-o",
                  tmp_path / "no.nc")
    assert res.exit_code == 2 and not (tmp_path / "no.nc").exists()


def test_a_noise_channel_is_not_a_tacho(tmp_path):
    path = tmp_path / "rec.csv"
    noise = np.random.default_rng(0).standard_normal((N, 2))
    np.savetxt(path, noise, delimiter=",", header="acc,tacho", comments="")
    with pytest.raises(InputError, match=r"^tacho: channel tacho's \d+ pulses are not "
                                         r"regular .*is it a once-per-revolution tacho\?$"):
        read_record(path, fs=FS, tacho="tacho")


def test_a_run_up_record_in_a_spectrum_and_its_orbit_marks(tmp_path):
    """A spectrum of a run-up is refused (its lines smear); its orbit's once-per-revolution
    marks follow the tacho's speed: every mark near the shaft angle 0 (x = 20 µm, y = 0)."""
    from analysis.measured.runs import record_run
    from analysis.signal.orbit import revolution_marks

    path = _runup(tmp_path)
    res = _invoke("spectrum", path, "--channel", "acc", "--tacho", "tacho")
    assert res.exit_code == 2 and "the record's speed changes (" in res.output and \
        "use bearingdyn waterfall (--orders)" in res.output, res.output
    ds = record_run(read_record(path, tacho="tacho"), ["px", "py"], si=True,
                    changing_speed=None)
    marks = revolution_marks(ds)
    assert marks.sizes["k"] > 50
    angle = np.arctan2(marks["py"].values / 10e-6, marks["px"].values / 20e-6)
    # the speed profile (257 rows from the tacho's pulses) drifts by < 0.01 % of the 120
    # turns; marks at the mean speed would lie all round the orbit
    assert np.max(np.abs(angle)) < 0.06


def test_tdms_with_a_time_channel_and_uff_with_uneven_abscissa(tmp_path):
    import pyuff
    from nptdms import ChannelObject, TdmsWriter

    data = signals(1)[:, 0]
    t = np.arange(N) / FS
    with TdmsWriter(str(tmp_path / "rec.tdms")) as writer:
        writer.write_segment([ChannelObject("g", "Time", t), ChannelObject("g", "acc", data)])
    rec = read_record(tmp_path / "rec.tdms")
    assert channels(rec) == ["acc"] and rec.attrs["sample_rate_hz"] == pytest.approx(FS)
    np.testing.assert_array_equal(rec["acc"].values, data)
    uff = pyuff.prepare_58(binary=1, func_type=1, rsp_node=1, rsp_dir=1, ref_node=0,
                           ref_dir=0, data=data, x=t, id1="acc", abscissa_spacing=0,
                           orddenom_spec_data_type=0, ordinate_axis_units_lab="g")
    pyuff.UFF(str(tmp_path / "rec.uff")).write_sets([uff], mode="add")
    rec = read_record(tmp_path / "rec.uff")
    assert rec.attrs["sample_rate_hz"] == pytest.approx(FS, rel=1e-9)
    assert rec.attrs["sample_rate_source"] == "file: abscissa values"
    np.testing.assert_array_equal(rec["acc"].values, data)
