"""1 s of simulated motion (N_b = 8, Δt = 1e-5 s, the paper's case) through bearingdyn's
CasADi RK4 and through SciPy ``solve_ivp`` (RK45) with a Python right-hand side made from the
same SymPy equations (``lambdify``), in one process. Prints medians and the ratio.

    python benchmarks/bench_simulate.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from analysis import load_model, simulate
from modelgen.assemble import assemble
from modelgen.spec import load_spec

MODEL, N_BALLS, DURATION = "vakharia2015", 8, 1.0


def scipy_rhs():
    eq = assemble(load_spec(MODEL)[0])
    ctx = eq.ctx
    f = sp.lambdify([ctx.t, sp.Matrix(ctx.state), *ctx.params.values()],
                    eq.first_order(N_BALLS), modules="numpy", cse=True)
    values = list(load_model(MODEL).defaults.values())
    return lambda t, z: np.asarray(f(t, z, *values), dtype=float).ravel()


def timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    model = load_model(MODEL)
    simulate(model, N_BALLS, duration=0.01, transient=0.0)  # build the CasADi functions once
    t_rk4, ds = timed(lambda: simulate(model, N_BALLS, duration=DURATION, transient=0.0),
                      args.repeat)
    rhs = scipy_rhs()
    z0 = [1e-6, 1e-6, 0.0, 0.0]
    t_ivp, sol = timed(lambda: solve_ivp(rhs, (0, DURATION), z0, method="RK45", rtol=1e-9,
                                         atol=1e-14), max(1, args.repeat // 5))
    print(f"{'path':44s} {'median (s)':>10s} {'ratio':>8s}")
    print(f"{'bearingdyn RK4 (CasADi VM, 1e5 steps)':44s} {t_rk4:10.3f} {1.0:8.1f}")
    print(f"{'SciPy solve_ivp RK45, Python rhs (lambdify)':44s} {t_ivp:10.3f} "
          f"{t_ivp / t_rk4:8.1f}")
    print(f"solve_ivp: {sol.nfev} rhs evaluations, status {sol.status}; "
          f"RK4 steps: {ds.sizes['t'] - 1}")


if __name__ == "__main__":
    main()
