"""The counter of an attractor study moves within a block of initial states, not once per
block: the recurrence mapper's after each chunk of periods (in this process, or in a
worker through ``attractor_blocks.WorkerCounts``), the featurizing mapper's as the member
kernel's sub-chunks finish; and an interrupted study says how many states it kept.

Small Duffing grids (c = 0.1, k1 = 1, k3 = 0.5, F = 0.3 at ω = 1.4 rad/s: two attractors).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import analysis.integrate.kernels.members as members
import analysis.sweeps.attractor_blocks as blocks
from analysis.model import System
from analysis.stability.attractors import Range, RecurrenceMapper
from analysis.stability.attractors.featurizing import FeatureOptions
from analysis.sweeps.attractor_blocks import WorkerCounts, basins_to_file
from analysis.sweeps.store import PointStore

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
X, Y = Range("x", -3.0, 3.0, 10), Range("vx", -3.0, 3.0, 10)
BLOCK = 50


@pytest.fixture(scope="module")
def system() -> System:
    return System.make("duffing", speed_rpm=1.4 * 30 / np.pi, **DUFFING)


def read(path: Path) -> xr.Dataset:
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


def check_counts(done: list[int], total: int, block: int) -> None:
    """Monotone, ending at ``total``, more often than once per block, and inside blocks."""
    assert done == sorted(done) and done[-1] == total
    assert len(set(done)) > -(-total // block) + 1
    assert any(0 < d % block for d in done)


@pytest.fixture(scope="module")
def serial(system, tmp_path_factory) -> tuple[xr.Dataset, list[int]]:
    """The serial run's file and its counter."""
    seen: list[tuple[int, int]] = []
    out = tmp_path_factory.mktemp("serial") / "b.nc"
    basins_to_file(system, X, Y, out, block=BLOCK, progress=lambda d, t: seen.append((d, t)))
    assert {t for _, t in seen} == {100}
    return read(out), [d for d, _ in seen]


def test_the_recurrence_mapper_counts_within_a_block(serial):
    check_counts(serial[1], 100, BLOCK)


class InThisProcess:
    """An executor that is not the serial one (so the blocks go to ``map_block_task`` as
    tasks, with their counts file), running each task here, one after the other."""

    name = "in this process"

    def run(self, fn, tasks):
        for task in tasks:
            yield task, fn(task)

    def close(self) -> None:
        pass


def test_workers_counts_reach_the_parents_counter(system, serial, tmp_path, monkeypatch):
    """What a worker writes to its slot is in the parent's count at once: read after each
    write, the count is monotone, moves inside blocks and ends at the total; the file equals
    the serial run's, and the counts file is gone."""
    parent, seen = {}, []
    real_run, real_writer = blocks.run_with_progress, WorkerCounts.writer

    def run_with_progress(executor, fn, tasks, done, total, progress, on_result):
        parent["done"] = done
        return real_run(executor, fn, tasks, done, total, progress, on_result)

    def writer(path, slot):
        write = real_writer(path, slot)

        def and_read(done: int, total: int) -> None:
            write(done, total)
            seen.append(parent["done"]())

        return and_read

    monkeypatch.setattr(blocks, "run_with_progress", run_with_progress)
    monkeypatch.setattr(WorkerCounts, "writer", staticmethod(writer))
    out = tmp_path / "w.nc"
    basins_to_file(system, X, Y, out, block=BLOCK, executor=InThisProcess(),
                   progress=lambda d, t: None)
    check_counts([*seen, parent["done"]()], 100, BLOCK)
    xr.testing.assert_identical(read(out), serial[0])
    assert not (tmp_path / "w.nc.parts").exists()


def test_a_processes_run_counts_to_the_total(system, serial, tmp_path):
    from analysis.sweeps.executors import make_executor

    seen: list[int] = []
    out = tmp_path / "p.nc"
    basins_to_file(system, X, Y, out, block=BLOCK, executor=make_executor("processes", 2),
                   progress=lambda d, t: seen.append(d))
    assert seen == sorted(seen) and seen[-1] == 100
    xr.testing.assert_identical(read(out), serial[0])


def test_the_featurizing_mapper_counts_within_its_block(system, tmp_path, monkeypatch):
    """One block of 100 states on the CPU member kernel, its sub-chunks as small as they
    go: the counter moves more than once inside the block."""
    monkeypatch.setattr(members, "PROGRESS_SECONDS", 1e-6)
    seen: list[int] = []
    basins_to_file(system, X, Y, tmp_path / "f.nc", mapper="features", device="cpu",
                   feature_options=FeatureOptions(transient=20, sections=24),
                   progress=lambda d, t: seen.append(d))
    assert seen == sorted(seen) and seen[-1] == 100
    assert len(set(seen)) >= 3 and any(0 < d < 100 for d in seen)


def test_an_interrupted_study_says_how_many_states_it_kept(system, tmp_path, monkeypatch):
    save, saved = PointStore.save, []

    def stop(self, key, values):
        save(self, key, values)
        saved.append(key)
        raise KeyboardInterrupt

    monkeypatch.setattr(PointStore, "save", stop)
    out = tmp_path / "b.nc"
    with pytest.raises(KeyboardInterrupt) as caught:
        basins_to_file(system, X, Y, out, block=BLOCK)
    assert caught.value.__notes__ == [
        f"1 block ({BLOCK} initial states) kept in {out}.parts; run the same command to "
        "resume"]


def test_an_interrupted_study_that_kept_nothing_says_so(system, tmp_path, monkeypatch):
    def stop(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(RecurrenceMapper, "map", stop)
    out = tmp_path / "b.nc"
    with pytest.raises(KeyboardInterrupt) as caught:
        basins_to_file(system, X, Y, out, block=BLOCK)
    assert caught.value.__notes__ == [
        "nothing was kept: none of the blocks of initial states had finished"]
    assert not out.exists() and not Path(f"{out}.parts").exists()


def test_a_searching_state_counts_its_share_of_max_periods():
    """Ten trajectories that never recur (every point in a new cell), 50 periods at most in
    chunks of 10: the counter moves every chunk by 10 x 10/50 states, though none settles
    before the last chunk makes them all 'undecided'."""
    from analysis.stability.attractors import MapperOptions
    from analysis.stability.attractors.mapper import UNDECIDED, Scale

    def advance(block: np.ndarray, n: int) -> np.ndarray:
        first = block[:, -1:] + np.arange(1, n + 1)[None, :]  # never the same cell twice
        block[:, -1] += n
        return np.repeat((first + 1e3 * np.arange(len(block))[:, None])[:, :, None], 2, axis=2)

    mapper = RecurrenceMapper(advance, lambda points: np.zeros(len(points), dtype=bool),
                              Scale(np.ones(2)),
                              MapperOptions(revisits=5, max_periods=50, chunk=10))
    seen: list[tuple[int, int]] = []
    labels = mapper.map(np.zeros((10, 2)), progress=lambda d, t: seen.append((d, t)))
    assert np.all(labels == UNDECIDED)
    assert seen == [(2, 10), (4, 10), (6, 10), (8, 10), (10, 10)]
