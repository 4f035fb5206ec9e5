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

import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError, check_count
from analysis.integrate.checks import MAX_STEPS, check_seconds
from analysis.integrate.compiled import compiled_function
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.integrate.tangent import tangent_block
from analysis.model import BallCounts, Model, Structure, System, as_system
from analysis.provenance import run_attrs, state_at

BLOCKS = 10
"""Batches for the confidence interval of the exponents (batch means)."""
DURATION_FACTOR = 10
"""Default averaging time in spec durations (30 s for the bearing models: a 95 % interval of
λ1 below 5 1/s for the paper's case, N_b = 6…10; 6000 s for Duffing)."""
TANGENT_TRANSIENT_FRACTION = 0.1
"""Default tangent transient as a fraction of the spec's transient (0.1 s for the bearing
models, 30 s for Duffing): time for the tangent vectors to turn from the identity frame into
the Lyapunov (covariant-ordered) frame before the logs are averaged."""


def default_lengths(model: Model) -> tuple[float, float, float]:
    """(transient, duration, tangent transient) in s from the model's own time scale: the
    spec's transient, ``DURATION_FACTOR`` times its duration (the simulated time of a run:
    3 s for the bearing models, 600 s for Duffing) and ``TANGENT_TRANSIENT_FRACTION`` of its
    transient."""
    sim = model.simulation_defaults
    transient = float(sim.get("transient", 0.0))
    duration = DURATION_FACTOR * float(sim["duration"])
    return transient, duration, TANGENT_TRANSIENT_FRACTION * transient


def renorm_counts(dt: float, renorm_every: int, duration: float,
                  tangent_transient: float) -> tuple[int, int]:
    """(discarded, averaged) numbers of renormalisations, both multiples of ``BLOCKS`` (one
    call of the tangent block each): the tangent transient rounded up, the averaging time
    rounded to the nearest (at least ``BLOCKS``)."""
    interval = dt * renorm_every
    calls = math.ceil(tangent_transient / (interval * BLOCKS) - 1e-9)
    averaged = max(BLOCKS, round(duration / interval))
    return BLOCKS * max(0, calls), averaged - averaged % BLOCKS


def _check_lengths(dt: float, renorm_every: int, transient: float, duration: float,
                   tangent_transient: float) -> None:
    """The step, the renormalisation interval and the lengths fit together."""
    check_seconds("dt", dt)
    check_seconds("transient", transient, zero=True)
    interval = dt * renorm_every
    if interval * BLOCKS > duration:
        raise InputError(f"renorm_every: {BLOCKS} renormalisations of {renorm_every} steps "
                         f"({interval * BLOCKS:g} s) must fit in the averaging duration "
                         f"{duration:g} s; at most {max(1, int(duration / (dt * BLOCKS)))}")
    total = (transient + tangent_transient + duration) / dt
    if total > MAX_STEPS:
        raise InputError(f"duration: {total:.3g} RK4 steps in all (transient, tangent "
                         f"transient and averaging at dt = {dt:g} s); at most {MAX_STEPS:.0e}")


def _check_options(n: int, n_exponents, renorm_every, duration: float,
                   tangent_transient: float) -> int:
    n_exponents = check_count("n_exponents", n_exponents, 1, n)
    check_count("renorm_every", renorm_every, 1)
    check_seconds("duration", duration)
    check_seconds("tangent_transient", tangent_transient, zero=True)
    return n_exponents


def lyapunov(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    duration: float | None = None,
    transient: float | None = None,
    tangent_transient: float | None = None,
    dt: float | None = None,
    n_exponents: int | None = None,
    renorm_every: int = 100,
    initial_state: Sequence[float] | None = None,
    compiled: bool = True,
    progress: Callable[[int, int], None] | None = None,
    **parameters: float,
) -> xr.Dataset:
    """Lyapunov exponents (1/s), largest first, averaged over ``duration`` seconds.

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls``, ``initial_state`` (the model's state order and units) and ``**parameters``.
    Times (s) default to the model's own (``default_lengths``): ``transient`` and
    ``duration`` to the spec's, ``tangent_transient`` to a tenth of the spec's transient;
    ``dt`` to the spec's step.

    The state alone runs for ``transient`` − ``tangent_transient``; then the tangent vectors
    start from the identity frame and are renormalised for ``tangent_transient`` seconds
    with their logs discarded (the frame turns into the Lyapunov frame; averaging from the
    identity frame biases λ1 by O(1/duration)), then averaged for ``duration``. The
    averaging thus starts at max(``transient``, ``tangent_transient``); the tangent
    transient is rounded up to whole blocks of ten renormalisations. The states are those of
    ``simulate`` bit for bit (the same RK4 steps at times k·dt), wherever the tangent starts.
    ``n_exponents`` in [1, n] (default n, the model's state size: the whole spectrum).
    ``progress(done, total)``: called with the compiled blocks of ``BLOCKS`` renormalisations
    done (0 before the block is compiled, then after each).

    Returns a Dataset with ``exponents`` (dim ``index``), their 95 % confidence half-widths
    ``ci95`` (batch means over ten blocks), ``running`` (the running estimates over the
    averaging time, dims ``t`` × ``index``, to judge convergence), ``transient_running``
    (those of the discarded tangent transient, dims ``t_transient`` × ``index``) and the mean
    phase-space divergence ``mean_divergence`` (1/s) as an attribute, next to the run's
    provenance (``run_attrs``). ``compiled``: the tangent block runs as C
    (``analysis.integrate.compiled``), else in the CasADi VM.
    """
    system = as_system(system, n_balls, initial_state, **parameters)
    model, structure, values = system.model, system.structure, dict(system.parameters)
    n = model.n_state
    default_transient, default_duration, default_tangent = default_lengths(model)
    transient = float(default_transient if transient is None else transient)
    duration = float(default_duration if duration is None else duration)
    tangent_transient = float(default_tangent if tangent_transient is None
                              else tangent_transient)
    dt = float(model.simulation_defaults["dt"] if dt is None else dt)
    n_exponents = _check_options(n, n if n_exponents is None else n_exponents,
                                 renorm_every, duration, tangent_transient)
    _check_lengths(dt, renorm_every, transient, duration, tangent_transient)
    RunPlan.step(system, dt)  # the step's resolution and RK4 stability, transient or not
    discarded, averaged = renorm_counts(dt, renorm_every, duration, tangent_transient)
    start = max(0, round(transient / dt) - discarded * renorm_every)
    z0 = _state_after(system, start, dt)
    p = system.p
    state = np.concatenate([z0, [start], np.eye(n)[:, :n_exponents].T.ravel()])
    calls = (discarded + averaged) // BLOCKS
    if progress:
        progress(0, calls)
    block = compiled_function(tangent_block(model, structure, n_exponents, renorm_every,
                                            BLOCKS), (state, p, dt, 0.0), compiled)
    logs, traces, jac = [], [], system.functions.jac
    for call in range(calls):
        if progress and call:
            progress(call, calls)
        out_state, out_logs = block(state, p, dt, 0.0)
        state = np.asarray(out_state).ravel()
        if not np.all(np.isfinite(state)):
            raise SimulationError(f"the tangent dynamics blew up near t = "
                                  f"{state[n] * dt:.6g} s; try a smaller dt")
        logs.append(np.asarray(out_logs))
        if call >= discarded // BLOCKS:
            traces.append(np.trace(np.asarray(jac(state[n] * dt, state[:n], p))))
    if progress:
        progress(calls, calls)
    logs_all = in_order(np.concatenate(logs, axis=1), discarded)
    interval = dt * renorm_every
    res = _result(model, structure, values, logs_all[:, discarded:], interval,
                  (start + discarded * renorm_every) * dt, float(np.mean(traces)), dt,
                  renorm_every, duration, transient)
    res.attrs["tangent_transient"] = discarded * interval
    return _with_transient(res, logs_all[:, :discarded], interval, start * dt)


def _state_after(system: System, steps: int, dt: float) -> np.ndarray:
    """The state after ``steps`` RK4 steps of ``dt`` s from the system's state at t = 0
    (``simulate``: its checks and its blocks)."""
    if steps == 0:
        return np.asarray(system.state, dtype=float)
    settled = simulate(system, duration=(steps + 1) * dt, transient=steps * dt, dt=dt,
                       save_every=1)
    return state_at(settled, 0)


def in_order(logs: np.ndarray, discarded: int = 0) -> np.ndarray:
    """The rows of ``logs`` (k × m, one row per exponent) reordered so that their means
    over the averaged columns (from ``discarded`` on) run from largest to smallest.

    The QR frame orders the exponents only in the limit: over a finite time two close ones
    (two near-zero exponents of a torus, say) can come out swapped. A stable sort, so rows
    with equal means keep their QR order."""
    order = np.argsort(-logs[:, discarded:].sum(axis=1), kind="stable")
    return logs[order]


def running_mean(logs: np.ndarray, interval: float) -> np.ndarray:
    """Running estimates (1/s), k × m: the mean growth rate of the logs (k × m, one column
    per renormalisation ``interval`` s) from the first column to each."""
    return np.cumsum(logs, axis=1) / (interval * np.arange(1, logs.shape[1] + 1))


def batch_ci95(logs: np.ndarray, interval: float) -> np.ndarray:
    """95 % confidence half-widths (1/s) of the mean growth rates of the logs (k × m, m a
    multiple of ``BLOCKS``): batch means over ``BLOCKS`` batches, Student t with 9 d.o.f."""
    k, m = logs.shape
    batches = logs.reshape(k, BLOCKS, m // BLOCKS).sum(axis=2) / (interval * (m // BLOCKS))
    return 2.262 * batches.std(axis=1, ddof=1) / np.sqrt(BLOCKS)


def _with_transient(res: xr.Dataset, logs: np.ndarray, interval: float,
                    t_start: float) -> xr.Dataset:
    """``res`` with ``transient_running``: the running estimates over the discarded tangent
    transient (logs k × m from ``t_start`` s), dims ``t_transient`` × ``index``."""
    times = t_start + interval * np.arange(1, logs.shape[1] + 1)
    return res.assign(transient_running=(("t_transient", "index"),
                                         running_mean(logs, interval).T,
                                         {"units": "1/s", "long_name":
                                          "running estimate over the discarded tangent "
                                          "transient"})).assign_coords(
        t_transient=("t_transient", times, {"units": "s"}))


def _result(model: Model, structure: Structure, values: dict, logs: np.ndarray, interval: float,
            t0: float, mean_trace: float, dt: float, renorm_every: int, duration: float,
            transient: float) -> xr.Dataset:
    k, n = logs.shape
    times = t0 + interval * np.arange(1, n + 1)
    running = running_mean(logs, interval)
    exponents = running[:, -1]
    ci95 = batch_ci95(logs, interval)
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
