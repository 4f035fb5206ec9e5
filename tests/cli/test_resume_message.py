"""An interrupted sweep says what it kept and how to resume; a refused re-run names the
command that started the stored sweep (issue 25, item 10).

Real interruptions: a `bearingdyn sweep` / `chart` subprocess is sent SIGINT or SIGTERM
after some points are stored; its message is checked against the points found on disk
afterwards, and a re-run with the same command is checked to resume from them."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from analysis.io import open_result
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.store import PointStore, command_line

SWEEP = ["sweep", "vakharia2015", "--n-balls", "8", "--param", "speed_rpm", "--from", "4000",
         "--to", "6000", "--num", "40", "--transient", "0.05", "--samples", "30",
         "--executor", "serial"]
CHART = ["chart", "vakharia2015", "--x", "speed_rpm:4000:6000:6", "--y", "n_balls:7:9",
         "--transient", "0.05", "--revolutions", "30", "--no-lyapunov",
         "--executor", "serial", "--quiet"]
KEPT = re.compile(r"^(\d+) of (\d+) points kept in (\S+); run the same command to resume$",
                  re.M)


def _cli(args, cwd):
    return subprocess.Popen([sys.executable, "-m", "analysis.cli", *args], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _interrupt_after(proc, parts, points: int, signum: int) -> str:
    deadline = time.time() + 300
    while len(list(parts.glob("*.npz"))) < points and time.time() < deadline:
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.02)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    return err


def test_ctrl_c_mid_sweep_says_how_many_points_are_kept_and_a_rerun_resumes(tmp_path):
    err = _interrupt_after(_cli([*SWEEP, "-o", "r.nc"], tmp_path), tmp_path / "r.nc.parts",
                           5, signal.SIGINT)
    kept = len(list((tmp_path / "r.nc.parts").glob("*.npz")))
    match = KEPT.search(err)
    assert match, err
    assert int(match.group(1)) == kept and 5 <= kept < 40 and match.group(2) == "40"
    assert match.group(3) == "r.nc.parts" and "Traceback" not in err
    lines = err.splitlines()
    assert lines[-2].startswith("interrupted") and lines[-1] == match.group(0), err

    again = _cli([*SWEEP, "-o", "r.nc"], tmp_path)
    _, err = again.communicate(timeout=600)
    assert again.returncode == 0, err
    # the first progress line counts the stored points: the re-run started from them
    first = re.search(r"(\d+)/40 points", err)
    assert first and int(first.group(1)) >= kept, err
    assert not (tmp_path / "r.nc.parts").exists()
    assert open_result(tmp_path / "r.nc").sizes["speed_rpm"] == 40


def test_sigterm_mid_chart_says_how_many_points_are_kept(tmp_path):
    err = _interrupt_after(_cli([*CHART, "-o", "c.nc"], tmp_path), tmp_path / "c.nc.parts",
                           3, signal.SIGTERM)
    kept = len(list((tmp_path / "c.nc.parts").glob("*.npz")))
    match = KEPT.search(err)
    assert match, err
    assert int(match.group(1)) == kept and match.group(2) == "18", err


def test_a_refused_rerun_names_the_command_that_started_the_stored_sweep(tmp_path):
    first = [*SWEEP, "--quiet", "-o", "r.nc"]
    _interrupt_after(_cli(first, tmp_path), tmp_path / "r.nc.parts", 2, signal.SIGINT)
    changed = list(first)
    changed[changed.index("40")] = "41"
    res = subprocess.run([sys.executable, "-m", "analysis.cli", *changed], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert "different definition" in res.stderr and "differs in axis.values" in res.stderr
    assert res.stderr.rstrip().endswith(
        "finish it with the command that started it: bearingdyn " + " ".join(first)
        + ", or delete the folder"), res.stderr


def test_an_error_mid_chart_keeps_its_points_and_says_so(tmp_path, monkeypatch):
    """In-process: the third point's save fails (a disk error); the two stored are kept and
    the exception carries the note the command line prints; the same call then resumes and
    gives the chart of an uninterrupted run."""
    setting = Setting("vakharia2015", 8, {}, transient=0.05, samples=20, lyapunov=False)
    x, y = Axis.parse("speed_rpm:4000:6000:4"), Axis.parse("radial_load:6:50:1")
    save, calls = PointStore.save, []

    def failing(self, key, values):
        calls.append(key)
        if len(calls) == 3:
            raise OSError(28, "No space left on device", str(self.folder / f"{key}.npz"))
        save(self, key, values)

    monkeypatch.setattr(PointStore, "save", failing)
    with pytest.raises(OSError) as info:
        stability_chart(setting, x, y, tmp_path / "c.nc")
    assert info.value.__notes__ == [
        f"2 of 4 points kept in {tmp_path / 'c.nc.parts'}; run the same command to resume"]
    monkeypatch.setattr(PointStore, "save", save)
    resumed = stability_chart(setting, x, y, tmp_path / "c.nc")
    whole = stability_chart(setting, x, y, tmp_path / "whole.nc")
    for var in ("nature_code", "amplitude_x", "amplitude_y"):
        np.testing.assert_array_equal(resumed[var].values, whole[var].values)


def test_nothing_stored_means_no_note_and_no_folder(tmp_path, monkeypatch):
    setting = Setting("vakharia2015", 8, {}, transient=0.05, samples=20, lyapunov=False)
    x, y = Axis.parse("speed_rpm:4000:6000:2"), Axis.parse("radial_load:6:50:1")

    def failing(self, key, values):
        raise OSError(28, "No space left on device", str(self.folder / f"{key}.npz"))

    monkeypatch.setattr(PointStore, "save", failing)
    with pytest.raises(OSError) as info:
        stability_chart(setting, x, y, tmp_path / "c.nc")
    assert not getattr(info.value, "__notes__", None)
    assert not (tmp_path / "c.nc.parts").exists()


def test_command_line_as_typed():
    assert command_line(["/usr/bin/bearingdyn", "sweep", "a b"]) == "bearingdyn sweep 'a b'"
    assert command_line(["/x/analysis/cli/__main__.py", "chart"]) == "bearingdyn chart"
    assert command_line(["study.py", "--n", "3"]) == "study.py --n 3"
