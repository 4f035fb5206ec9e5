"""Throughput of an ensemble (``analysis.integrate.ensemble``) against one run at a time.

Both paths integrate the same members (initial states near the spec's) for the same steps of
a stroboscopic map, interleaved in one process:

- one trajectory at a time: each member's whole duration in one ``compiled.run_rk4`` call
  through the model's compiled RK4 blocks, keeping the state after every period (the
  strongest single-trajectory path: at most a few dozen block calls per member);
- the ensemble: ``StroboscopicMap.advance`` on all members in one call of the member
  kernels' CPU build (``analysis.integrate.kernels``: one member per OpenMP iteration, every
  core, or ``BEARINGDYN_THREADS``).

    python benchmarks/bench_ensemble.py [--model balanced-rotor] [--n-balls 8]
        [--speed-rpm 8000] [--members 64] [--periods 200] [--repeat 5]

Prints the trajectory-steps per second of each path (medians and best of the repeats), the
ratio of the medians, and the first-use time of the member kernel (C written, compiled into
an empty cache, loaded and self-tested). The two paths' section points are checked equal
bit for bit before anything is timed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import numpy as np

from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.kernels import members
from analysis.integrate.kernels.cpu import cores, cpu_library
from analysis.model import System


def first_use(system: System) -> float:
    """Seconds to write, compile (into an empty cache), load and self-test the kernel."""
    saved = os.environ.get("BEARINGDYN_CACHE")
    with tempfile.TemporaryDirectory(prefix="bench-ensemble-") as cache:
        os.environ["BEARINGDYN_CACHE"] = cache
        cpu_library.cache_clear()
        members._self_test.cache_clear()
        try:
            start = time.perf_counter()
            members._kernel(system, False, "cpu")
            seconds = time.perf_counter() - start
        finally:
            if saved is None:
                del os.environ["BEARINGDYN_CACHE"]
            else:
                os.environ["BEARINGDYN_CACHE"] = saved
            cpu_library.cache_clear()
            members._self_test.cache_clear()
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="balanced-rotor")
    parser.add_argument("--n-balls", type=int, default=8)
    parser.add_argument("--speed-rpm", type=float, default=8000.0)
    parser.add_argument("--period", default="vc")
    parser.add_argument("--members", type=int, default=64)
    parser.add_argument("--periods", type=int, default=200)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    system = System.make(args.model, n_balls=args.n_balls, speed_rpm=args.speed_rpm)
    compile_s = first_use(system)
    smap = StroboscopicMap.make(system, args.period)
    n, big_n, k = system.n_state, smap.steps, args.members
    rng = np.random.default_rng(1)
    z = system.state * (1 + 0.5 * rng.standard_normal((k, n))) + 1e-7 * rng.standard_normal((k, n))
    lib, p = library(system.model, system.structure), system.p

    def one_at_a_time() -> np.ndarray:
        return np.stack([run_rk4(lib, p, z[i], smap.dt, args.periods * big_n, big_n)[:, 1:].T
                         for i in range(k)])

    def together() -> np.ndarray:
        return smap.advance(np.column_stack([z, np.zeros(k)]), args.periods)

    if not np.array_equal(one_at_a_time(), together()):
        raise SystemExit("the ensemble's section points differ from the single runs'")
    steps = k * args.periods * big_n
    rates: dict[str, list[float]] = {"one trajectory at a time (run_rk4)": [],
                                     f"ensemble (member kernel, {cores()} threads)": []}
    for _ in range(args.repeat):
        for key, path in zip(rates, (one_at_a_time, together), strict=True):
            start = time.perf_counter()
            path()
            rates[key].append(steps / (time.perf_counter() - start))
    print(f"{system.model.name}, N_b = {args.n_balls}, {args.speed_rpm:g} rpm, period "
          f"{args.period}: T = {smap.period_s:.6g} s, N = {big_n} steps of h = {smap.dt:.6g} s; "
          f"{k} members x {args.periods} periods = {steps} trajectory-steps per path, "
          f"{args.repeat} interleaved repeats; load average {os.getloadavg()[0]:.2f}")
    print("| path | median (trajectory-steps/s) | best | µs per step (median) |")
    print("|---|---:|---:|---:|")
    for key, values in rates.items():
        med = statistics.median(values)
        print(f"| {key} | {med:.4g} | {max(values):.4g} | {1e6 / med:.3f} |")
    base, kernel = (statistics.median(v) for v in rates.values())
    print(f"ratio of medians (ensemble / one at a time): {kernel / base:.2f}x")
    print(f"first use of the member kernel (write C, compile, load, self-test): {compile_s:.2f} s")


if __name__ == "__main__":
    main()
