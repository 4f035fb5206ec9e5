"""`bearingdyn torus`: a single torus and a short branch as JSON (the layout of `hb
--json`), the run it samples read by `spectrum`, `poincare`, `plot` and `classify` (which
calls it quasi-periodic on its own), the figure, and the bad inputs (one line, exit 2,
nothing written)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.io import open_result
from tests.frequency.test_harmonic_balance import unforced_spec

ROTOR = ["vakharia2015", "--n-balls", "10", "--set", "speed_rpm=5000"]


def test_command_single_torus_run_and_figure(cli, tmp_path):
    out = cli("torus", *ROTOR, "--frequencies", "shaft,vc", "--harmonics", "6,3",
              "--lyapunov-duration", "2", "-o", str(tmp_path / "t.nc"), "--run",
              str(tmp_path / "run.nc"), "--duration", "1", "--plot", str(tmp_path / "t.png"),
              "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert len(data["points"]) == 1
    point = data["points"][0]
    assert set(point) == {"amplitude", "stable", "special", "residual"}
    assert set(point["amplitude"]) == {"x", "y", "vx", "vy"} and point["residual"] < 1e-10
    assert point["stable"] is True and point["special"] == ""
    assert data["provenance"]["model"] == "vakharia2015"
    assert data["provenance"]["frequencies"] == "shaft,vc"
    stored = open_result(tmp_path / "t.nc")
    assert np.allclose(np.ptp(stored.torus.values[0, 0]) / 2, point["amplitude"]["x"])
    assert (tmp_path / "t.png").stat().st_size > 0
    spectrum = cli("spectrum", str(tmp_path / "run.nc"), "--json")
    assert spectrum.returncode == 0, spectrum.stderr
    labels = [p["label"] for p in json.loads(spectrum.stdout)["peaks"] if p["direction"] == "x"]
    assert "VC+X" in labels and "X" in labels
    poincare = cli("poincare", str(tmp_path / "run.nc"), "--section", "shaft", "-o",
                   str(tmp_path / "p.png"))
    assert poincare.returncode == 0, poincare.stderr
    plot = cli("plot", str(tmp_path / "run.nc"), "-o", str(tmp_path / "run.png"))
    assert plot.returncode == 0, plot.stderr
    classify = cli("classify", str(tmp_path / "run.nc"))  # the sampled run, judged alone
    assert classify.returncode == 0 and classify.stdout.startswith("quasi-periodic"), \
        classify.stdout


def test_command_branch(cli, tmp_path):
    out = cli("torus", *ROTOR, "--harmonics", "4,2", "--param", "speed_rpm", "--from",
              "5000", "--to", "6000", "--max-points", "3", "--lyapunov-duration", "0",
              "-o", str(tmp_path / "b.nc"), "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    points = data["points"]
    assert len(points) == 3
    assert all(set(p) == {"speed_rpm", "amplitude", "stable", "special", "residual"}
               for p in points)
    assert not any(p["stable"] for p in points)  # λ1 not computed: not called stable
    assert data["stop_report"].startswith("stopped after max_points = 3")
    stored = open_result(tmp_path / "b.nc")
    assert np.allclose(stored.speed_rpm.values, [p["speed_rpm"] for p in points])


@pytest.mark.parametrize("args, words", [
    ([*ROTOR, "--harmonics", "0,4"], "--harmonics: each of H1,H2 must be a whole number"),
    ([*ROTOR, "--harmonics", "200,200"], "GiB"),
    ([*ROTOR, "--frequencies", "shaft,shaft"], "--frequencies: shaft and shaft are the same"),
    ([*ROTOR, "--frequencies", "shaft,vc[left]"], "no bearing 'left'"),
    ([*ROTOR, "--set", "outer_race_diameter=0.028107"], "are commensurate"),
    ([*ROTOR, "--param", "speed_rpm", "--from", "5000"], "give --to"),
    (["UNFORCED", "--frequencies", "shaft,param:linear_stiffness"], "has no forcing"),
    (["two-bearing-rotor", "--n-balls", "left=7", "--n-balls", "right=11", "--frequencies",
      "shaft,vc[left]", "--harmonics", "2,2", "--settle", "0.05"], "do not carry"),
])
def test_command_bad_inputs(cli, tmp_path, args, words):
    if args[0] == "UNFORCED":
        args = [unforced_spec(tmp_path), *args[1:]]
    target = tmp_path / "t.nc"
    out = cli("torus", *args, "-o", str(target), env={"BEARINGDYN_CACHE": str(tmp_path / "c")})
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], lines
    assert not target.exists()


def test_command_shooting_torus_json_run_and_figure(cli, tmp_path):
    """--method shooting: the JSON layout of --method hb, the Dataset read by torus_run
    (--run), the figure with the result's provenance in its PNG."""
    from PIL import Image

    out = cli("torus", *ROTOR, "--method", "shooting", "--points", "17",
              "--lyapunov-duration", "0", "-o", str(tmp_path / "c.nc"), "--run",
              str(tmp_path / "run.nc"), "--duration", "0.3", "--plot",
              str(tmp_path / "c.png"), "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    point = data["points"][0]
    assert set(point) == {"amplitude", "stable", "special", "residual"}
    assert point["residual"] < 1e-10 and set(point["amplitude"]) == {"x", "y", "vx", "vy"}
    assert data["provenance"]["solver"] == "shooting"
    stored = open_result(tmp_path / "c.nc")
    assert stored.attrs["points"] == 17 and stored.circle.shape == (4, 17)
    assert np.allclose(np.ptp(stored.torus.values[0, 0]) / 2, point["amplitude"]["x"])
    run = open_result(tmp_path / "run.nc")
    assert run.attrs["method"] == "torus" and run.sizes["t"] > 1000
    text = Image.open(tmp_path / "c.png").text
    assert text["model"] == "vakharia2015" and text["spec_sha256"] == stored.attrs["spec_sha256"]
    assert text["bearingdyn_version"] == stored.attrs["bearingdyn_version"]


def test_hb_figure_carries_the_provenance(cli, tmp_path):
    from PIL import Image

    from tests.frequency.test_harmonic_balance import DUFFING_ARGS

    out = cli("hb", "duffing", *DUFFING_ARGS, "--set", "speed_rpm=12", "--harmonics", "5",
              "-o", str(tmp_path / "one.nc"), "--plot", str(tmp_path / "one.png"))
    assert out.returncode == 0, out.stderr
    stored = open_result(tmp_path / "one.nc")
    text = Image.open(tmp_path / "one.png").text
    for key in ("model", "spec_file", "spec_sha256", "bearingdyn_version"):
        assert text[key] == str(stored.attrs[key]), key


@pytest.mark.parametrize("args, words", [
    ([*ROTOR, "--method", "shooting", "--points", "7"], "--points: must be a whole number >= 8"),
    ([*ROTOR, "--method", "shooting", "--points", "100000"], "GiB"),
    ([*ROTOR, "--method", "shooting", "--harmonics", "8,4"], "--harmonics: applies to "
                                                             "--method hb only"),
    ([*ROTOR, "--frequencies", "vc,shaft", "--points", "33"],  # the default there is hb
     "--points: applies to --method shooting only"),
    ([*ROTOR, "--method", "shooting", "--param", "speed_rpm", "--from", "5000"],
     "give --to"),
    ([*ROTOR, "--method", "shooting", "--frequencies", "vc,shaft"], "--method shooting needs"),
    ([*ROTOR, "--method", "fourier"], "--method: must be hb or shooting"),
])
def test_command_shooting_bad_inputs(cli, tmp_path, args, words):
    target = tmp_path / "t.nc"
    out = cli("torus", *args, "-o", str(target))
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], lines
    assert not target.exists()


def test_command_shooting_branch(cli, tmp_path):
    out = cli("torus", *ROTOR, "--method", "shooting", "--points", "33", "--param",
              "speed_rpm", "--from", "5000", "--to", "6000", "--max-points", "2",
              "-o", str(tmp_path / "b.nc"), "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    points = data["points"]
    assert len(points) == 2
    assert all(set(p) == {"speed_rpm", "amplitude", "stable", "special", "residual"}
               for p in points)
    assert not any(p["stable"] for p in points)  # λ1 not computed on a circle branch
    assert data["stop_report"].startswith("stopped after max_points = 2")
