"""Compiled flow maps (shooting, monodromy, continuation) against the same Functions in the
CasADi VM, against the flow map written as one MX fold with AD jacobians, and the cache."""

from __future__ import annotations

import shutil

import casadi as ca
import numpy as np
import pytest

from analysis.integrate import compiled
from analysis.integrate.flow import (
    Period,
    evaluate,
    flow_map,
    orbit_states,
    steps_per_period,
)
from analysis.model import load_model

pytestmark = pytest.mark.skipif(shutil.which(compiled.DEFAULT_CC) is None,
                                reason=f"no C compiler ({compiled.DEFAULT_CC})")

CASES = {"balanced-rotor": dict(radial_load=50.0),
         "rotor-housing": dict(radial_load=50.0, unbalance_force=0.0)}


def _setting(name: str):
    model = load_model(name)
    values = {**model.defaults, **CASES[name]}
    per = Period.parse("vc")
    n_steps = steps_per_period(model, (8,), per, values, 1e-5)
    z0 = compiled.test_state(model.n_state)
    return model, per, n_steps, z0, model.parameter_vector(values)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("name", sorted(CASES))
def test_compiled_flow_map_equals_the_vm(name):
    """zT, monodromy and dzT/dp of the compiled flow map and of the VM's, 1e-12 relative;
    the orbit's states likewise, its last column the flow's zT."""
    model, per, n_steps, z0, p = _setting(name)
    fast = evaluate(flow_map(model, (8,), per, n_steps), z0, 0.0, p)
    vm = evaluate(flow_map(model, (8,), per, n_steps, compiled=False), z0, 0.0, p)
    for got, want in zip(fast, vm, strict=True):
        assert np.all(np.isfinite(got)) and _relative(got, want) <= 1e-12
    states = np.asarray(orbit_states(model, (8,), per, n_steps)(z0, 0.0, p))
    states_vm = np.asarray(orbit_states(model, (8,), per, n_steps, compiled=False)(z0, 0.0, p))
    assert states.shape == (model.n_state, n_steps)
    assert _relative(states, states_vm) <= 1e-12
    assert _relative(states[:, -1], fast[0]) <= 1e-12


def _fold_flow(model, per, n_steps):
    """The flow map as one MX fold of RK4 steps with AD jacobians (time accumulated step by
    step): an independent formulation of the same derivatives."""
    step = model.functions((8,)).rk4_step
    n, n_par = model.n_state, len(model.parameter_names)
    zt, p, h = ca.MX.sym("zt", n + 1), ca.MX.sym("p", n_par), ca.MX.sym("h")
    advance = ca.Function("advance", [zt, p, h],
                          [ca.vertcat(step(zt[n], zt[:n], p, h), zt[n] + h)])
    z0, t0 = ca.MX.sym("z0", n), ca.MX.sym("t0")
    h_value = per.seconds(model, (8,), p) / n_steps
    z_end = advance.fold(n_steps)(ca.vertcat(z0, t0), ca.repmat(p, 1, n_steps),
                                  ca.repmat(h_value, 1, n_steps))[:n]
    return ca.Function("fold_flow", [z0, t0, p],
                       [z_end, ca.jacobian(z_end, z0), ca.jacobian(z_end, p)])


def test_compiled_flow_map_equals_the_fold_with_ad_jacobians():
    """Monodromy and dzT/dp (the period's dependence on p and the steps' times included)
    agree with the AD of one MX fold over the period, at t0 ≠ 0."""
    model, per, _, z0, p = _setting("rotor-housing")
    n_steps = 123  # one block of 100, two of 10, three single steps
    got = evaluate(flow_map(model, (8,), per, n_steps), z0, 0.37e-3, p)
    want = evaluate(_fold_flow(model, per, n_steps), z0, 0.37e-3, p)
    for a, b in zip(got, want, strict=True):
        assert _relative(a, b) <= 1e-11


def test_one_library_serves_every_step_count():
    """The compiled blocks do not depend on the period or the number of steps: a new step
    count and a new period compile nothing."""
    model, per, n_steps, z0, p = _setting("balanced-rotor")
    evaluate(flow_map(model, (8,), per, n_steps), z0, 0.0, p)
    before = compiled.compilations()
    for count, period in ((n_steps + 7, per), (211, Period.parse("shaft"))):
        *_, mono, _ = evaluate(flow_map(model, (8,), period, count), z0, 0.0, p)
        assert np.all(np.isfinite(mono))
    assert compiled.compilations() == before
