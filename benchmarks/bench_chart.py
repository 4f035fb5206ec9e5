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

``--host-points G`` (default 32, 0 skips) first times the host side of one group of G
points after its one ``run_members`` call (the call itself replayed, not timed): the
per-point path (a Dataset per point, ``chart_row``, one store entry written, fsynced and
read back per point) against the chart's (``chart_points``: a group's rows classified with
numpy over its points; ``PointStore.save_block``: one entry per group; ``points``), in ms
per point.

``--host-speeds S`` times the host side of a whole chart of S speeds × N_b 5-12 in the
GPU's groups (``chart.GROUP_POINTS["gpu"]``): ``stability_chart`` with ``run_members``
replaced by a replay (one real member per N_b on the CPU build, its sections, logs and
extremes given to every point of a call; every point then quasi-periodic and judged by its
graph ratio, the costliest class), so only the host's work is timed: the groups' plans
(``points.chart_grid_points``: arrays, not a System per point), classes, store blocks and
the assembled chart, in CPU ms per point (issue 33's 160 000-point chart is
``--host-speeds 20000``; target of issue 39: <= 0.05 ms/point, ``HOST_TARGET``).

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
from analysis.sweeps import points as chart_module
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.executors import make_executor
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.points import chart_point, chart_points, chart_row, kernel_points
from analysis.sweeps.store import PointStore

SETTING = Setting("vakharia2015", None, {}, transient=1.0, samples=200, lyapunov=True)
WALL_TARGET = 150.0
"""s of wall time for the 1600-point chart on 2 cores."""
HOST_TARGET = 0.05
"""CPU ms per point of the chart's host side (``--host-speeds``; issue 39)."""
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


def host_side(count: int, repeat: int) -> dict[str, float]:
    """ms per point of the host side after one ``run_members`` call for ``count`` points
    (N_b 8, speeds spread over 1000-10000 rpm): ``per_point`` (a Dataset per point, a
    store entry per point written and read back) and ``block`` (the chart's path); the
    kernel call runs once and is replayed. Best of ``repeat``."""
    systems = [SETTING.system_at(n_balls=8, speed_rpm=v)
               for v in np.linspace(1000.0, 10000.0, count)]
    durations = [SETTING.seconds(system) for system in systems]
    real, kept = chart_module.run_members, []

    def replay(*args, **kwargs):
        if not kept:
            kept.append(real(*args, **kwargs))
        return kept[0]

    def per_point(store: PointStore) -> None:
        rows = [chart_row(p) for p in kernel_points(systems, durations, SETTING.transient,
                                                    SETTING.step(), SETTING.section)]
        for i, row in enumerate(rows):
            store.save(f"0000-{i:04d}", row)
        for i in range(len(rows)):
            store.load(f"0000-{i:04d}")

    def block(store: PointStore) -> None:
        rows = chart_points(SETTING, systems)
        store.save_block([(f"0000-{i:04d}", row) for i, row in enumerate(rows)])
        store.points()

    chart_module.run_members = replay
    times: dict[str, list[float]] = {"per_point": [], "block": []}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            chart_points(SETTING, systems)  # the kernel call, kept for the replays
            for k in range(repeat):
                for name, fn in (("per_point", per_point), ("block", block)):
                    store = PointStore(Path(tmp) / f"{name}{k}.nc", {"kind": "bench"},
                                       lock=True)
                    times[name].append(timed(fn, store) / count * 1e3)
                    store.remove()
    finally:
        chart_module.run_members = real
    return {name: min(values) for name, values in times.items()}


def host_chart(speeds: int) -> tuple[float, float]:
    """ms per point (wall, CPU time of this process) of the host side of a chart of
    ``speeds`` speeds × N_b 5-12 in GPU-size groups, the kernel call replayed (see the
    module); a 2-speed chart first builds the replays (not timed)."""
    from analysis.integrate.kernels import MemberResult, Schedule
    from analysis.sweeps import chart as chart_mod

    real, replays = chart_module.run_members, {}

    def replay(system, z0, p, h, schedule, **kwargs):
        m, n, k = len(z0), system.model.n_state, schedule.max_sections
        if system.structure not in replays:
            one = {name: schedule.counts(name)[:1] for name in (
                "transient_steps", "steps_per_section", "n_sections", "lyapunov_skip",
                "extremes_from", "extremes_to")}
            replays[system.structure] = real(system, z0[:1], p[:1], h[:1],
                                             Schedule(**one, tangent=True))
        one = replays[system.structure]
        kept = min(k, one.sections.shape[1])
        sections, logs = np.full((m, k, n), np.nan), np.full((m, k), np.nan)
        sections[:, :kept], logs[:, :kept] = one.sections[0, :kept], one.logs[0, :kept]
        return MemberResult(sections, logs, np.repeat(one.lambda1, m),
                            np.full(m, -1, dtype=np.int64), *(np.repeat(a, m, axis=0) for a in
                                                              (one.final, one.low, one.high)),
                            "cpu")

    groups = dict(chart_mod.GROUP_POINTS)
    chart_module.run_members = replay
    chart_mod.GROUP_POINTS["cpu"] = chart_mod.GROUP_POINTS["gpu"]
    y = Axis.parse("n_balls:5:12")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            stability_chart(SETTING, Axis.parse("speed_rpm:1000:10000:2"), y,
                            Path(tmp) / "warm.nc")
            start, cpu = time.perf_counter(), time.process_time()
            chart = stability_chart(SETTING, Axis.parse(f"speed_rpm:1000:10000:{speeds}"), y,
                                    Path(tmp) / "chart.nc")
            wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    finally:
        chart_module.run_members = real
        chart_mod.GROUP_POINTS.update(groups)
    return wall / chart.nature.size * 1e3, cpu / chart.nature.size * 1e3


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
    parser.add_argument("--host-points", type=int, default=32,
                        help="points of the host-side timing (0: skip it)")
    parser.add_argument("--host-speeds", type=int, default=0,
                        help="time the host side of a chart of this many speeds (0: skip)")
    parser.add_argument("--no-chart", action="store_true",
                        help="the serial reference only")
    parser.add_argument("--save", type=Path, help="also write the chart to this netCDF file")
    args = parser.parse_args()
    speeds = 10 if args.quick else args.speeds
    x = Axis.parse(f"speed_rpm:1000:10000:{speeds}")
    y = Axis.parse("n_balls:5:12")
    full_x = Axis.parse("speed_rpm:1000:10000:200")

    if args.host_points > 0:
        host = host_side(args.host_points, args.repeat)
        print(f"host side after the kernel call, {args.host_points} points (best of "
              f"{args.repeat}, load {os.getloadavg()[0]:.1f}): per point (Dataset, one "
              f"store entry each) {host['per_point']:.2f} ms/point; chart's (numpy rows, "
              f"one block) {host['block']:.2f} ms/point; "
              f"{host['per_point'] / host['block']:.1f}x")
    if args.host_speeds > 0:
        per, cpu = host_chart(args.host_speeds)
        verdict = "met" if cpu <= HOST_TARGET else "MISSED"
        print(f"host side of a {8 * args.host_speeds}-point chart (GPU groups, kernel "
              f"replayed, load {os.getloadavg()[0]:.1f}): {per:.3f} ms/point wall, {cpu:.3f} "
              f"ms/point CPU: {cpu * 160:.0f} s of CPU for 160 000 points (target <= "
              f"{HOST_TARGET} ms/point CPU: {verdict})")
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
