"""Benchmark: the compiled RK4 of generated models against hand-written numba RK4s of the
same equations, measured in the same run (the targets of "Models of any shape").

- 2-DOF: vakharia2015, N_b = 8 (the numba kernel of ``analysis.reports.bench``);
- 8 states: rotor-housing, N_b = 8 (a numba kernel written out below).

Both paths keep every state of a 1 s run at Δt = 1e-5 s (1e5 steps); the time is the median
of ``--repeat`` runs, taken in turns so that load on the machine hits both alike. Numba's
JIT compilation and bearingdyn's C compilation (cached) are not timed. Targets: compiled /
numba ≤ 1.2 (2-DOF) and ≤ 1.3 (rotor-housing). The final states of the two paths are
compared on a non-chaotic setting (they must agree to 1e-9 relative).

    python benchmarks/bench_shapes.py [--repeat 5] [--duration 1.0] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from analysis.integrate.compiled import library, run_rk4
from analysis.model import load_model
from analysis.reports import bench

DT = 1e-5
N_BALLS = 8
TARGETS = {"vakharia2015": 1.2, "rotor-housing": 1.3}
CALM = {"radial_load": 50.0, "damping": 2000.0}
"""A non-chaotic setting, where two correct RK4 codes must agree to rounding."""


def housing_kernel() -> Callable:
    """numba RK4 of the rotor in a sprung housing: ``rk4(z0, h, n, constants) -> states
    (n + 1, 8)``; one sin/cos of the cage angle per stage, angle addition over the balls."""
    import numba

    jit = numba.njit(error_model="numpy")

    @jit
    def rhs(t, z, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi, dz):
        c0, s0 = math.cos(wc * t), math.sin(wc * t)
        rx, ry = z[0] - z[2], z[1] - z[3]
        rvx, rvy = z[4] - z[6], z[5] - z[7]
        qx = 0.0
        qy = 0.0
        for i in range(cphi.shape[0]):
            ci = cphi[i] * c0 - sphi[i] * s0
            si = sphi[i] * c0 + cphi[i] * s0
            d = rx * ci + ry * si - gam
            if d > 0.0:
                q = k * (d * math.sqrt(d))
                qx += q * ci
                qy += q * si
        fxr = pr + pu * math.cos(w * t) - c * rvx - qx
        fyr = pu * math.sin(w * t) - c * rvy - qy
        fxh = -k_h * z[2] - c_h * z[6] + c * rvx + qx
        fyh = -k_h * z[3] - c_h * z[7] + c * rvy + qy
        dz[0], dz[1], dz[2], dz[3] = z[4], z[5], z[6], z[7]
        dz[4], dz[5], dz[6], dz[7] = fxr / m_r, fyr / m_r, fxh / m_h, fyh / m_h

    @jit
    def kernel(z0, h, n, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi):
        out = np.empty((n + 1, 8))
        z = z0.copy()
        out[0] = z
        k1, k2, k3, k4 = np.empty(8), np.empty(8), np.empty(8), np.empty(8)
        tmp = np.empty(8)
        g = h / 2
        for step in range(n):
            t = step * h
            rhs(t, z, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi, k1)
            for j in range(8):
                tmp[j] = z[j] + g * k1[j]
            rhs(t + g, tmp, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi, k2)
            for j in range(8):
                tmp[j] = z[j] + g * k2[j]
            rhs(t + g, tmp, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi, k3)
            for j in range(8):
                tmp[j] = z[j] + h * k3[j]
            rhs(t + h, tmp, w, wc, k, gam, c, pr, pu, m_r, m_h, k_h, c_h, cphi, sphi, k4)
            for j in range(8):
                z[j] += h / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j])
            out[step + 1] = z
        return out

    return kernel


def housing_constants(v: dict[str, float]) -> tuple:
    w = math.pi / 30 * v["speed_rpm"]
    d_i, d_o = v["inner_race_diameter"], v["outer_race_diameter"]
    phi = 2 * np.pi * np.arange(N_BALLS) / N_BALLS
    return (w, w * d_i / (d_i + d_o), v["contact_stiffness"], v["radial_clearance"],
            v["damping"], v["radial_load"], v["unbalance_force"], v["rotor_mass"],
            v["housing_mass"], v["housing_stiffness"], v["housing_damping"], np.cos(phi),
            np.sin(phi))


def paths(name: str, values: dict[str, float], n_steps: int) -> dict[str, Callable]:
    """The two ways of running ``name``: bearingdyn's compiled RK4 and numba."""
    model = load_model(name)
    lib = library(model, N_BALLS)
    p, z0 = model.parameter_vector(values), model.initial_state
    if name == "rotor-housing":
        kernel, args = housing_kernel(), housing_constants(values)
        numba_run = lambda: kernel(z0, DT, n_steps, *args)  # noqa: E731
    else:
        ref = bench.Reference.from_parameters(values, N_BALLS)
        kernel = bench.numba_rk4()
        numba_run = lambda: kernel(ref, z0, DT, n_steps)  # noqa: E731
    compiled = lambda: run_rk4(lib, p, z0, DT, n_steps).T  # noqa: E731
    return {"compiled": compiled, "numba": numba_run, "backend": lib.backend}


def measure(name: str, repeat: int, duration: float,
            progress: Callable[[str], None] = print) -> dict:
    """Median times (s) of both paths, their ratio, and their agreement on ``CALM``."""
    model = load_model(name)
    n_steps = round(duration / DT)
    run = paths(name, model.defaults, n_steps)
    calm = paths(name, model.parameters(CALM), n_steps)
    ends = {k: np.asarray(calm[k]())[-1] for k in ("compiled", "numba")}  # also warms up
    for k in ("compiled", "numba"):
        run[k]()
    times: dict[str, list[float]] = {"compiled": [], "numba": []}
    progress(f"{name}: {repeat} runs of each path, {n_steps:.0e} steps …")
    for _ in range(repeat):
        for k in ("compiled", "numba"):
            start = time.perf_counter()
            run[k]()
            times[k].append(time.perf_counter() - start)
    scale = np.maximum(np.abs(ends["numba"]), 1e-300)
    median = {k: statistics.median(v) for k, v in times.items()}
    return {"model": name, "states": model.n_state, "backend": run["backend"],
            "compiled_s": median["compiled"], "numba_s": median["numba"],
            "ratio": median["compiled"] / median["numba"], "target": TARGETS[name],
            "agreement": float(np.max(np.abs(ends["compiled"] - ends["numba"]) / scale))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--duration", type=float, default=1.0, help="simulated time, s")
    parser.add_argument("--json", type=Path, help="also write the results as JSON")
    args = parser.parse_args(argv)
    results = [measure(name, args.repeat, args.duration,
                       lambda msg: print(msg, file=sys.stderr)) for name in TARGETS]
    print(f"{'model':16s} {'states':>6s} {'compiled (s)':>13s} {'numba (s)':>10s} "
          f"{'ratio':>6s} {'target':>7s} {'agree':>8s}")
    for r in results:
        ok = "ok" if r["ratio"] <= r["target"] else "MISSED"
        print(f"{r['model']:16s} {r['states']:6d} {r['compiled_s']:13.4f} {r['numba_s']:10.4f} "
              f"{r['ratio']:6.2f} {'≤ ' + format(r['target'], 'g'):>7s} {r['agreement']:8.1e}"
              f"  {ok}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
