"""`bearingdyn uncertainty` end to end (tiny): the cost said first, the JSON layout of issue
40 (strict), the file and figure, and bad input as one line with exit code 2, nothing
written."""

from __future__ import annotations

import json

import pytest

from analysis.io import open_result

TINY = ("--transient-revolutions", "10", "--revolutions", "40")


def test_cli_json_file_and_figure(cli, tmp_path):
    out, png = tmp_path / "unc.nc", tmp_path / "unc.png"
    res = cli("uncertainty", "vakharia2015", "--dist", "radial_clearance=uniform:5e-6:20e-6",
              "--dist", "damping=normal:200:20", "--param", "speed_rpm:5000:6000:2",
              "--samples", "2", *TINY, "-o", str(out), "--plot", str(png), "--json")
    assert res.returncode == 0, res.stderr
    head = res.stderr.splitlines()
    assert "2 draws -> 8 members x 2 values = 16 runs" in head[0]
    assert "RK4 steps" in res.stderr.split("runs/s")[0]  # the estimate before the progress
    doc = json.loads(res.stdout)
    assert [v["speed_rpm"] for v in doc["values"]] == [5000.0, 6000.0]
    for value in doc["values"]:
        assert sum(value["probability"].values()) == pytest.approx(1.0)
        for name, (lo, hi) in value["ci95"].items():
            assert lo <= value["probability"][name] <= hi
        assert {"x", "y"} == set(value["amplitude"])
    assert {"chaotic", "amplitude"} == set(doc["sobol"])
    assert {"radial_clearance", "damping", "speed_rpm"} == set(doc["sobol"]["chaotic"][0])
    assert doc["provenance"]["model"] == "vakharia2015"
    ds = open_result(out)
    assert ds.attrs["kind"] == "uncertainty" and ds.sizes["draw"] == 8
    assert png.stat().st_size > 10_000
    assert not (tmp_path / "unc.nc.parts").exists()


BASE = ("uncertainty", "vakharia2015", "--n-balls", "8", "--samples", "2")


@pytest.mark.parametrize(("args", "words"), [
    (("--dist", "damping=uniform:300:100"), "negative spread"),
    (("--dist", "damping=normal:200:-1"), "negative spread"),
    (("--dist", "rotor_mass=uniform:-0.5:1"), "allowed range"),
    (("--dist", "damping=weibull:1:2"), "unknown distribution"),
    (("--dist", "damping=uniform:100:300", "--set", "damping=200"), "--set"),
])
def test_bad_input_is_one_line_exit_2(cli, tmp_path, args, words):
    out = tmp_path / "u.nc"
    res = cli(*BASE, *args, "-o", str(out))
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and words in lines[0], lines
    assert not out.exists() and not (tmp_path / "u.nc.parts").exists()


def test_zero_samples_and_no_axis(cli, tmp_path):
    res = cli("uncertainty", "vakharia2015", "--dist", "damping=uniform:100:300",
              "--n-balls", "8", "--samples", "0")
    assert res.returncode == 2 and "--samples" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    res = cli("uncertainty", "vakharia2015", "--dist", "damping=uniform:100:300",
              "--samples", "2")
    assert res.returncode == 2 and "--param/--n-balls" in res.stderr


def test_cli_resumes_a_stored_block(cli, tmp_path):
    """A block stored before (as an interrupted command leaves it) is read back by the
    command, not computed again: mark it and find the mark in the file."""
    import numpy as np

    from analysis.inference.simulate import RunSettings
    from analysis.sweeps.store import PointStore
    from analysis.uncertainty.study import evaluate_members, prepare

    out = tmp_path / "unc.nc"
    study = prepare("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6"], n_balls=[8],
                    samples=2, block=3,
                    settings=RunSettings(transient_revolutions=10, revolutions=40))
    store = PointStore(out, study.definition(), lock=True)
    block = evaluate_members(study.system(8), study.names, study.design.values[3:6],
                             study.settings)
    block["lambda1"] = np.full(3, 4321.0)
    store.save("v0-r3", block)
    store.close()
    res = cli("uncertainty", "vakharia2015", "--dist", "radial_clearance=uniform:5e-6:20e-6",
              "--n-balls", "8", "--samples", "2", "--block", "3", *TINY, "-o", str(out))
    assert res.returncode == 0, res.stderr
    lam = open_result(out)["lambda1"].values[0]
    assert np.all(lam[3:] == 4321.0) and np.all(lam[:3] != 4321.0)
