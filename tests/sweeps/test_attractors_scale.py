"""Attractor studies at scale (analysis.sweeps.attractor_blocks): blocks of initial states on
the executors, stored and resumed like sweeps.

- the file does not depend on the executor or the number of workers (serial, 2 processes,
  the in-process API);
- a run interrupted after some blocks were stored (an exception, or a SIGKILL of the
  command), then re-run, gives the data of an uninterrupted run;
- a re-run with another definition is refused while blocks are stored; a damaged stored
  block is reported and mapped again; a block that fails is recorded, its states labelled
  ``failed``.

Small Duffing grids (c = 0.1, k1 = 1, k3 = 0.5, F = 0.3 at ω = 1.4 rad/s: two attractors).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.model import System
from analysis.stability.attractors import (
    Box,
    MapperOptions,
    Range,
    RecurrenceMapper,
    basin_fractions,
    basins,
    grid_states,
)
from analysis.stability.attractors.mapper import FAILED
from analysis.sweeps.attractor_blocks import (
    basins_to_file,
    continuation_to_file,
    fractions_to_file,
)
from analysis.sweeps.executors import make_executor
from analysis.sweeps.store import PointStore

OMEGA = 1.4
DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
SPEED = OMEGA * 30 / np.pi
X, Y = Range("x", -3.0, 3.0, 10), Range("vx", -3.0, 3.0, 10)
BOX = Box.parse(["x:-3:3", "vx:-3:3"])
BLOCK = 25


@pytest.fixture(scope="module")
def system() -> System:
    return System.make("duffing", speed_rpm=SPEED, **DUFFING)


@pytest.fixture(scope="module")
def reference(system, tmp_path_factory) -> xr.Dataset:
    """The basins of an uninterrupted serial run, read back from its file."""
    out = tmp_path_factory.mktemp("reference") / "b.nc"
    basins_to_file(system, X, Y, out, block=BLOCK)
    return read(out)


def read(path) -> xr.Dataset:
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


class Interrupted(Exception):
    pass


def interrupt_after(monkeypatch, count: int) -> None:
    """The run stops with ``Interrupted`` once ``count`` blocks have been stored."""
    save, saved = PointStore.save, []

    def stop(self, key, values):
        save(self, key, values)
        saved.append(key)
        if len(saved) == count:
            raise Interrupted(key)

    monkeypatch.setattr(PointStore, "save", stop)


def test_the_file_does_not_depend_on_the_executor_or_the_workers(system, reference, tmp_path):
    assert reference.sizes["attractor"] == 2 and reference.attrs["block"] == BLOCK
    assert set(np.unique(reference.basin.values)) == {1, 2}
    assert int(reference.label_periods.min()) > 0
    ex = make_executor("processes", 2)
    basins_to_file(system, X, Y, tmp_path / "p.nc", block=BLOCK, executor=ex)
    xr.testing.assert_identical(read(tmp_path / "p.nc"), reference)
    assert not (tmp_path / "p.nc.parts").exists()  # removed once the file is written
    in_process = basins(system, X, Y, block=BLOCK)  # the API: no store, no executor
    xr.testing.assert_identical(in_process, reference)
    # fractions too, and the blocks matter to the file only through their size
    fractions_to_file(system, BOX, 60, tmp_path / "f.nc", seed=2, block=16, executor=ex)
    xr.testing.assert_identical(read(tmp_path / "f.nc"),
                                basin_fractions(system, BOX, 60, seed=2, block=16))


def test_one_block_merges_as_many_blocks_do(system, reference):
    whole = basins(system, X, Y, block=1000)  # one mapper, as before blocks
    assert np.array_equal(whole.basin.values, reference.basin.values)
    assert list(whole.nature.values) == list(reference.nature.values)


@pytest.mark.parametrize("executor", ["serial", "processes"])
def test_an_interrupted_run_resumes_to_the_uninterrupted_file(system, reference, tmp_path,
                                                              monkeypatch, executor):
    out = tmp_path / "b.nc"
    with monkeypatch.context() as patch:
        interrupt_after(patch, 1)
        with pytest.raises(Interrupted):
            basins_to_file(system, X, Y, out, block=BLOCK,
                           executor=make_executor(executor, 2))
    assert not out.exists()
    assert len(list((tmp_path / "b.nc.parts").glob("*.npz"))) == 1  # kept for the re-run
    mapped = []
    real = RecurrenceMapper.map

    def count(self, states, *args, **kwargs):
        mapped.append(len(states))
        return real(self, states, *args, **kwargs)

    monkeypatch.setattr(RecurrenceMapper, "map", count)
    basins_to_file(system, X, Y, out, block=BLOCK)
    assert sum(mapped) == X.num * Y.num - BLOCK  # the stored block was not mapped again
    xr.testing.assert_identical(read(out), reference)


def test_another_definition_is_refused_and_a_damaged_block_is_mapped_again(
        system, reference, tmp_path, monkeypatch):
    out = tmp_path / "b.nc"
    with monkeypatch.context() as patch:
        interrupt_after(patch, 2)
        with pytest.raises(Interrupted):
            basins_to_file(system, X, Y, out, block=BLOCK)
    parts = sorted((tmp_path / "b.nc.parts").glob("*.npz"))
    before = {p.name: p.read_bytes() for p in parts}
    with pytest.raises(InputError, match="different definition"):
        basins_to_file(system, X, Y, out, block=BLOCK, options=MapperOptions(resolution=30))
    with pytest.raises(InputError, match="different definition"):
        basins_to_file(system, X, Y, out, block=20)
    assert {p.name: p.read_bytes() for p in parts} == before  # left as they were
    parts[0].write_bytes(parts[0].read_bytes()[:100])  # truncated
    damaged = []
    basins_to_file(system, X, Y, out, block=BLOCK, on_damaged=damaged.append)
    assert damaged == [parts[0].stem]
    xr.testing.assert_identical(read(out), reference)


def test_a_continuation_resumes_inside_a_value(system, tmp_path, monkeypatch):
    values = np.array([1.30, 1.40, 1.50]) * 30 / np.pi
    args = (system, "speed_rpm", values, BOX, 30)
    whole = continuation_to_file(*args, tmp_path / "a.nc", block=12)
    assert set(whole.nature.values.ravel()) - {""} == {"periodic-1"}
    assert whole.present.values.sum(axis=1).tolist() == [2, 2, 2]
    out = tmp_path / "b.nc"
    with monkeypatch.context() as patch:
        interrupt_after(patch, 4)  # value 0's three blocks and one of value 1's
        with pytest.raises(Interrupted):
            continuation_to_file(*args, out, block=12, executor=make_executor("processes", 2))
    assert len(list((tmp_path / "b.nc.parts").glob("*.npz"))) == 4
    continuation_to_file(*args, out, block=12, executor=make_executor("processes", 2))
    xr.testing.assert_identical(read(out), read(tmp_path / "a.nc"))


def test_a_failed_block_is_recorded_and_the_study_goes_on(system, monkeypatch):
    real, second = RecurrenceMapper.map, grid_states(system, X, Y)[BLOCK]

    def fail_second(self, states, *args, **kwargs):
        if np.array_equal(states[0], second):  # block 1
            raise SimulationError("blew up in the test")
        return real(self, states, *args, **kwargs)

    monkeypatch.setattr(RecurrenceMapper, "map", fail_second)
    ds = basins(system, X, Y, block=BLOCK)
    labels = ds.basin.values.ravel()
    assert (labels[BLOCK:2 * BLOCK] == FAILED).all() and (labels[:BLOCK] > 0).all()
    assert ds.attrs["failed_blocks"] == "1: blew up in the test"
    assert str(ds.nature.sel(attractor=FAILED).values) == "failed"
    assert float(ds.fraction.sel(attractor=FAILED)) == pytest.approx(0.25)


def cli(*args: str, cwd) -> list[str]:
    return [sys.executable, "-m", "analysis.cli", *args]


BASINS = ("basins", "duffing", "--speed-rpm", repr(SPEED),
          *[f"--set={k}={v}" for k, v in DUFFING.items()],
          "--x", "x:-3:3:30", "--y", "vx:-3:3:30", "--block", "20", "--executor", "serial",
          "--quiet", "-o", "b.nc")


def test_a_killed_command_resumes_and_bad_options_write_nothing(system, tmp_path):
    res = subprocess.run(cli(*BASINS, "--block", "0", cwd=tmp_path), cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert res.stderr == "error: block: must be a whole number >= 1, got 0\n"
    assert list(tmp_path.iterdir()) == []
    proc = subprocess.Popen(cli(*BASINS, cwd=tmp_path), cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    parts = tmp_path / "b.nc.parts"
    deadline = time.monotonic() + 120
    while len(list(parts.glob("*.npz"))) < 3 and proc.poll() is None \
            and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    stored = len(list(parts.glob("*.npz")))
    assert proc.returncode == -signal.SIGKILL and 3 <= stored < 45, proc.stderr.read()
    res = subprocess.run(cli(*BASINS, "--json", cwd=tmp_path), cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    x, y = Range("x", -3.0, 3.0, 30), Range("vx", -3.0, 3.0, 30)
    xr.testing.assert_identical(read(tmp_path / "b.nc"), basins(system, x, y, block=20))
    assert not parts.exists()


def test_a_dask_local_cluster_gives_the_same_file(system, reference, tmp_path):
    pytest.importorskip("distributed")
    ex = make_executor("dask", 2)
    try:
        basins_to_file(system, X, Y, tmp_path / "d.nc", block=BLOCK, executor=ex)
    finally:
        ex.close()
    xr.testing.assert_identical(read(tmp_path / "d.nc"), reference)
