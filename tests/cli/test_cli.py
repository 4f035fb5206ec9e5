"""The real ``bearingdyn`` command, run as a user runs it (subprocess, files on disk)."""

from __future__ import annotations

import hashlib
import json

import xarray as xr

from analysis.provenance import load_dataset
from tests.conftest import SPECS


def test_debug_shows_the_traceback(cli, tmp_path):
    res = cli("--debug", "simulate", "vakharia2015", "-o", "r.nc", "--n-balls", "2",
              cwd=tmp_path)
    assert res.returncode != 0 and "Traceback" in res.stderr


def test_generate_check_passes_on_committed_tree(cli):
    res = cli("generate", "--check")
    assert res.returncode == 0, res.stderr
    assert "matches its specs" in res.stdout


def test_simulate_spectrum_poincare_round_trip(cli, tmp_path):
    res = cli("simulate", "vakharia2015", "--n-balls", "6", "--duration", "1.2",
              "--transient", "0.2", "-o", "run.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    ds = load_dataset(tmp_path / "run.nc")
    assert ds.attrs["n_balls"] == 6 and ds.sizes["t"] == 100001
    assert not list(tmp_path.glob(".*.tmp")), "no temporary file left behind"

    res = cli("spectrum", "run.nc", "--json", "-o", "spec.png", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    labels = {p["label"] for p in report["peaks"] if p["direction"] == "x"}
    assert {"X", "VC"} <= labels
    assert (tmp_path / "spec.png").read_bytes()[:4] == b"\x89PNG"

    res = cli("poincare", "run.nc", "--section", "cage", "-o", "poin.png", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "points on the cage section" in res.stdout
    assert (tmp_path / "poin.png").stat().st_size > 10_000


def test_models_lists_the_shipped_models(cli):
    res = cli("models")
    assert res.returncode == 0
    for name in ("vakharia2015", "vakharia2015-consistent", "balanced-rotor"):
        assert name in res.stdout


def test_run_writes_the_paper_case(cli, tmp_path):
    res = cli("run", "-o", "out", "--n-balls", "6", "--n-balls", "10", "--duration", "0.7",
              "--transient", "0.2", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = tmp_path / "out"
    for nb in (6, 10):
        assert (out / f"nb{nb}.png").read_bytes()[:4] == b"\x89PNG"
        assert xr.open_dataset(out / f"nb{nb}.nc", engine="h5netcdf").attrs["n_balls"] == nb
    table = (out / "peaks.md").read_text()
    assert "| 6 | 199.3 |" in table and "| 10 | 332.2 |" in table
    peaks = json.loads((out / "peaks.json").read_text())
    assert [entry["n_balls"] for entry in peaks] == [6, 10]
    spec_digest = hashlib.sha256((SPECS / "vakharia2015.toml").read_bytes()).hexdigest()
    for entry in peaks:  # each entry carries the attrs of its own run file
        with xr.open_dataset(out / f"nb{entry['n_balls']}.nc", engine="h5netcdf") as ds:
            assert entry["provenance"]["n_balls"] == ds.attrs["n_balls"] == entry["n_balls"]
            assert entry["provenance"]["speed_rpm"] == ds.attrs["speed_rpm"]
        assert entry["provenance"]["spec_sha256"] == spec_digest


def test_atomic_write_follows_the_umask(tmp_path):
    import os

    from analysis.io import atomic_write

    target = atomic_write(tmp_path / "a.txt", lambda tmp: tmp.write_text("done"))
    umask = os.umask(0)
    os.umask(umask)
    assert target.read_text() == "done"
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]
