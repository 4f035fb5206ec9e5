"""Cost per state of a reduced flexible rotor's RK4 step against today's 8-state models.

The shipped ``three-disk-rotor`` (a finite-element shaft reduced by Craig–Bampton to 32
states, two 8-ball bearings) and the shipped 8-state models (``two-bearing-rotor``,
``rotor-housing``, ``6205-outer-defect``) each run the same number of RK4 steps of their
spec's dt from their default state through the compiled library ``simulate`` uses
(``analysis.integrate.compiled``); the best of ``--repeat`` runs is kept. Printed: µs per
step, µs per step and state, and the ratio of the flexible model's cost per state to each
8-state model's and to their mean (the goal: at most 1.5). The cost per state counts the
work of the whole model, so the ratio says whether a 4× larger state costs at most 6× the
time of a step.

    python benchmarks/bench_flexible.py [--steps 50000] [--repeat 3]
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


def step_cost(name: str, steps: int, repeat: int) -> tuple[int, float]:
    """(states, best seconds per RK4 step) of model ``name`` at its defaults."""
    model = load_model(name)
    lib = library(model, None)
    p = np.asarray(model.parameter_vector(model.defaults), dtype=float)
    z0 = np.asarray(model.module.INITIAL_STATE, dtype=float)
    dt = float(model.module.SIMULATION["dt"])
    run_rk4(lib, p, z0, dt, 1000, save_every=1000)  # warm: load, first blocks
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        run_rk4(lib, p, z0, dt, steps, save_every=steps)
        best = min(best, (time.perf_counter() - start) / steps)
    return model.n_state, best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=50_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    costs = {name: step_cost(name, args.steps, args.repeat) for name in (FLEXIBLE, *RIGID)}
    for name, (n, seconds) in costs.items():
        print(f"{name:20s} {n:3d} states  {seconds * 1e6:8.3f} µs/step  "
              f"{seconds * 1e6 / n:7.4f} µs/step/state")
    n_flex, t_flex = costs[FLEXIBLE]
    per_state = t_flex / n_flex
    ratios = {name: per_state / (seconds / n) for name, (n, seconds) in costs.items()
              if name != FLEXIBLE}
    mean = per_state / np.mean([seconds / n for name, (n, seconds) in costs.items()
                                if name != FLEXIBLE])
    for name, ratio in ratios.items():
        print(f"cost per state, {FLEXIBLE} / {name}: {ratio:.2f}")
    print(f"cost per state, {FLEXIBLE} / the mean of the 8-state models: {mean:.2f} "
          f"(goal <= {GOAL}: {'met' if mean <= GOAL else 'NOT met'})")


if __name__ == "__main__":
    main()
