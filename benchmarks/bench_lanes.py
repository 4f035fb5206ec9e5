"""Cost of one RK4 step of a chart point, interleaved in one process:

- the model's compiled RK4 block, states only (``analysis.integrate.compiled.Runner``, one
  core);
- the scalar tangent block of a chart point (``points.chart_blocks``: states and one tangent
  vector, CasADi's compiled C, one core);
- the member kernels' CPU build (``analysis.integrate.kernels``), states and tangent
  variants, on one thread and on every core (``--members`` members per call; per member
  step, wall time).

    python benchmarks/bench_lanes.py [--model vakharia2015] [--n-balls 8] [--repeat 10]
                                     [--members 16]

Prints the median and minimum µs per step (per member step for the kernels), the steps per
second and the ratios to the states-only compiled block measured in the same run, with the
load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from analysis.integrate.compiled import Runner, library
from analysis.integrate.kernels import Schedule, run_members
from analysis.integrate.kernels.cpu import cores
from analysis.model import System
from analysis.sweeps.points import _Caller, chart_blocks

STEPS = 20_000
"""RK4 steps per timed run of each path (per member for the kernels)."""


def _kernel(system: System, z: np.ndarray, tangent: bool, threads: int) -> float:
    """Wall seconds of one kernel call of ``len(z)`` members on ``threads`` threads."""
    os.environ["BEARINGDYN_THREADS"] = str(threads)
    schedule = Schedule(0, 500, STEPS // 500, tangent=tangent, keep_sections=False)
    t = time.perf_counter()
    run_members(system, z, None, float(system.model.simulation_defaults["dt"]), schedule)
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="vakharia2015")
    parser.add_argument("--n-balls", type=int, default=8)
    parser.add_argument("--speed-rpm", type=float, default=2000.0)
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--members", type=int, default=16)
    args = parser.parse_args()
    system = System.make(args.model, args.n_balls, speed_rpm=args.speed_rpm)
    model, structure = system.model, system.structure
    dt = float(model.simulation_defaults["dt"])
    z = np.asarray(system.state, dtype=float)
    n, all_cores = model.n_state, cores()
    members = z * (1 + 0.01 * np.arange(args.members))[:, None]
    start = np.concatenate([z, [0.0], np.eye(n)[:, 0]])
    runner = Runner(library(model, structure), system.p, dt)
    scalar = _Caller(chart_blocks(model, structure)[100], start.copy(), system.p, dt)
    times: dict[str, list[float]] = {
        "states only, compiled block (1 core)": [], "tangent, scalar block (1 core)": [],
        "kernel states (1 thread)": [], "kernel tangent (1 thread)": [],
        f"kernel states ({all_cores} threads)": [], f"kernel tangent ({all_cores} threads)": []}
    for _ in range(args.repeat + 1):  # the first round warms up (and builds), not kept
        t = time.perf_counter()
        for _ in runner.blocks(z, STEPS):
            pass
        a = time.perf_counter() - t
        t = time.perf_counter()
        for _ in range(STEPS // 10_000):
            scalar()
        b = time.perf_counter() - t
        per = [_kernel(system, members, tangent, threads) / args.members
               for threads in (1, all_cores) for tangent in (False, True)]
        for key, value in zip(times, (a, b, *per), strict=True):
            times[key].append(value / STEPS * 1e6)
    os.environ.pop("BEARINGDYN_THREADS", None)
    for key in times:
        times[key] = times[key][1:]
    base = statistics.median(times["states only, compiled block (1 core)"])
    print(f"{model.name}, N_b = {args.n_balls}, {args.speed_rpm:g} rpm, dt = {dt:g} s; "
          f"{STEPS} steps per run, {args.members} kernel members, {args.repeat} interleaved "
          f"runs; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    print("| path | median (µs per step) | min | steps/s | ratio of medians to states only |")
    print("|---|---:|---:|---:|---:|")
    for key, values in times.items():
        med = statistics.median(values)
        print(f"| {key} | {med:.3f} | {min(values):.3f} | {1e6 / med:.3g} | "
              f"{med / base:.2f} |")


if __name__ == "__main__":
    main()
