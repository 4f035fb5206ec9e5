"""The paper's calibration (issue 30): which rotor mass, damping and contact stiffness make
`vakharia2015` reproduce Table 2 of the seed paper (target ``paper-table2``).

Priors, all log-uniform: rotor_mass 0.1-10 kg, damping 10-3162 N·s/m, contact_stiffness
3e9-2e10 N/m^1.5; the clearance as in Table 1 (the spec's 10 µm). Each parameter set runs
at the five N_b of Table 2 (one call of the member kernels per N_b and block), each member
``--transient-revolutions`` shaft revolutions dropped and ``--revolutions`` recorded, λ1
from a tangent over the record. Prints the wall time, runs per second, the best number of
rows matched, the share of the prior matching k rows, the 90 % credible box and the best
sets; writes the calibration (netCDF), its JSON and the corner figure to ``--out``.

    python benchmarks/bench_calibrate.py [--samples 2500] [--rounds 2] [--device cpu|gpu]
                                         [--executor serial|processes|dask] [--workers N]
                                         [--transient-revolutions 50] [--revolutions 100]
                                         [--out DIR] [--json]

Target (issue 30): >= 5000 parameter sets × 5 N_b in <= 30 min on 2 cores (the default:
2500 sets × 2 rounds); the same run on a GPU with ``--device gpu``. ``--quick`` is
``--samples 64`` for an estimate.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from analysis.inference.abc import prepare
from analysis.inference.results import calibrate_to_file, to_dataset, to_json
from analysis.inference.simulate import RunSettings
from analysis.reports.progress import ProgressReporter
from analysis.sweeps.executors import make_executor

PRIORS = ("rotor_mass:0.1:10:log", "damping:10:3162:log", "contact_stiffness:3e9:2e10:log")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2500)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--target", default="paper-table2",
                        help="paper-table2, or paper-table2-torus (N_b = 10 read as a torus)")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--executor", default="serial")
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--block", type=int, default=None,
                        help="sets per task (default: 256 on cpu, all of a round on gpu)")
    parser.add_argument("--transient-revolutions", type=int, default=50)
    parser.add_argument("--revolutions", type=int, default=100)
    parser.add_argument("--out", type=Path, default=Path("bench-calibrate"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    samples = 64 if args.quick else args.samples
    block = args.block or (samples if args.device == "gpu" else 256)
    problem = prepare("vakharia2015", args.target, PRIORS, samples=samples,
                      rounds=args.rounds, seed=args.seed, device=args.device, block=block,
                      settings=RunSettings(transient_revolutions=args.transient_revolutions,
                                           revolutions=args.revolutions))
    cost = problem.estimate()
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.target.replace("paper-table2", "paper-calibration")
    output = args.out / f"{stem}.nc"
    executor = make_executor(args.executor, args.workers)
    start = time.perf_counter()
    try:
        cal = calibrate_to_file(problem, output, executor=executor,
                                progress=ProgressReporter("calibrate", unit="runs"),
                                log=print)
    finally:
        executor.close()
    wall = time.perf_counter() - start
    doc = to_json(cal, str(output))
    (args.out / f"{stem}.json").write_text(json.dumps(doc, indent=1))
    from analysis.reports.calibration_plots import corner_figure
    from analysis.reports.plots import save_figure

    save_figure(corner_figure(to_dataset(cal)), args.out / f"{stem}.png")
    runs = int(cost["simulations"])
    summary = {"sets": samples * args.rounds, "rows": len(problem.target.rows), "runs": runs,
               "wall_s": round(wall, 1), "runs_per_s": round(runs / wall, 2),
               "estimated_core_s": round(cost["core_seconds"], 1), "device": cal.device,
               "executor": executor.name, "best_matched": doc["best_matched"],
               "share_of_prior": doc["share_of_prior"], "credible_90": doc["credible_90"],
               "tolerances": doc["tolerances"],
               "best": [{"parameters": b["parameters"], "matched": b["matched"],
                         "lines_matched": b["lines_matched"],
                         "classes": [r["class"] for r in b["rows"]]} for b in doc["best"][:5]]}
    print(json.dumps(summary, indent=1) if args.json else
          "\n".join(f"{k}: {v}" for k, v in summary.items()))


if __name__ == "__main__":
    main()
