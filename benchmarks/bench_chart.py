"""The stability-chart benchmark of the sweeps issue: N_b = 5…12 × 200 speeds (1000-10000 rpm),
each point 1 s transient + 200 shaft revolutions, classified with its largest Lyapunov
exponent, on all cores. Prints the wall time and the points per second per core.

    python benchmarks/bench_chart.py [--speeds 200] [--workers N] [--executor processes|dask]

Use --speeds 10 for a quick estimate (80 points).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from analysis.reports.progress import ProgressReporter
from analysis.sweeps.executors import make_executor
from analysis.sweeps.sweep import Axis, Setting, stability_chart


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--speeds", type=int, default=200)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--executor", default="processes")
    args = parser.parse_args()
    setting = Setting("vakharia2015", None, {}, transient=1.0, samples=200, lyapunov=True)
    x = Axis.parse(f"speed_rpm:1000:10000:{args.speeds}")
    y = Axis.parse("n_balls:5:12")
    executor = make_executor(args.executor, args.workers)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        try:
            chart = stability_chart(setting, x, y, Path(tmp) / "chart.nc", executor=executor,
                                    progress=ProgressReporter("chart"))
        finally:
            executor.close()
        wall = time.perf_counter() - start
    points = chart.sizes["speed_rpm"] * chart.sizes["n_balls"]
    counts = {k: int((chart.nature == k).sum()) for k in sorted(set(chart.nature.values.ravel()))}
    print(f"{points} points ({y.values[0]:g}-{y.values[-1]:g} balls × {len(x.values)} speeds), "
          f"{args.workers} workers ({executor.name}): {wall:.1f} s wall, "
          f"{points / wall / args.workers:.3f} points/s/core; target <= 300 s for 1600 points")
    print("classes:", counts)


if __name__ == "__main__":
    main()
