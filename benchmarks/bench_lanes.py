"""Cost of one RK4 step of a chart point, three ways, interleaved in one process:

- the model's compiled RK4 block, states only (``analysis.integrate.compiled.Runner``);
- the scalar tangent block of a chart point (``points.chart_blocks``: states and one tangent
  vector, CasADi's compiled C);
- the lane kernel (``analysis.integrate.lanes``): states and tangent of ``LANES`` points per
  call, per point, with the step of ``simulate`` and with the chart's step
  (``tangent.Carry.angle_addition``: the shaft angle of the later RK4 stages by angle
  addition, two sin/cos pairs fewer).

    python benchmarks/bench_lanes.py [--model vakharia2015] [--n-balls 8] [--repeat 20]

Prints the median and minimum µs per step (per point for the lanes) and the ratios to the
states-only step measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from analysis.integrate.compiled import Runner, library
from analysis.integrate.lanes import LANES, kernel
from analysis.model import load_model
from analysis.sweeps.points import (
    ANGLE_ADDITION,
    LANE_RENORMS,
    RENORM_EVERY,
    _Caller,
    chart_blocks,
)

STEPS = 30_000
"""RK4 steps per timed run of each path."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="vakharia2015")
    parser.add_argument("--n-balls", type=int, default=8)
    parser.add_argument("--speed-rpm", type=float, default=2000.0)
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args()
    model = load_model(args.model)
    structure = model.structure(args.n_balls)
    dt = float(model.simulation_defaults["dt"])
    speeds = [args.speed_rpm * (1 + 0.02 * k) for k in range(LANES)]
    params = [model.parameter_vector(model.parameters({"speed_rpm": v})) for v in speeds]
    z = np.asarray(model.initial_state, dtype=float)
    n = model.n_state
    start = np.concatenate([z, [0.0], np.eye(n)[:, 0]])
    runner = Runner(library(model, structure), params[0], dt)
    scalar = _Caller(chart_blocks(model, structure)[100], start.copy(), params[0], dt)
    kernels = [kernel(model, structure, RENORM_EVERY, False),
               kernel(model, structure, RENORM_EVERY, True)]
    if None in kernels:
        raise SystemExit("no lane kernel for this model (see analysis/integrate/lanes.py)")
    p = np.stack(params, axis=1)
    times: dict[str, list[float]] = {
        "states only": [], f"tangent, scalar block{' (angle addition)' * ANGLE_ADDITION}": [],
        f"tangent, lanes ({LANES} points per call)": [],
        f"tangent, lanes, angle addition ({LANES} points per call)": []}
    renorms = STEPS // RENORM_EVERY
    for _ in range(args.repeat + 1):  # the first round warms up, not kept
        t = time.perf_counter()
        for _ in runner.blocks(z, STEPS):
            pass
        a = time.perf_counter() - t
        t = time.perf_counter()
        for _ in range(STEPS // 10_000):
            scalar()
        b = time.perf_counter() - t
        lane_times = []
        for lanes in kernels:
            s = np.ascontiguousarray(np.repeat(start[:, None], LANES, axis=1))
            t = time.perf_counter()
            for _ in range(renorms // LANE_RENORMS):
                lanes.run(s, p, np.full(LANES, dt), np.zeros(LANES), LANE_RENORMS,
                          RENORM_EVERY)
            lane_times.append((time.perf_counter() - t) / LANES)
        for key, value in zip(times, (a, b, *lane_times), strict=True):
            times[key].append(value / STEPS * 1e6)
    for key in times:
        times[key] = times[key][1:]
    base = statistics.median(times["states only"])
    print(f"{model.name}, N_b = {args.n_balls}, {args.speed_rpm:g} rpm, dt = {dt:g} s; "
          f"{STEPS} steps per run, {args.repeat} interleaved runs")
    print("| path | median (µs per step) | min | ratio of medians to states only |")
    print("|---|---:|---:|---:|")
    for key, values in times.items():
        med = statistics.median(values)
        print(f"| {key} | {med:.3f} | {min(values):.3f} | {med / base:.2f} |")


if __name__ == "__main__":
    main()
