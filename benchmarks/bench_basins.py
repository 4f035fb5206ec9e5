"""The basins benchmark of the attractors issue: basins of attraction of the balanced rotor
(N_b = 8, 8000 rpm, radial load 50 N) on a 100 × 100 grid of initial (x, y) over the box of
tests/stability/test_attractors.py (x from -20 to 30 µm, y from -20 to 20 µm), on 2 cores
(``analysis.sweeps.attractor_blocks.basins_to_file``, the processes executor with 2 workers,
blocks of 256 states; the wall time includes the cell scale, the description of every
attractor and writing the file).

In the same run, a hand-written reference on the same 2 cores: the compiled RK4 of the
ensemble (``analysis.integrate.ensemble.run_members``: the model's RK4 step in the state
lane kernel, two trajectories per call, only the end state kept) integrating every initial
state of the grid for the fixed time the slowest one needed to settle: the largest number
of periods the mapper spent on any labelled state (``label_periods`` of the result, over
states whose label is an attractor). Ratio = basins' wall time / the reference's; the goal
is <= 0.5 (early stopping must win).

    python benchmarks/bench_basins.py [--num 100] [--workers 2] [--block 256]
                                      [--no-ensemble]

Also prints the ensemble's throughput against one trajectory at a time
(``benchmarks/bench_ensemble.py``, a short run) unless ``--no-ensemble``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from analysis.integrate.ensemble import StroboscopicMap, run_members
from analysis.model import System
from analysis.stability.attractors import Range, grid_states
from analysis.stability.periodic import as_period
from analysis.sweeps.attractor_blocks import basins_to_file
from analysis.sweeps.executors import make_executor

MODEL = dict(n_balls=8, speed_rpm=8000.0, radial_load=50.0)


def fixed_time_task(task: tuple[np.ndarray, int]) -> np.ndarray:
    """The reference's work on one worker: ``periods`` forcing periods of every state in
    ``states`` by the ensemble's compiled RK4, the end states returned."""
    states, periods = task
    system = System.make("balanced-rotor", **MODEL)
    smap = StroboscopicMap.make(system, as_period(system.model, None))
    k = len(states)
    s = np.ascontiguousarray(np.column_stack([states, np.zeros(k)]))
    p = np.repeat(system.p[None, :], k, axis=0)
    run_members(system, p, np.full(k, smap.dt), s, 1, periods * smap.steps)
    return s[:, :-1]


def reference(states: np.ndarray, periods: int, workers: int) -> float:
    """Wall time of the fixed-time reference on ``workers`` processes (the states in
    4 tasks per worker)."""
    executor = make_executor("processes", workers)
    tasks = [(part, periods) for part in np.array_split(states, 4 * workers)]
    start = time.perf_counter()
    ends = [end for _, end in executor.run(fixed_time_task, tasks)]
    seconds = time.perf_counter() - start
    executor.close()
    bounded = np.isfinite(np.concatenate(ends)).all(axis=1).mean()
    print(f"  reference: {len(states)} states x {periods} periods in {seconds:.2f} s "
          f"({100 * bounded:.1f} % bounded at the end)")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--num", type=int, default=100, help="grid values per axis")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--block", type=int, default=256)
    parser.add_argument("--no-ensemble", action="store_true")
    args = parser.parse_args()
    system = System.make("balanced-rotor", **MODEL)
    x, y = Range("x", -20e-6, 30e-6, args.num), Range("y", -20e-6, 20e-6, args.num)
    states = grid_states(system, x, y)
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="bench-basins-") as folder:
        executor = make_executor("processes", args.workers)
        start = time.perf_counter()
        ds = basins_to_file(system, x, y, Path(folder) / "basins.nc", block=args.block,
                            executor=executor)
        basins_s = time.perf_counter() - start
        executor.close()
    labels, spent = ds.basin.values.ravel(), ds.label_periods.values.ravel()
    slowest = int(spent[labels > 0].max())
    print(f"balanced-rotor, N_b = 8, 8000 rpm, radial_load 50 N: basins on {args.num} x "
          f"{args.num} (x, y), {args.workers} workers, blocks of {args.block}")
    for i in ds.attractor.values:
        row = ds.sel(attractor=i)
        print(f"  attractor {int(i)}: {row.nature.values!s}, "
              f"{100 * float(row.fraction):.1f} % of the grid")
    print(f"  basins: {basins_s:.2f} s wall; {int(spent.sum())} periods integrated "
          f"(mean {spent.mean():.1f}, slowest labelled state {slowest} periods)")
    print(f"  load average after the basins: {os.getloadavg()[0]:.2f} (other processes on "
          "these cores slow both paths)")
    ref_s = reference(states, slowest, args.workers)
    print(f"  load average after the reference: {os.getloadavg()[0]:.2f}")
    print(f"  work ratio (periods, basins / fixed time): "
          f"{spent.sum() / (len(states) * slowest):.3f}")
    print(f"ratio of wall times (basins / fixed-time compiled RK4): {basins_s / ref_s:.3f} "
          f"(goal <= 0.5)")
    if not args.no_ensemble:
        bench = Path(__file__).with_name("bench_ensemble.py")
        subprocess.run([sys.executable, str(bench), "--repeat", "3", "--members", "32",
                        "--periods", "100"], check=True)


if __name__ == "__main__":
    main()
