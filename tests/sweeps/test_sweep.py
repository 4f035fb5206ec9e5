"""Sweeps: resume after a kill, Dask equals serial, lost workers retried, chart classes."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time

import cloudpickle
import numpy as np
import pytest

from analysis.io import open_result
from analysis.stability.periodic import shoot
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.executors import DaskExecutor, ProcessExecutor
from analysis.sweeps.grid import Axis, Setting
from tests.conftest import ROOT

SWEEP = ["sweep", "vakharia2015", "--n-balls", "8", "--param", "speed_rpm", "--from", "4000",
         "--to", "6000", "--num", "24", "--transient", "0.05", "--samples", "20",
         "--executor", "serial", "--quiet"]


def _cli(args, cwd):
    return subprocess.Popen([sys.executable, "-m", "analysis.cli", *args], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_interrupted_sweep_resumes_to_the_same_result(tmp_path):
    whole = _cli([*SWEEP, "-o", "whole.nc"], tmp_path)
    assert whole.wait(timeout=600) == 0, whole.stderr.read()

    proc = _cli([*SWEEP, "-o", "part.nc"], tmp_path)
    parts = tmp_path / "part.nc.parts"
    deadline = time.time() + 300
    while len(list(parts.glob("*.npz"))) < 5 and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)  # no chance to clean up
    proc.wait()
    done = len(list(parts.glob("*.npz")))
    assert 5 <= done < 24 and not (tmp_path / "part.nc").exists()

    again = _cli([*SWEEP, "-o", "part.nc"], tmp_path)
    assert again.wait(timeout=600) == 0, again.stderr.read()
    a, b = open_result(tmp_path / "whole.nc"), open_result(tmp_path / "part.nc")
    for var in ("x", "y", "vx", "vy", "amplitude_x", "amplitude_y", "t_start"):
        np.testing.assert_array_equal(a[var].values, b[var].values)
    assert not parts.exists()
    starts = a.t_start.values[0]  # time carried on from value to value (the forcing phase)
    assert starts[0] == 0.0 and np.all(np.diff(starts) > 0)


def test_resume_refuses_a_different_sweep(tmp_path):
    proc = _cli([*SWEEP, "-o", "r.nc"], tmp_path)
    parts = tmp_path / "r.nc.parts"
    while not list(parts.glob("*.npz")) and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    changed = [*SWEEP, "-o", "r.nc"]
    changed[changed.index("24")] = "25"
    res = subprocess.run([sys.executable, "-m", "analysis.cli", *changed], cwd=tmp_path,
                         capture_output=True, text=True)
    assert res.returncode == 2 and "different definition" in res.stderr


TINY = Setting("vakharia2015", 8, {}, transient=0.05, samples=10, lyapunov=True)


def test_dask_local_cluster_equals_serial(tmp_path):
    x, y = Axis.parse("speed_rpm:4000:6000:2"), Axis.parse("radial_load:6:50:2")
    serial = stability_chart(TINY, x, y, tmp_path / "serial.nc")
    executor = DaskExecutor(workers=2)
    try:
        dask = stability_chart(TINY, x, y, tmp_path / "dask.nc", executor=executor)
    finally:
        executor.close()
    for var in ("nature_code", "lyapunov", "ci95", "amplitude_x", "amplitude_y"):
        np.testing.assert_array_equal(serial[var].values, dask[var].values)


def kill_worker_once(args):
    """Dies (without cleanup) the first time it runs for a task, then succeeds."""
    marker, value = args
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return value * 2


def test_process_pool_retries_a_task_whose_worker_died(tmp_path):
    tasks = [(str(tmp_path / f"m{i}"), i) for i in range(3)]
    results = dict(ProcessExecutor(workers=2).run(kill_worker_once, tasks))
    assert {task[1]: r for task, r in results.items()} == {0: 0, 1: 2, 2: 4}


def test_dask_retries_a_task_whose_worker_died(tmp_path):
    import tests.sweeps.test_sweep as me

    cloudpickle.register_pickle_by_value(me)  # workers need not import the tests package
    executor = DaskExecutor(workers=2)
    try:
        results = dict(executor.run(kill_worker_once, [(str(tmp_path / "m"), 21)]))
    finally:
        executor.close()
        cloudpickle.unregister_pickle_by_value(me)
    assert list(results.values()) == [42]


def test_tiny_chart_has_the_classes_floquet_analysis_predicts(tmp_path):
    """Duffing (c = 0.2, F = 20): ω = 1.1 rad/s lies below the period doubling, ω = 1.3
    inside the period-2 interval. Shooting (independent of the classifier) says: a stable
    period-1 orbit at 1.1; at 1.3 the period-1 orbit is unstable through a multiplier < −1
    and a stable period-2 orbit exists."""
    params = dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2,
                  forcing_amplitude=20.0)
    rpm = 30 / math.pi
    at_11 = shoot("duffing", None, "shaft", dt=0.01, settle=200.0,
                  **params, speed_rpm=1.1 * rpm)
    at_13 = shoot("duffing", None, "shaft", dt=0.01, settle=200.0,
                  **params, speed_rpm=1.3 * rpm)
    assert at_11.stability == "stable"
    assert at_13.stability == "unstable" and at_13.multipliers.real.min() < -1
    base = {k: v for k, v in params.items() if k != "forcing_amplitude"}  # the y axis's
    setting = Setting("duffing", None, base, transient=300.0, samples=40, dt=0.01,
                      lyapunov=False)
    chart = stability_chart(setting, Axis.parse(f"speed_rpm:{1.1 * rpm}:{1.3 * rpm}:2"),
                            Axis.parse("forcing_amplitude:20:20:1"), tmp_path / "c.nc")
    assert list(chart.nature.values.ravel()) == ["periodic-1", "periodic-2"]


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def test_structure_axis_names_its_bearing():
    axis = Axis.parse("n_balls[left]:5:7")
    assert (axis.name, axis.values) == ("n_balls[left]", (5.0, 6.0, 7.0))
    assert Axis.linear("n_balls[right]", 6, 8.4, 5).values == (6.0, 7.0, 8.0)
    setting = Setting("two-bearing-rotor", {"right": 9}, {}, transient=0.1, samples=2)
    system = setting.system_at(**{"n_balls[left]": 6.0, "damping": 50.0})
    assert system.structure == system.model.structure({"right": 9, "left": 6})
    assert system.parameters["damping"] == 50.0
    with pytest.raises(ValueError, match="axis"):
        Axis.parse("n_balls[left]:7")


def test_followed_value_starts_at_the_same_forcing_angles():
    """With unbalance the forcing has the shaft and the VC frequency; a speed step scales
    both, so the start time of the next value (``follow_start``) gives the end state the
    shaft and cage angles it ended with, whichever section is followed."""
    from analysis.model import load_model
    from analysis.sweeps.diagram import follow_start

    model = load_model("vakharia2015")
    end = {"final": np.array([1e-6, 2e-6, 3e-3, 4e-3]), "t_final": 1.2345}
    for section in ("shaft", "vc"):
        setting = Setting("vakharia2015", 8, {}, transient=0.1, samples=10, section=section)
        start = follow_start(setting, setting.system_at(speed_rpm=5000.0), end,
                             setting.system_at(speed_rpm=5200.0))
        assert start.state == tuple(end["final"])
        for key in ("shaft_hz", "cage_hz", "vc_hz"):
            old, new = (model.frequencies(model.structure(8), model.parameters(
                {"speed_rpm": rpm})).as_dict()[key] for rpm in (5000.0, 5200.0))
            assert new * start.time == pytest.approx(old * end["t_final"], rel=1e-14)
