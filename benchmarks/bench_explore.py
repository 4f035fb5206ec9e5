"""The explorer's cost against its chart's: the chart of the explore guide (vakharia2015,
13 speeds 2000-8000 rpm × N_b = 5…10, 0.3 s transient, 60 revolutions, λ1 at every point)
and then its explorer page (each point simulated again for its spectra, peaks and Poincaré
points), on the same executor in the same run. Prints both wall times and their ratio.

    python benchmarks/bench_explore.py [--speeds 13] [--workers N] [--executor processes]
                                       [--profile]

Target (issue 25): the explorer takes no more than about twice its chart's time.
``--profile`` also profiles one point's detail in this process (where its time goes).
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import pstats
import tempfile
import time
from pathlib import Path

from analysis.reports.explorer import point_detail, write_explorer
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.executors import make_executor
from analysis.sweeps.grid import Axis, Setting

SETTING = Setting("vakharia2015", None, {}, transient=0.3, samples=60, lyapunov=True)
RATIO_TARGET = 2.0
"""Explorer / chart wall time."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speeds", type=int, default=13)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--executor", default="processes")
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    x = Axis.linear("speed_rpm", 2000, 8000, args.speeds)
    y = Axis.parse("n_balls:5:10")
    with tempfile.TemporaryDirectory() as folder:
        chart_file = Path(folder) / "chart.nc"
        executor = make_executor(args.executor, args.workers)
        try:
            start = time.perf_counter()
            chart = stability_chart(SETTING, x, y, chart_file, executor=executor)
            chart_s = time.perf_counter() - start
            start = time.perf_counter()
            write_explorer(chart, Path(folder) / "chart.html", executor=executor)
            explore_s = time.perf_counter() - start
        finally:
            executor.close()
        points = len(x.values) * len(y.values)
        ratio = explore_s / chart_s
        print(f"{points} points on {executor.name}: chart {chart_s:.1f} s, explorer "
              f"{explore_s:.1f} s, ratio {ratio:.2f} (target <= {RATIO_TARGET:g}: "
              f"{'met' if ratio <= RATIO_TARGET else 'not met'})")
        if args.profile:
            setting = dataclasses.replace(SETTING, lyapunov=False)  # as the explorer runs
            task = (setting, "speed_rpm", 5000.0, "n_balls", 6, 400)
            point_detail(task)  # the model loaded once, as in a worker
            profile = cProfile.Profile()
            profile.enable()
            point_detail(task)
            profile.disable()
            pstats.Stats(profile).sort_stats("cumulative").print_stats(14)


if __name__ == "__main__":
    main()
