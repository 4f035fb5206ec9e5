"""Faults injected into real runs: what each kills or damages, and when, and what must survive.

- a second process on a sweep's output (refused; the first one's points untouched);
- stored points truncated or emptied between two runs of a sweep (recomputed; the result equals
  an uninterrupted sweep bit for bit);
- a grid value whose run blows up (recorded as its class; the sweep completes);
- the parent of a sweep's worker processes ended by SIGTERM or SIGKILL mid-sweep (the workers
  end too; a re-run resumes);
- a disk too small for a run (RLIMIT_FSIZE: one line before the write, exit 1, no file, an
  older file at the same path kept), and a write that fails half-way (an OSError inside
  ``atomic_write``: ``test_bad_inputs.test_crash_mid_write_leaves_nothing``);
- Ctrl-C (SIGINT) while a long run streams to its file (exit 130, no partial file);
- a refused sweep (nothing written at all);
- a blow-up inside a block of RK4 steps (found at its first bad sample, not at the block's end).
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.store import PointStore
from tests.conftest import run_cli

TINY = Setting("vakharia2015", None, {}, transient=0.02, samples=12, lyapunov=False)
X = Axis.parse("speed_rpm:3000:6000:3")
Y = Axis.parse("n_balls:7:8")
CHART = ("chart", "vakharia2015", "--x", "speed_rpm:1000:6000:30", "--y", "n_balls:7:8",
         "--transient", "0.3", "--revolutions", "100", "--no-lyapunov", "-o", "c.nc",
         "--quiet")


def _popen(args: tuple[str, ...], cwd: Path, **kwargs) -> subprocess.Popen:
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    return subprocess.Popen([sys.executable, "-m", "analysis.cli", *args], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **kwargs)


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _wait_for(condition, timeout: float, every: float = 0.1) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(every)
    return condition()


# ---------------------------------------------------------------- sweeps

def test_a_second_process_on_the_same_output_is_refused(tmp_path):
    holder = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    try:
        before = sorted(p.name for p in (tmp_path / "c.nc.parts").iterdir())
        res = run_cli(*CHART, cwd=tmp_path)
        assert res.returncode == 2
        assert res.stderr.strip().startswith("error: output: another bearingdyn process is "
                                             "writing 'c.nc'"), res.stderr
        assert res.stderr.count("\n") == 1
        assert sorted(p.name for p in (tmp_path / "c.nc.parts").iterdir()) == before
    finally:
        holder.close()
    # released: the kernel holds flock per open file, so the next one gets it
    PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True).close()


def test_damaged_points_are_recomputed_and_the_chart_equals_an_uninterrupted_one(tmp_path):
    reference = stability_chart(TINY, X, Y, tmp_path / "ref.nc")
    stored = []

    class Stop(Exception):
        pass

    def stop_after_three(done: int, total: int) -> None:
        if done >= 3:
            raise Stop

    with pytest.raises(Stop):
        stability_chart(TINY, X, Y, tmp_path / "c.nc", progress=stop_after_three)
    parts = sorted((tmp_path / "c.nc.parts").glob("*.npz"))
    assert len(parts) >= 3
    parts[0].write_bytes(b"")                                # a zero-byte part
    parts[1].write_bytes(parts[1].read_bytes()[:60])         # a truncated one
    chart = stability_chart(TINY, X, Y, tmp_path / "c.nc", on_damaged=stored.append)
    assert stored == [parts[0].stem, parts[1].stem]
    for name in ("nature_code", "amplitude_x", "amplitude_y", "period"):
        np.testing.assert_array_equal(chart[name].values, reference[name].values)
    assert not (tmp_path / "c.nc.parts").exists()


def test_a_value_that_blows_up_is_recorded_and_the_sweep_completes(tmp_path):
    """Duffing with a softening spring (cubic_stiffness = -1) escapes its well (the blow-up
    case of the catalogue); +1 and 0 are bounded. The recorded time is the one a run of that
    value alone reports."""
    setting = Setting("duffing", None, {}, transient=20.0, samples=40, dt=0.01,
                      lyapunov=False)
    from analysis.integrate.simulate import simulate

    with pytest.raises(SimulationError) as alone:  # the same value run by itself
        simulate("duffing", duration=30.0, transient=0.0, dt=0.01, cubic_stiffness=-1.0,
                 damping=0.2)
    when = str(alone.value).split(" (")[0].removeprefix("the motion ")
    chart = stability_chart(setting, Axis.parse("cubic_stiffness:-1:1:3"),
                            Axis.parse("damping:0.2:0.2:1"), tmp_path / "c.nc")
    nature = list(chart.nature.values.ravel())
    assert nature[0] == f"failed: {when} (displacement not finite or growing without bound)"
    assert int(chart.nature_code.values.ravel()[0]) == 0
    assert not any(n.startswith("failed") for n in nature[1:])
    assert np.isnan(chart.amplitude_x.values.ravel()[0])
    damped = Setting("duffing", None, {"damping": 0.2}, transient=20.0, samples=40, dt=0.01,
                     lyapunov=False)
    diagram = bifurcation_diagram(damped, Axis.linear("cubic_stiffness", -1, 1, 3),
                                  tmp_path / "d.nc")
    status = list(diagram.status.values.ravel())
    assert status[0].startswith(f"failed: {when}") and status[1:] == ["", ""]
    assert np.all(np.isnan(diagram.x.values[0, 0])) and np.isfinite(diagram.x.values[0, 1]).all()


def test_a_refused_sweep_writes_nothing(tmp_path):
    res = run_cli("sweep", "balanced-rotor", "--param", "speed_rpm", "--from", "1000", "--to",
                  "2000", "--num", "3", "--transient", "-1", "-o", "d.nc", cwd=tmp_path)
    assert res.returncode == 2 and "transient: must be a finite number >= 0 s" in res.stderr
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="the same on both axes"):
        stability_chart(TINY, X, Axis.parse("speed_rpm:1:2:2"), tmp_path / "c.nc")
    assert list(tmp_path.iterdir()) == []


def _descendants(pid: int) -> list[int]:
    found, todo = [], [pid]
    while todo:
        for child in _children(todo.pop()):
            found.append(child)
            todo.append(child)
    return found


@pytest.mark.parametrize("how, executor", [(signal.SIGTERM, "processes"),
                                           (signal.SIGKILL, "processes"),
                                           (signal.SIGKILL, "dask")],
                         ids=["SIGTERM", "SIGKILL", "SIGKILL-dask"])
def test_workers_end_with_their_parent_and_the_sweep_resumes(tmp_path, how, executor):
    """Processes: the pool's workers. Dask: the LocalCluster's nannies and workers (they
    notice the lost scheduler and stop; given 60 s here)."""
    proc = _popen((*CHART, "--workers", "2", "--executor", executor), tmp_path)
    assert _wait_for(lambda: len(_descendants(proc.pid)) >= 2, 90), "no workers started"
    time.sleep(3.0 if executor == "dask" else 0.0)
    workers = _descendants(proc.pid)
    time.sleep(1.0)
    proc.send_signal(how)
    proc.wait(timeout=30)
    if how == signal.SIGTERM:
        assert proc.returncode == 130 and "interrupted" in proc.stderr.read()
    else:
        assert proc.returncode == -signal.SIGKILL
    patience = 60 if executor == "dask" else 10
    assert _wait_for(lambda: not any(_alive(w) for w in workers), patience), \
        "workers outlived their parent"
    assert not (tmp_path / "c.nc").exists()
    stored = len(list((tmp_path / "c.nc.parts").glob("*.npz")))
    assert stored < 60
    res = run_cli(*CHART, "--workers", "2", cwd=tmp_path)  # the lock went with the parent
    assert res.returncode == 0, res.stderr
    with xr.open_dataset(tmp_path / "c.nc", engine="h5netcdf") as chart:
        assert chart.nature.size == 60 and "failed" not in " ".join(chart.nature.values.ravel())


def test_a_pool_worker_ignores_sigint():
    """The worker initializer makes SIGINT harmless in a worker: an idle worker that got a
    terminal's Ctrl-C printed a KeyboardInterrupt traceback of its own."""
    code = ("import os, signal, time\n"
            "from analysis.sweeps.executors import die_with_parent\n"
            "die_with_parent(os.getppid())\n"
            "os.kill(os.getpid(), signal.SIGINT)\n"
            "time.sleep(0.2)\n"
            "print('still here')\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0 and res.stdout == "still here\n", res.stderr


def test_ctrl_c_in_the_terminal_is_reported_once_by_the_parent(tmp_path):
    """A terminal's Ctrl-C reaches the whole process group, the pool's workers too: they
    ignore it (``die_with_parent``), the parent says ``interrupted`` once, and no worker
    prints a traceback; the workers end with the parent."""
    proc = _popen((*CHART, "--workers", "2", "--executor", "processes"), tmp_path,
                  start_new_session=True)
    assert _wait_for(lambda: len(_descendants(proc.pid)) >= 2, 90), "no workers started"
    workers = _descendants(proc.pid)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGINT)
    proc.wait(timeout=30)
    err = proc.stderr.read()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert err.count("interrupted") == 1, err
    assert _wait_for(lambda: not any(_alive(w) for w in workers), 10)


# ---------------------------------------------------------------- writes

def _limit_file_size(limit: int):
    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write fails (EFBIG) instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_a_full_disk_while_writing_gives_one_line_and_keeps_the_old_file(tmp_path):
    (tmp_path / "r.nc").write_text("an older result")
    proc = _popen(("simulate", "vakharia2015", "--duration", "1", "--transient", "0", "-o",
                   "r.nc"), tmp_path, preexec_fn=_limit_file_size(2_000_000))
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err
    assert err.startswith("error: output: 'r.nc' needs about 5.0 MiB") and err.count("\n") == 1
    assert "MiB are allowed per file (ulimit -f); nothing was written" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc"]
    assert (tmp_path / "r.nc").read_text() == "an older result"


def test_ctrl_c_while_a_long_run_streams_leaves_no_partial_file(tmp_path):
    (tmp_path / "r.nc").write_text("an older result")
    proc = _popen(("simulate", "vakharia2015", "--duration", "200", "--transient", "0",
                   "-o", "r.nc"), tmp_path)
    assert _wait_for(lambda: any(tmp_path.glob(".r.nc.*.tmp")), 120), "the write never began"
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.nc"]
    assert (tmp_path / "r.nc").read_text() == "an older result"


def test_a_streamed_run_equals_the_run_in_memory(tmp_path):
    from analysis.integrate.simulate import simulate, simulate_to_file
    from analysis.io import save_dataset

    for options in (dict(duration=0.3, transient=0.1), dict(duration=0.2, transient=0.05,
                                                              save_every=7)):
        save_dataset(simulate("vakharia2015", 8, **options), tmp_path / "a.nc")
        simulate_to_file("vakharia2015", tmp_path / "b.nc", 8, chunk=999, **options)
        with xr.open_dataset(tmp_path / "a.nc", engine="h5netcdf") as a, \
                xr.open_dataset(tmp_path / "b.nc", engine="h5netcdf") as b:
            xr.testing.assert_identical(a.load(), b.load())


# ---------------------------------------------------------------- numerics

def test_a_blow_up_inside_a_block_is_found_at_its_first_sample(monkeypatch):
    """A limit between the run's typical and largest displacement: only some samples inside
    10 000-step blocks exceed it, and the last sample of their block does not. The error
    names the time of the first such sample, found here independently from the run."""
    import analysis.integrate.simulate as simulate_module

    run = simulate_module.simulate("vakharia2015", 8, duration=0.3, transient=0.0)
    r = np.hypot(run.x.values, run.y.values)
    limit = float(np.quantile(r, 0.999))
    first = int(np.argmax(r > limit))
    assert r[(first // 10_000 + 1) * 10_000] <= limit, "the block's last sample is inside"
    monkeypatch.setattr(simulate_module, "blow_up_limit", lambda model, values: limit)
    with pytest.raises(SimulationError, match=rf"blew up at t = {run.t.values[first]:.6g} s"):
        simulate_module.simulate("vakharia2015", 8, duration=0.3, transient=0.0)



def test_the_block_check_by_extremes_decides_as_the_state_by_state_one():
    """``check_bounded`` passes a block at once when its extremes are within the limit, and
    searches it state by state otherwise. On blocks with a NaN, an inf or one displacement
    beyond the limit at a random row, and on blocks whose extremes (x large in one row, y in
    another) exceed the limit while no state does, it raises exactly when a plain search of
    every column finds a bad one, and names that column's time."""
    from analysis.integrate.simulate import check_bounded

    rng = np.random.default_rng(7)
    limit, pairs = 1.0, [(0, 1)]
    for trial in range(200):
        rows = rng.uniform(-0.6, 0.6, size=(1000, 5))
        rows[:, 4] = np.arange(1000)
        kind = trial % 4
        at = int(rng.integers(1000))
        if kind == 0:
            rows[at, int(rng.integers(4))] = np.nan
        elif kind == 1:
            rows[at, int(rng.integers(4))] = -np.inf
        elif kind == 2:
            rows[at, :2] = rng.choice([-1, 1], 2) * 0.75  # displacement 1.06
        else:  # extremes hypot(0.9, 0.9) > 1, every state within
            rows[at, :2] = (0.9, 0.1)
            rows[(at + 1) % 1000, :2] = (0.1, -0.9)
        states, times = rows[:, :4].T, rows[:, 4] * 1e-3
        bad = ~np.all(np.isfinite(states), axis=0) | (np.hypot(states[0], states[1]) > limit)
        if bad.any():
            with pytest.raises(SimulationError, match=rf"t = {times[np.argmax(bad)]:.6g} s"):
                check_bounded(states, times, limit, pairs)
        else:
            check_bounded(states, times, limit, pairs)
        assert bad.any() == (kind != 3)
