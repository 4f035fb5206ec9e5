"""The step rule of the member kernels (issue 33, item 7) against the value-by-value path.

A brute-force diagram (``sweep --no-follow``) of vakharia2015, N_b 10, 41 speeds from 4000 to
6000 rpm (1 s transient, 64 shaft sections) computed twice in one run: value by value (RK4 at
dt, sections interpolated between steps) and on the member kernels (``device="cpu"``: each
value's step the largest h <= dt dividing its shaft period, sections on steps). Prints, per
speed, the largest difference of the section points of x and y (relative to the largest
value of each) and of the amplitudes (relative), and both wall times.

    python benchmarks/bench_step_rule.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting

SETTING = Setting("vakharia2015", 10, {}, transient=1.0, samples=64)
AXIS = Axis.parse("speed_rpm:4000:6000:41")


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        a = bifurcation_diagram(SETTING, AXIS, Path(folder) / "a.nc", follow=False)
        per_value = time.perf_counter() - start
        start = time.perf_counter()
        b = bifurcation_diagram(SETTING, AXIS, Path(folder) / "b.nc", follow=False,
                                device="cpu")
        ensemble = time.perf_counter() - start
    print(f"value by value {per_value:.1f} s, member kernels {ensemble:.1f} s")
    for i, rpm in enumerate(AXIS.values):
        points = max(np.abs(a[k].values[0, i] - b[k].values[0, i]).max()
                     / np.abs(a[k].values[0]).max() for k in ("x", "y"))
        amplitude = max(abs(b[f"amplitude_{k}"].values[0, i]
                            / a[f"amplitude_{k}"].values[0, i] - 1) for k in ("x", "y"))
        print(f"{rpm:7.0f} rpm  section points {points:.2e} of the largest, "
              f"amplitudes {amplitude:.2e}")


if __name__ == "__main__":
    main()
