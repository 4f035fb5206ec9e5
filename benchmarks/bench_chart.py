"""The stability-chart benchmark of the sweeps issue: N_b = 5…12 × 200 speeds (1000-10000 rpm),
each point 1 s transient + 200.5 shaft revolutions (RK4, dt = 1e-5 s), classified with its
largest Lyapunov exponent (``analysis.sweeps.points.chart_point``: states and tangent in one
pass), on all cores. Prints the wall time and the points per second per core.

In the same run, a serial reference: for ``--reference-points`` points of the grid, each
with its neighbour on the speed axis (same N_b), the pair computed in this process as the
chart computes it (``chart_points``: the two points as members of one call of the member
kernels, ``analysis.integrate.kernels``), each point also alone (``chart_point``: the scalar CasADi
blocks), against the model's compiled RK4 blocks (``analysis.integrate.compiled.library`` /
``Runner``: states only, no tangent, no classification) over the same simulated time from
the same initial states; the ratio of the summed times is the chart's cost per point in
units of a plain compiled RK4 run.

    python benchmarks/bench_chart.py [--speeds 200] [--workers N] [--executor processes|dask]
                                     [--reference-points 10] [--repeat 3] [--no-chart]
                                     [--device cpu|gpu|auto]

``--device gpu`` runs the chart's points on the GPU (one process; ``--reference-points 0``
skips the serial reference): issue 33's 160 000-point chart is ``--speeds 20000 --device gpu
--reference-points 0`` (target <= 30 s on an H200).
                                     [--save chart.nc]

Targets: the 1600-point chart in <= 150 s on 2 cores; chart point / RK4 <= 2.5 (serial).
``--quick`` is ``--speeds 10`` (80 points) for an estimate.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from analysis.integrate.compiled import Runner, library
from analysis.model import as_system
from analysis.reports.progress import ProgressReporter
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.executors import make_executor
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.points import chart_point, chart_points

SETTING = Setting("vakharia2015", None, {}, transient=1.0, samples=200, lyapunov=True)
WALL_TARGET = 150.0
"""s of wall time for the 1600-point chart on 2 cores."""
RATIO_TARGET = 2.5
"""Chart point / compiled RK4 of the same simulated time (serial)."""


def rk4_only(n_balls: int, values: dict[str, float], duration: float, dt: float) -> float:
    """Seconds of wall time for round(duration / dt) compiled RK4 steps (states only) of the
    chart's model from its initial state (``duration``, ``dt`` in s)."""
    system = as_system(SETTING.model, n_balls, None, **values)
    runner = Runner(library(system.model, system.structure), system.p, dt)
    z0 = np.asarray(system.state, dtype=float)
    start = time.perf_counter()
    for _ in runner.blocks(z0, round(duration / dt)):
        pass
    return time.perf_counter() - start


def cpu_seconds() -> float:
    """User + system CPU seconds of this process and of its children that have ended (the
    workers of a process pool, once it is closed)."""
    own, children = (resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                           resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def timed(fn, *args) -> float:
    """Seconds of wall time for ``fn(*args)`` in this process."""
    start = time.perf_counter()
    fn(*args)
    return time.perf_counter() - start


def each_alone(points: list) -> None:
    """The chart points one by one (``chart_point``: the scalar tangent blocks)."""
    for system in points:
        chart_point(SETTING, system)


def rk4_pair(n_balls: int, pair: list[dict], durations: list[float]) -> None:
    """Compiled RK4 of both points of a pair (states only)."""
    for values, duration in zip(pair, durations, strict=True):
        rk4_only(n_balls, values, duration, SETTING.step())


def serial_reference(x: Axis, y: Axis, count: int, repeat: int) -> dict:
    """Chart points (a pair in one kernel call, and each alone) against compiled RK4 at
    ``count`` grid points spread over both axes, each with its neighbour on x; median of
    ``repeat``
    interleaved runs each (the first call, which loads the libraries, not timed). Times in
    s, per point."""
    picks = []
    for i in range(count):
        ix = min(round(i * (len(x.values) - 1) / max(count - 1, 1)), len(x.values) - 2)
        n_balls = round(y.values[(3 * i) % len(y.values)])
        picks.append((n_balls, [{x.name: x.values[ix]}, {x.name: x.values[ix + 1]}]))
    rows = []
    for n_balls, pair in picks:
        points = [SETTING.system_at(n_balls=n_balls, **v) for v in pair]
        durations = [SETTING.seconds(system) for system in points]

        timed(chart_points, SETTING, points), timed(each_alone, points)
        timed(rk4_pair, n_balls, pair, durations)
        kernel, single, plain = [], [], []
        for _ in range(repeat):
            kernel.append(timed(chart_points, SETTING, points) / 2)
            single.append(timed(each_alone, points) / 2)
            plain.append(timed(rk4_pair, n_balls, pair, durations) / 2)
        rows.append((n_balls, pair[0][x.name], sum(durations) / 2, statistics.median(kernel),
                     statistics.median(single), statistics.median(plain)))
    sums = [sum(r[i] for r in rows) for i in (3, 4, 5)]
    return {"rows": rows, "chart": sums[0] / len(rows), "alone": sums[1] / len(rows),
            "rk4": sums[2] / len(rows), "ratio": sums[0] / sums[2],
            "ratio_alone": sums[1] / sums[2],
            "simulated": sum(r[2] for r in rows) / len(rows)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--speeds", type=int, default=200)
    parser.add_argument("--quick", action="store_true", help="--speeds 10 (80 points)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--executor", default="processes")
    parser.add_argument("--reference-points", type=int, default=10)
    parser.add_argument("--device", default="cpu", help="where the chart's points run")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-chart", action="store_true",
                        help="the serial reference only")
    parser.add_argument("--save", type=Path, help="also write the chart to this netCDF file")
    args = parser.parse_args()
    speeds = 10 if args.quick else args.speeds
    x = Axis.parse(f"speed_rpm:1000:10000:{speeds}")
    y = Axis.parse("n_balls:5:12")
    full_x = Axis.parse("speed_rpm:1000:10000:200")

    if args.reference_points > 0:
        report_reference(serial_reference(full_x, y, args.reference_points, args.repeat),
                         args.repeat)
    if args.no_chart:
        return
    chart_run(args, x, y)


def report_reference(ref: dict, repeat: int) -> None:
    """Print the serial reference's table and its verdict."""
    print(f"serial reference, {len(ref['rows'])} pairs of neighbouring points of the "
          f"1600-point grid (median of {repeat} each; times per point):")
    print("| N_b | speed_rpm | simulated (s) | chart point, kernel (s) | alone (s) | "
          "compiled RK4, states only (s) | ratio | ratio alone |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n_balls, speed, duration, chart_s, alone_s, rk4_s in ref["rows"]:
        print(f"| {n_balls} | {speed:.0f}+ | {duration:.3f} | {chart_s:.4f} | {alone_s:.4f} | "
              f"{rk4_s:.4f} | {chart_s / rk4_s:.2f} | {alone_s / rk4_s:.2f} |")
    verdict = "met" if ref["ratio"] <= RATIO_TARGET else "MISSED"
    print(f"mean per point: chart {ref['chart']:.4f} s (alone {ref['alone']:.4f} s), RK4 "
          f"{ref['rk4']:.4f} s for {ref['simulated']:.3f} s simulated; ratio "
          f"{ref['ratio']:.2f} (alone {ref['ratio_alone']:.2f}; target <= {RATIO_TARGET}: "
          f"{verdict})")


def chart_run(args: argparse.Namespace, x: Axis, y: Axis) -> None:
    """The chart on ``args.workers`` workers (or the GPU), timed, with its verdict."""
    if args.device != "cpu":
        args.executor, args.workers = "serial", 1
    executor = make_executor(args.executor, args.workers)
    cpu_before = cpu_seconds()
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        try:
            chart = stability_chart(SETTING, x, y, Path(tmp) / "chart.nc", executor=executor,
                                    progress=ProgressReporter("chart"), device=args.device)
        finally:
            executor.close()
        wall = time.perf_counter() - start
    cpu = cpu_seconds() - cpu_before
    points = chart.sizes["speed_rpm"] * chart.sizes["n_balls"]
    counts = {k: int((chart.nature == k).sum()) for k in sorted(set(chart.nature.values.ravel()))}
    verdict = ("met" if wall <= WALL_TARGET else "MISSED") if points == 1600 and \
        args.workers == 2 else "not this grid or worker count"
    print(f"{points} points ({y.values[0]:g}-{y.values[-1]:g} balls × {len(x.values)} speeds), "
          f"{args.workers} workers ({executor.name}): {wall:.1f} s wall, "
          f"{points / wall / args.workers:.3f} points/s/core; target <= {WALL_TARGET:g} s for "
          f"1600 points on 2 cores: {verdict}")
    print(f"CPU time of this process and its finished workers: {cpu:.1f} s; / {args.workers} "
          f"workers = {cpu / args.workers:.1f} s, the wall time on free cores at perfect "
          f"parallel efficiency (less sensitive than the wall time to other load)")
    print("classes:", counts)
    if args.save is not None:
        chart.to_netcdf(args.save)


if __name__ == "__main__":
    main()
