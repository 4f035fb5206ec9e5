"""Benchmark: seconds per continuation step and per shooting solve, with the flow maps
compiled to C (the default) and in the CasADi VM (``compiled=False``), in the same run.

The case is that of ``bearingdyn continue balanced-rotor --n-balls 8 --param speed_rpm
--from 2000 --to 10000 --set radial_load=50`` on a shorter range (``--to``, default 4000
rpm): the first orbit is shot once, then both paths continue the branch from it with the
same settings, so they compute the same points (checked: the branches agree to 1e-8).
A continuation step is one new orbit of the branch (its predictor, Newton corrections,
amplitude and any special point located on the way): the wall time of the continuation
divided by its number of new points. A shooting solve is ``shoot`` from a fixed guess
(the state after 0.05 s, a few Newton iterations away; the simulation for the guess not
timed). Library loading and compilation are done once
before timing. Target: <= 0.05 s per continuation step compiled (0.41 s before).

    python benchmarks/bench_continuation.py [--to 4000] [--repeat 3] [--max-points 40]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time
from collections.abc import Iterator

import numpy as np

from analysis.integrate import flow
from analysis.model import System, load_model
from analysis.stability import continuation, periodic

MODEL, N_BALLS, PARAM, START = "balanced-rotor", 8, "speed_rpm", 2000.0
VALUES = {"radial_load": 50.0}
TARGET = 0.05
SHOOT_SETTLE = 0.05
"""s simulated for the guess of the timed shooting solves: a few Newton iterations left."""


@contextlib.contextmanager
def vm_flow_maps() -> Iterator[None]:
    """``flow_map`` and ``orbit_states`` with ``compiled=False`` in shooting and continuation."""
    saved = {(mod, name): getattr(mod, name) for mod in (continuation, periodic)
             for name in ("flow_map", "orbit_states")}

    def vm(fn):
        return lambda *args: fn(*args, compiled=False)

    try:
        for mod, name in saved:
            setattr(mod, name, vm(getattr(flow, name)))
        yield
    finally:
        for (mod, name), fn in saved.items():
            setattr(mod, name, fn)


def _timed(fn, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def run(stop: float, repeat: int, max_points: int) -> dict:
    model = load_model(MODEL)
    system = System.make(model, N_BALLS, None, **{**VALUES, PARAM: START})
    per = periodic.as_period(model, None)
    dt = model.simulation_defaults["dt"]
    orbit = periodic.shoot(system, None, None, *periodic.default_guess(system, per, None, dt))
    guess, t0 = periodic.default_guess(system, per, SHOOT_SETTLE, dt)
    assert orbit.converged, orbit.message

    def branch():
        return continuation.continue_from_orbit(orbit, param=PARAM, stop=stop,
                                                max_points=max_points)

    def solve():
        return periodic.shoot(system, None, None, guess, t0)

    rows = {}
    for label, ctx in (("compiled", contextlib.nullcontext), ("vm", vm_flow_maps)):
        with ctx():
            branch()  # warm-up: load (or build) the libraries, build the Functions
            solve()
            t_branch, br = _timed(branch, repeat)
            t_shoot, sh = _timed(solve, repeat)
        points = br.sizes["point"] - 1
        rows[label] = dict(per_step=t_branch / points, points=points, branch_s=t_branch,
                           per_shoot=t_shoot, shoot_iterations=sh.iterations, branch=br,
                           shot=sh)
    a, b = rows["compiled"]["branch"], rows["vm"]["branch"]
    same = a.sizes["point"] == b.sizes["point"]
    diff = float(np.max(np.abs(a[PARAM].values - b[PARAM].values)) / abs(stop - START)) \
        if same else float("inf")
    return dict(rows=rows, stop=stop, n_steps=orbit.n_steps, status=a.attrs["status"],
                agree=diff, specials=[str(s) for s in a.special.values if s])


def report(res: dict, repeat: int) -> str:
    rows = res["rows"]
    c, v = rows["compiled"], rows["vm"]
    lines = [f"{MODEL}, N_b = {N_BALLS}, radial_load = 50 N, {PARAM} {START:g} -> "
             f"{res['stop']:g} rpm, dt = 1e-5 s ({res['n_steps']} RK4 steps per VC period at "
             f"the start); median of {repeat}",
             "",
             "| flow maps | s per continuation step | points | s per shooting solve "
             "(Newton its) |",
             "|---|---:|---:|---:|"]
    for label, r in (("compiled C", c), ("CasADi VM", v)):
        lines.append(f"| {label} | {r['per_step']:.4f} | {r['points']} | "
                     f"{r['per_shoot']:.4f} ({r['shoot_iterations']}) |")
    lines += ["",
              f"ratio VM / compiled: continuation step {v['per_step'] / c['per_step']:.1f}x, "
              f"shooting solve {v['per_shoot'] / c['per_shoot']:.1f}x",
              f"target <= {TARGET} s per continuation step (compiled): {c['per_step']:.4f} s, "
              f"{'met' if c['per_step'] <= TARGET else 'NOT met'}",
              f"branches agree: max |Δ{PARAM}| / range = {res['agree']:.1e}; status "
              f"'{res['status']}'; special points {', '.join(res['specials']) or 'none'}"]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--to", type=float, default=4000.0, help="end speed, rpm")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--max-points", type=int, default=40)
    args = parser.parse_args()
    res = run(args.to, args.repeat, args.max_points)
    print(report(res, args.repeat))
    if res["agree"] > 1e-8:
        raise SystemExit("compiled and VM branches differ")


if __name__ == "__main__":
    main()
