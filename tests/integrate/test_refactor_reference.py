"""The shipped one-rotor specs give the numbers they gave before "models of any shape".

``tests/data/pre_shapes_reference.npz`` holds runs computed at commit 3a34198, the last commit
before the bodies-and-bearings schema, the any-size generated code and the analysis
sub-packages (a worktree of that commit on ``PYTHONPATH``, its own compile cache)::

    simulate(model, n_balls, duration=0.5, transient=0.0, **params)   # every 500th sample
    simulate("duffing", duration=100.0, transient=0.0, dt=0.01)        # every 100th sample

A refactor changes no result: each state here must agree with today's run to 1e-9 of that
state's largest magnitude (two correct RK4 codes that order their operations differently
differ by about 4e-11 on the N_b = 10 case). When this was written they agreed bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.integrate.simulate import simulate

REFERENCE = np.load(Path(__file__).parents[1] / "data" / "pre_shapes_reference.npz")


def _case(key: str) -> tuple[str, int | None, dict[str, float]]:
    model, n_balls, params = key.split("|")
    values = dict(item.split("=") for item in params.split(",") if item)
    return model, int(n_balls) if n_balls else None, {k: float(v) for k, v in values.items()}


@pytest.mark.parametrize("key", sorted(REFERENCE.files))
def test_shipped_specs_reproduce_the_pre_refactor_runs(key):
    model, n_balls, params = _case(key)
    if model == "duffing":
        ds = simulate(model, duration=100.0, transient=0.0, **params)
        states, every = ("x", "vx"), 100
    else:
        ds = simulate(model, n_balls, duration=0.5, transient=0.0, **params)
        states, every = ("x", "y", "vx", "vy"), 500
    reference = REFERENCE[key]
    for row, name in zip(reference, states, strict=True):
        today = ds[name].values[::every]
        assert today.shape == row.shape
        scale = np.max(np.abs(row))
        assert scale > 0.0
        assert np.max(np.abs(today - row)) <= 1e-9 * scale, name
