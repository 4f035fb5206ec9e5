"""Cost of one RK4 step of a chart point, interleaved in one process:

- the model's compiled RK4 block, states only (``analysis.integrate.compiled.Runner``, one
  core);
- the scalar tangent block of a chart point (``points.chart_blocks``: states and one tangent
  vector, CasADi's compiled C, one core);
- the member kernels' CPU build (``analysis.integrate.kernels.cpu.cpu_library``), states
  and tangent variants, on one thread and on every core (``--members`` members per call;
  per member step, wall time), scalar (``lanes=0``, the build before lanes) and in blocks
  of lanes (``--lanes``, default the host's: 8 with AVX-512F, 4 with
  AVX2; with the host's flags for that count, ``cpu.host_isas``; ``--lanes`` alone: none).

    python benchmarks/bench_lanes.py [--model vakharia2015] [--n-balls 8] [--repeat 10]
                                     [--members 16] [--lanes 4 8]

Prints the median and minimum µs per step (per member step for the kernels), the steps per
second and the ratios to the states-only compiled block and to the kernel's state variant
on one thread, measured in the same run, with the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from analysis.integrate.compiled import Runner, library
from analysis.integrate.kernels import Schedule
from analysis.integrate.kernels.cpu import CpuLibrary, cores, cpu_library, host_isas, host_lanes
from analysis.model import System
from analysis.sweeps.points import _Caller, chart_blocks

STEPS = 20_000
"""RK4 steps per timed run of each path (per member for the kernels)."""


def _kernel(lib: CpuLibrary, system: System, z: np.ndarray, threads: int) -> float:
    """Wall seconds of one call of ``lib`` on the members ``z`` on ``threads`` threads."""
    m, n = z.shape
    schedule = Schedule(0, 500, STEPS // 500, keep_sections=False)
    inputs = [np.ascontiguousarray(z), np.zeros(m), np.tile(system.p, (m, 1)),
              np.full(m, float(system.model.simulation_defaults["dt"])), np.zeros(m),
              np.full(m, np.inf), *schedule.per_member(m)]
    kmax = STEPS // 500
    outs = [np.empty((m, kmax, n)), np.empty((m, kmax)), np.empty((m, n)),
            np.empty(m, dtype=np.int64), np.empty((m, n)), np.empty((m, n))]
    t = time.perf_counter()
    lib.run(m, threads, inputs, kmax, False, outs)
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="vakharia2015")
    parser.add_argument("--n-balls", type=int, default=8)
    parser.add_argument("--speed-rpm", type=float, default=2000.0)
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--members", type=int, default=16)
    parser.add_argument("--lanes", type=int, nargs="*", default=None,
                        help="members per block of lanes, one row each (default: the "
                             "host's; none: no such row)")
    args = parser.parse_args()
    lanes = [host_lanes()[0]] if args.lanes is None else args.lanes
    system = System.make(args.model, args.n_balls, speed_rpm=args.speed_rpm)
    model, structure = system.model, system.structure
    dt = float(model.simulation_defaults["dt"])
    z = np.asarray(system.state, dtype=float)
    n, all_cores = model.n_state, cores()
    members = z * (1 + 0.01 * np.arange(args.members))[:, None]
    start = np.concatenate([z, [0.0], np.eye(n)[:, 0]])
    runner = Runner(library(model, structure), system.p, dt)
    scalar = _Caller(chart_blocks(model, structure)[100], start.copy(), system.p, dt)
    libs = {"states": cpu_library(model, structure, False, 0),
            "tangent": cpu_library(model, structure, True, 0)}
    for count in filter(None, lanes):
        flags = " ".join(host_isas().get(count, ())) or "no ISA flag"
        for variant in ("states", "tangent"):
            libs[f"{variant}, lanes of {count} ({flags})"] = \
                cpu_library(model, structure, variant == "tangent", count)
    kernels = [(f"kernel {name} ({threads} thread{'s' if threads > 1 else ''})", lib, threads)
               for threads in (1, all_cores) for name, lib in libs.items()]
    times: dict[str, list[float]] = {
        "states only, compiled block (1 core)": [], "tangent, scalar block (1 core)": [],
        **{key: [] for key, _, _ in kernels}}
    for _ in range(args.repeat + 1):  # the first round warms up (and builds), not kept
        t = time.perf_counter()
        for _ in runner.blocks(z, STEPS):
            pass
        a = time.perf_counter() - t
        t = time.perf_counter()
        for _ in range(STEPS // 10_000):
            scalar()
        b = time.perf_counter() - t
        per = [_kernel(lib, system, members, threads) / args.members
               for _, lib, threads in kernels]
        for key, value in zip(times, (a, b, *per), strict=True):
            times[key].append(value / STEPS * 1e6)
    for key in times:
        times[key] = times[key][1:]
    base = statistics.median(times["states only, compiled block (1 core)"])
    states = statistics.median(times["kernel states (1 thread)"])
    print(f"{model.name}, N_b = {args.n_balls}, {args.speed_rpm:g} rpm, dt = {dt:g} s; "
          f"{STEPS} steps per run, {args.members} kernel members, {args.repeat} interleaved "
          f"runs; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    print("| path | median (µs per step) | min | steps/s | ratio of medians to states only "
          "| to kernel states (1 thread) |")
    print("|---|---:|---:|---:|---:|---:|")
    for key, values in times.items():
        med = statistics.median(values)
        print(f"| {key} | {med:.3f} | {min(values):.3f} | {1e6 / med:.3g} | "
              f"{med / base:.2f} | {med / states:.2f} |")


if __name__ == "__main__":
    main()
