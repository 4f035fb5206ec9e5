"""Lyapunov exponents from the tangent dynamics of the RK4 map (Benettin's method).

The state is advanced with the same fixed-step RK4 as ``simulate``; a set of tangent
vectors Q (n × k, n the model's state size) is advanced with the Jacobian of each RK4 step
(CasADi forward-mode AD, ``jtimes``: the exact derivative of the discrete map applied to Q,
without forming the Jacobian) and re-orthonormalised by a QR factorisation every
``renorm_every`` steps. The exponents are the time averages of log|R_ii| (1/s). Everything,
QR included, runs inside one CasADi call per block of renormalisations.

Checks: the sum of all n exponents equals the mean phase-space divergence, the time
average of trace ∂f/∂z along the orbit (−2c/M_R for the one-body rotor with linear viscous
damping; a constant for any linear damping; otherwise sampled once per ten renormalisations
along the orbit).
Accuracy: the Jacobian contains √δ of each contact, which is not differentiable where a ball
meets the race; the tangent dynamics are still well defined and finite (``hertz15``), but
converge more slowly in Δt than smooth ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from pathlib import Path

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.integrate.compiled import compiled_function
from analysis.integrate.simulate import run_attrs, simulate, state_at
from analysis.model import BallCounts, Model, Structure, System, as_system

BLOCKS = 10
"""Batches for the confidence interval of the exponents (batch means)."""


@cache
def _tangent_block(model: Model, structure: Structure, n_vectors: int, renorm_every: int,
                   n_renorm: int) -> ca.Function:
    """(z, t, Q, p, h) -> (z, t, Q, log|diag R| per renormalisation (k × n_renorm))."""
    funcs = model.functions(structure)
    n_par, n = len(model.parameter_names), model.n_state
    z, t, h = ca.SX.sym("z", n), ca.SX.sym("t"), ca.SX.sym("h")
    p, q = ca.SX.sym("p", n_par), ca.SX.sym("q", n, n_vectors)
    z_next = funcs.rk4_step(t, z, p, h)
    state = ca.vertcat(z, t, ca.vec(q))
    step = ca.Function("tangent_step", [state, p, h],
                       [ca.vertcat(z_next, t + h, ca.vec(ca.jtimes(z_next, z, q)))])
    fold = step.fold(renorm_every)
    s, pm, hm = ca.MX.sym("s", state.shape[0]), ca.MX.sym("p", n_par), ca.MX.sym("h")
    moved = fold(s, ca.repmat(pm, 1, renorm_every), ca.repmat(hm, 1, renorm_every))
    q_new, logs = _qr_logs(n, n_vectors)(ca.reshape(moved[n + 1:], n, n_vectors))
    block = ca.Function("renorm", [s, pm, hm],
                        [ca.vertcat(moved[:n + 1], ca.vec(q_new)), logs])
    run = block.mapaccum("renorm_run", n_renorm)
    s0 = ca.MX.sym("s0", state.shape[0])
    out_state, out_logs = run(s0, ca.repmat(pm, 1, n_renorm), ca.repmat(hm, 1, n_renorm))
    return ca.Function("lyapunov_block", [s0, pm, hm], [out_state[:, -1], out_logs])


@cache
def _qr_logs(n: int, n_vectors: int) -> ca.Function:
    """Y (n × k) -> (Q with R's diagonal made positive, log|diag R|); SX, callable from MX."""
    y = ca.SX.sym("y", n, n_vectors)
    q, r = ca.qr(y)
    signs = ca.sign(ca.diag(r))  # keeps Q continuous from one block to the next
    return ca.Function("qr_logs", [y], [ca.mtimes(q, ca.diag(signs)),
                                        ca.log(ca.fabs(ca.diag(r)))])


def lyapunov(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    duration: float = 5.0,
    transient: float | None = None,
    dt: float | None = None,
    n_exponents: int | None = None,
    renorm_every: int = 100,
    initial_state: Sequence[float] | None = None,
    compiled: bool = True,
    **parameters: float,
) -> xr.Dataset:
    """Lyapunov exponents (1/s), largest first, averaged over ``duration`` seconds after a
    ``transient`` (s).

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls``, ``initial_state`` (the model's state order and units) and ``**parameters``.
    ``n_exponents`` in [1, n] (default n, the model's state size: the whole spectrum).
    ``dt`` (s) and ``transient`` default to the spec's.

    Returns a Dataset with ``exponents`` (dim ``index``), their 95 % confidence half-widths
    ``ci95`` (batch means over ten blocks), ``running`` (the running estimates over time,
    dims ``t`` × ``index``, to judge convergence) and the mean phase-space divergence
    ``mean_divergence`` (1/s) as an attribute, next to the run's provenance (``run_attrs``).
    ``compiled``: the tangent block runs as C (``analysis.integrate.compiled``), else in the
    CasADi VM.
    """
    system = as_system(system, n_balls, initial_state, **parameters)
    model, structure, values = system.model, system.structure, dict(system.parameters)
    n = model.n_state
    sim = model.simulation_defaults
    transient = float(sim["transient"] if transient is None else transient)
    dt = float(sim["dt"] if dt is None else dt)
    n_exponents = n if n_exponents is None else n_exponents
    if isinstance(n_exponents, bool) or not isinstance(n_exponents, (int, np.integer)) or \
            not 1 <= n_exponents <= n:
        raise InputError(f"n_exponents: must be an integer in [1, {n}], got {n_exponents!r}")
    n_exponents = int(n_exponents)
    if not (isinstance(renorm_every, int) and renorm_every >= 1):
        raise InputError(f"renorm_every: must be an integer >= 1, got {renorm_every!r}")
    if not duration > 0:
        raise InputError(f"duration: must be > 0 s, got {duration!r}")
    if transient > 0:
        settled = simulate(system, duration=transient + dt, transient=transient, dt=dt)
        z0 = state_at(settled, 0)
        t0 = float(settled.t[0])
    else:
        z0, t0 = system.state, 0.0
    n_renorm = max(BLOCKS, round(duration / (dt * renorm_every)))
    n_renorm -= n_renorm % BLOCKS
    per_call = BLOCKS  # one block shape for every duration: one compilation per model
    p = system.p
    state = np.concatenate([z0, [t0], np.eye(n)[:, :n_exponents].T.ravel()])
    block = compiled_function(_tangent_block(model, structure, n_exponents, renorm_every,
                                             per_call), (state, p, dt), compiled)
    logs, traces, jac = [], [], system.functions.jac
    for _ in range(n_renorm // per_call):
        out_state, out_logs = block(state, p, dt)
        state = np.asarray(out_state).ravel()
        if not np.all(np.isfinite(state)):
            raise SimulationError(f"the tangent dynamics blew up near t = {state[n]:.6g} s; "
                                  "try a smaller dt")
        logs.append(np.asarray(out_logs))
        traces.append(np.trace(np.asarray(jac(state[n], state[:n], p))))
    return _result(model, structure, values, np.concatenate(logs, axis=1), dt * renorm_every,
                   t0, float(np.mean(traces)), dt, renorm_every, duration, transient)


def _result(model: Model, structure: Structure, values: dict, logs: np.ndarray, interval: float,
            t0: float, mean_trace: float, dt: float, renorm_every: int, duration: float,
            transient: float) -> xr.Dataset:
    k, n = logs.shape
    times = t0 + interval * np.arange(1, n + 1)
    running = np.cumsum(logs, axis=1) / (interval * np.arange(1, n + 1))
    exponents = running[:, -1]
    batches = logs.reshape(k, BLOCKS, n // BLOCKS).sum(axis=2) / (interval * (n // BLOCKS))
    ci95 = 2.262 * batches.std(axis=1, ddof=1) / np.sqrt(BLOCKS)  # Student t, 9 d.o.f.
    attrs = run_attrs(model, structure, values)
    attrs.update(method="rk4 tangent map + QR (Benettin)", dt=dt, renorm_every=renorm_every,
                 duration=duration, transient=transient, mean_divergence=mean_trace,
                 sum_of_exponents=float(exponents.sum()), largest=float(exponents[0]),
                 largest_ci95=float(ci95[0]), n_exponents=k)
    index = np.arange(1, k + 1)
    return xr.Dataset(
        {"exponents": ("index", exponents, {"units": "1/s"}),
         "ci95": ("index", ci95, {"units": "1/s",
                                  "long_name": "95 % confidence half-width (batch means)"}),
         "running": (("t", "index"), running.T, {"units": "1/s",
                                                 "long_name": "running estimate"})},
        coords={"index": index, "t": ("t", times, {"units": "s"})}, attrs=attrs)
