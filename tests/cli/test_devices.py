"""`bearingdyn devices` and the --device / --mapper options of basins and attractors: what
the machine offers, and bad input in one line, exit 2, nothing written."""

from __future__ import annotations

import json

import pytest

from analysis.integrate.kernels.devices import gpu_problem

DUFFING = ("--speed-rpm", str(1.40 * 30 / 3.141592653589793), "--set", "linear_stiffness=1",
           "--set", "cubic_stiffness=0.5", "--set", "damping=0.1",
           "--set", "forcing_amplitude=0.3")
NO_GPU = gpu_problem()


def nothing_written(tmp_path) -> bool:
    return not any(tmp_path.iterdir())


def test_devices_lists_the_cores_and_says_why_there_is_no_gpu(cli):
    res = cli("devices", "--json")
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    kinds = [d["kind"] for d in info["devices"]]
    assert kinds[0] == "cpu" and info["devices"][0]["cores"] >= 1
    assert ("gpu" in kinds) == (info["gpu_problem"] is None)
    assert info["auto"]["min_members"] >= 1
    text = cli("devices")
    assert text.returncode == 0 and text.stdout.startswith("cpu: ")


def test_an_unknown_device_is_one_line_exit_2_nothing_written(cli, tmp_path):
    res = cli("basins", "duffing", "--x", "x:-3:3:4", "--y", "vx:-3:3:4", "--device", "tpu",
              "-o", "b.nc", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and "--device" in res.stderr and "tpu" in res.stderr
    assert nothing_written(tmp_path)


@pytest.mark.skipif(NO_GPU is None, reason="a GPU is visible: --device gpu would run")
def test_device_gpu_without_a_gpu_names_what_is_missing(cli, tmp_path):
    res = cli("attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--device", "gpu",
              "-o", "a.nc", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1
    assert "--device gpu" in res.stderr and "pip install bearingdyn[gpu]" in res.stderr
    assert nothing_written(tmp_path)


def test_an_ensemble_beyond_memory_is_refused_before_any_work(cli, tmp_path):
    res = cli("attractors", "duffing", "--samples", "200000000", "--box", "x:-3:3",
              "--mapper", "features", "--device", "cpu", "-o", "a.nc", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.startswith("error: samples: 200000000 initial states would need")
    assert res.stderr.count("\n") == 1
    assert nothing_written(tmp_path)


def test_an_unknown_mapper_is_one_line(cli, tmp_path):
    res = cli("attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--mapper",
              "kmeans", "-o", "a.nc", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "mapper" in res.stderr
    assert nothing_written(tmp_path)


def test_attractors_with_the_featurizing_mapper_on_the_cores(cli, tmp_path):
    res = cli("attractors", "duffing", *DUFFING, "--samples", "40", "--box", "x:-3:3",
              "--box", "vx:-3:3", "--mapper", "features", "--device", "cpu", "--json",
              "-o", "a.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    found = [a for a in out["attractors"] if a["id"] > 0]
    assert len(found) == 2  # the two orbits of the resonance
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.nc"]  # the store removed


def test_chart_takes_the_device_option(cli, tmp_path):
    res = cli("chart", "balanced-rotor", "--x", "speed_rpm:7000:8000:2", "--y", "n_balls:8:8",
              "--device", "tpu", "-o", "c.nc", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "--device" in res.stderr
    assert nothing_written(tmp_path)


def test_sweep_takes_the_device_option_without_follow_only(cli, tmp_path):
    base = ("sweep", "vakharia2015", "--param", "speed_rpm", "--from", "4000", "--to", "6000",
            "--num", "4", "-o", "s.nc")
    res = cli(*base, "--device", "cpu", cwd=tmp_path)  # a followed sweep
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "--device" in res.stderr and "--no-follow" in res.stderr
    res = cli(*base, "--no-follow", "--device", "xpu", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "xpu" in res.stderr
    assert nothing_written(tmp_path)


CHART = ("chart", "vakharia2015", "--x", "speed_rpm:4000:5000:4", "--y", "n_balls:8:8",
         "-o", "c.nc")
SWEEP = ("sweep", "vakharia2015", "--param", "speed_rpm", "--from", "4000", "--to", "5000",
         "--num", "4", "--no-follow", "-o", "d.nc")
NO_COMPILER = {"BEARINGDYN_CC": "/nonexistent/bin/cc"}
"""A C compiler that is not there: no member kernel can be built (none is cached for it)."""


@pytest.mark.skipif(NO_GPU is None, reason="a GPU is visible: --device gpu would run")
@pytest.mark.parametrize("command", [CHART, SWEEP], ids=["chart", "sweep"])
def test_chart_and_sweep_refuse_gpu_first_in_one_line(cli, tmp_path, command):
    """Before the estimate's probe and any executor: one line, the install hint once."""
    res = cli(*command, "--device", "gpu", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: --device gpu: {NO_GPU}; ")
    assert res.stderr.count("pip install") == 1 and res.stdout == ""
    assert nothing_written(tmp_path)  # no output file, no .parts folder


@pytest.mark.parametrize("device", ["cpu", pytest.param("gpu", marks=pytest.mark.skipif(
    NO_GPU is not None, reason=f"--device gpu: {NO_GPU}"))])
@pytest.mark.parametrize("command", [CHART, SWEEP], ids=["chart", "sweep"])
def test_a_kernel_that_cannot_be_built_is_one_line_naming_model_and_reason(cli, tmp_path,
                                                                           command, device):
    res = cli(*command, "--device", device, cwd=tmp_path, env=NO_COMPILER)
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: --device {device}: the member kernel of model "
                                 "'vakharia2015' with N_b ")
    assert res.stderr.rstrip().endswith("cannot be built: C compiler '/nonexistent/bin/cc' "
                                        "not found")
    assert nothing_written(tmp_path)


def test_a_chart_on_auto_without_a_kernel_runs_point_by_point(cli, tmp_path):
    res = cli("chart", "vakharia2015", "--x", "speed_rpm:4000:5000:2", "--y", "n_balls:8:8",
              "--transient", "0.05", "--revolutions", "10", "--executor", "serial",
              "-o", "c.nc", cwd=tmp_path, env=NO_COMPILER)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.nc"]
