"""Benchmark: seconds per continuation point, harmonic balance (with Hill's stability)
against shooting (with Floquet multipliers), on the same balanced-rotor branch, in the same
run.

The case is that of ``bearingdyn continue balanced-rotor --n-balls 8 --set radial_load=50
--param speed_rpm --from 7600 --to 8600`` (period vc, both period doublings inside). The
shooting branch uses the spec's RK4 step (1e-5 s, compiled flow maps); the HB branches use
H harmonics of the VC frequency (``--harmonics``, default 20 40 80) on the default AFT
samples. A point is one accepted point of the branch, special points located on the way
included: the wall time of the continuation (from its first solved response or orbit; the
first solve and the library loading are done once before timing) divided by its points.
Each row also gives the PD points found, so speed and accuracy are read together (the
exact-ODE PDs, from shooting with dt = 1e-6 s: 8141.92 and 8342.31 rpm).
Goal of issue 23: HB time per point <= 0.2 x shooting's.

    python benchmarks/bench_hb.py [--harmonics 20 40 80] [--to 8600]
"""

from __future__ import annotations

import argparse
import os
import time

from analysis.frequency import continue_harmonic, harmonic_balance
from analysis.model import System
from analysis.stability import continuation, periodic

MODEL, N_BALLS, PARAM, START = "balanced-rotor", 8, "speed_rpm", 7600.0
VALUES = {"radial_load": 50.0}
GOAL = 0.2
EXACT_PD = (8141.92, 8342.31)


def pds(branch) -> list[float]:
    return [float(v) for v, s in zip(branch[PARAM].values, branch.special.values, strict=True)
            if s == "PD"]


def run(stop: float, harmonics: list[int]) -> dict:
    system = System.make(MODEL, N_BALLS, None, **{**VALUES, PARAM: START})
    orbit = periodic.shoot(system, None, "vc")
    assert orbit.converged, orbit.message
    continuation.continue_from_orbit(orbit, param=PARAM, stop=START + 50.0)  # warm-up
    start = time.perf_counter()
    shot = continuation.continue_from_orbit(orbit, param=PARAM, stop=stop)
    rows = [dict(method="shooting (RK4 1e-5 s)", seconds=time.perf_counter() - start,
                 points=shot.sizes["point"], pd=pds(shot), status=shot.attrs["status"])]
    for h in harmonics:
        first = harmonic_balance(system, None, "vc", h, stability=False)
        assert first.converged, first.message
        start = time.perf_counter()
        br = continue_harmonic(system, param=PARAM, start=START, stop=stop, period="vc",
                               harmonics=h, guess=first.coefficients)
        rows.append(dict(method=f"HB, H = {h} (N = {br.attrs['samples']})",
                         seconds=time.perf_counter() - start, points=br.sizes["point"],
                         pd=pds(br), status=br.attrs["status"],
                         residual=float(br.residual.values.max())))
    for row in rows:
        row["per_point"] = row["seconds"] / max(1, row["points"] - 1)
    return dict(rows=rows, stop=stop)


def report(res: dict) -> str:
    rows = res["rows"]
    base = rows[0]["per_point"]
    lines = [f"{MODEL}, N_b = {N_BALLS}, radial_load = 50 N, {PARAM} {START:g} -> "
             f"{res['stop']:g} rpm, period vc; load average "
             f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}",
             "",
             "| method | points | s per point | ratio to shooting | PD points (rpm) |",
             "|---|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['points']} | {r['per_point']:.3f} | "
                     f"{r['per_point'] / base:.2f} | "
                     f"{', '.join(f'{v:.2f}' for v in r['pd']) or 'none'} |")
    best = min(r["per_point"] / base for r in rows[1:]) if len(rows) > 1 else float("nan")
    lines += ["", f"exact-ODE PDs (shooting, dt = 1e-6 s): {EXACT_PD[0]}, {EXACT_PD[1]} rpm",
              f"goal HB / shooting <= {GOAL}: best ratio {best:.2f}, "
              f"{'met' if best <= GOAL else 'NOT met'}"]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--harmonics", type=int, nargs="+", default=[20, 40, 80])
    parser.add_argument("--to", type=float, default=8600.0)
    args = parser.parse_args()
    print(report(run(args.to, args.harmonics)))


if __name__ == "__main__":
    main()
