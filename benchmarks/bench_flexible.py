"""Cost per state of a reduced flexible rotor's RK4 step against today's 8-state models.

The shipped ``three-disk-rotor`` (a finite-element shaft reduced by Craig–Bampton to 32
states, two 8-ball bearings) and the shipped 8-state models (``two-bearing-rotor``,
``rotor-housing``, ``6205-outer-defect``) each run the same number of RK4 steps of their
spec's dt from their default state through the compiled library ``simulate`` uses
(``analysis.integrate.compiled``), taking turns; the best of ``--repeat`` turns is kept.
Printed: µs per step, µs per step and state, the CasADi instructions of one step (a count
no load of the machine changes), and the ratio of the flexible model's cost per state to
each 8-state model's and to their mean (the goal: at most 1.5). The cost per state counts the
work of the whole model, so the ratio says whether a 4× larger state costs at most 6× the
time of a step.

    python benchmarks/bench_flexible.py [--steps 20000] [--repeat 9]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from analysis.integrate.compiled import library, run_rk4
from analysis.model import load_model

FLEXIBLE = "three-disk-rotor"
RIGID = ("two-bearing-rotor", "rotor-housing", "6205-outer-defect")
GOAL = 1.5
"""The flexible model's cost per state may be at most this many times the 8-state models'."""


def _setup(name: str):
    model = load_model(name)
    lib = library(model, None)
    p = np.asarray(model.parameter_vector(model.defaults), dtype=float)
    z0 = np.asarray(model.module.INITIAL_STATE, dtype=float)
    dt = float(model.module.SIMULATION["dt"])
    run_rk4(lib, p, z0, dt, 1000, save_every=1000)  # warm: load, first blocks
    return model, lib, p, z0, dt


def step_costs(names: tuple[str, ...], steps: int, repeat: int) -> dict[str, tuple]:
    """Per model: (states, best seconds per RK4 step, CasADi instructions of one step).
    The models take turns, ``repeat`` rounds: a load spike of the machine slows one turn of
    each, not one model's every run, and the best turn is kept."""
    runs = {name: _setup(name) for name in names}
    best = dict.fromkeys(names, np.inf)
    for _ in range(repeat):
        for name, (_, lib, p, z0, dt) in runs.items():
            start = time.perf_counter()
            run_rk4(lib, p, z0, dt, steps, save_every=steps)
            best[name] = min(best[name], (time.perf_counter() - start) / steps)
    return {name: (model.n_state, best[name],
                   model.functions(None).rk4_step.n_instructions())
            for name, (model, *_) in runs.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--repeat", type=int, default=9)
    args = parser.parse_args()
    costs = step_costs((FLEXIBLE, *RIGID), args.steps, args.repeat)
    for name, (n, seconds, ops) in costs.items():
        print(f"{name:20s} {n:3d} states  {seconds * 1e6:8.3f} µs/step  "
              f"{seconds * 1e6 / n:7.4f} µs/step/state  {ops:5d} instructions "
              f"({ops / n:.0f} per state)")
    n_flex, t_flex, ops_flex = costs[FLEXIBLE]
    rigid = [costs[name] for name in RIGID]
    for name in RIGID:
        n, seconds, _ = costs[name]
        print(f"cost per state, {FLEXIBLE} / {name}: {t_flex / n_flex / (seconds / n):.2f}")
    mean = t_flex / n_flex / np.mean([seconds / n for n, seconds, _ in rigid])
    ops = ops_flex / n_flex / np.mean([o / n for n, _, o in rigid])
    print(f"cost per state, {FLEXIBLE} / the mean of the 8-state models: {mean:.2f} "
          f"(goal <= {GOAL}: {'met' if mean <= GOAL else 'NOT met'}); CasADi instructions "
          f"per state: {ops:.2f}")


if __name__ == "__main__":
    main()
