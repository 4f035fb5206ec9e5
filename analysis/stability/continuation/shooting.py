"""The shooting family: periodic orbits continued by the engine, and the ways to start one.

``ShootingProblem``: unknowns w = (z0 / s_z, λ / s_λ), n + 1 of them for a model of n states
(the orbit's state at the section, scaled per component by ``periodic.state_scale``, and
the continuation parameter scaled by the requested range); equations
G(w) = (Φ_T(z0; λ) − z0) / s_z = 0 (shooting, ``analysis.integrate.flow``), the monodromy
matrix and ∂Φ/∂λ by AD (the period's own dependence on λ, e.g. on the speed, included).
Its points carry the Floquet multipliers; LP, PD, BP and NS are located by ``detect``.

Starts: ``continue_orbits`` (a model and a parameter range: the first orbit by shooting),
``continue_from_orbit`` (an orbit of ``periodic.shoot``, e.g. after branch switching),
``continue_from_branch`` (a point of a stored branch, either direction) and
``continue_problem`` (a ``ShootingProblem`` built by hand). Each takes its settings as a
``ContinuationOptions`` (``options=``) or as keyword arguments, which build one, and is
traced by the one engine (``trace.trace``) into a branch Dataset (``trace_branch``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.flow import (
    Period,
    evaluate,
    flow_map,
    orbit_states,
    period_seconds,
    steps_per_period,
)
from analysis.integrate.plan import RunPlan
from analysis.model import BallCounts, Model, Structure, System, as_system
from analysis.provenance import system_of_attrs
from analysis.stability.continuation.dataset import branch_dataset, with_normal_forms
from analysis.stability.continuation.options import (
    DEFAULT_DS,
    ContinuationOptions,
    StepGuards,
    options_with,
)
from analysis.stability.continuation.problem import (
    BranchPoint,
    ContinuedParameter,
    ContinuedRange,
)
from analysis.stability.continuation.step import start_at
from analysis.stability.continuation.trace import Progress, trace
from analysis.stability.periodic import PeriodicOrbit, as_period, shoot, state_scale


@dataclass
class ShootingProblem(ContinuedParameter):
    """Periodic orbits of ``model`` (with ``structure``) of period ``period`` as the runtime
    parameter number ``param_index`` varies, the others at ``values`` (their units): the
    section at ``t0`` (s), ``n_steps`` RK4 steps per period, the unknowns scaled by ``s_z``
    (per state, its unit) and ``s_lam`` (the parameter's unit). The flow map and the orbit
    sampler are built on construction. The shooting family of the engine (``trace.trace``):
    its points are ``BranchPoint`` with the Floquet multipliers."""

    model: Model
    structure: Structure
    period: Period
    param_index: int
    values: dict[str, float]
    t0: float
    n_steps: int
    s_z: np.ndarray
    s_lam: float
    flow: object = field(default=None)

    def __post_init__(self):
        self.flow = flow_map(self.model, self.structure, self.period, self.n_steps)
        self.orbit = orbit_states(self.model, self.structure, self.period, self.n_steps)

    @property
    def n(self) -> int:
        return self.model.n_state

    def residual(self, w: np.ndarray):
        """G(w) (n), its Jacobian (n × (n + 1)) and the monodromy matrix."""
        n = self.n
        z, lam = w[:n] * self.s_z, w[n] * self.s_lam
        z_end, mono, dp = evaluate(self.flow, z, self.t0, self.p(lam))
        g = (z_end - z) / self.s_z
        jz = (mono - np.eye(n)) * self.s_z[None, :] / self.s_z[:, None]
        jl = dp[:, self.param_index] * self.s_lam / self.s_z
        return g, np.column_stack([jz, jl]), mono

    def amplitude(self, w: np.ndarray) -> float:
        """Half the peak-to-peak of the first state variable (x, x_rotor …; m) over one
        period."""
        n = self.n
        states = np.asarray(self.orbit(w[:n] * self.s_z, self.t0, self.p(w[n] * self.s_lam)))
        return float(np.ptp(states[0])) / 2


def orbit_scale(prob: ShootingProblem, z0: np.ndarray) -> np.ndarray:
    """Per-component scales (``periodic.state_scale``) from the largest |z_i| over one period
    of the orbit through z0 (velocities at least size·2π/T)."""
    states = np.asarray(prob.orbit(z0, prob.t0, prob.model.parameter_vector(prob.values)))
    return state_scale(np.abs(states).max(axis=1),
                       period_seconds(prob.model, prob.structure, prob.period, prob.values),
                       prob.model.module.STATE_UNITS)



def continue_orbits(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    param: str,
    start: float,
    stop: float,
    period: str | Period | None = None,
    guess: np.ndarray | None = None,
    t0: float | None = None,
    ds: float | None = None,
    ds_min: float | None = None,
    ds_max: float | None = None,
    max_points: int | None = None,
    dt: float | None = None,
    tol: float | None = None,
    settle: float | None = None,
    progress: Progress = None,
    guards: StepGuards | None = None,
    options: ContinuationOptions | None = None,
    **parameters: float,
) -> xr.Dataset:
    """Continue a branch of periodic orbits in ``param`` from ``start`` towards ``stop``
    (the parameter's unit).

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls`` and ``**parameters``. ``period``: as in ``periodic.shoot`` (text for
    ``Period.parse``; None: ``periodic.default_period``). The first orbit is found by
    ``periodic.shoot`` at ``param = start`` (from ``guess``, the state at ``t0`` s, or a
    simulation of about ``settle`` s; None: the model's own ``periodic.default_settle``).
    ``options``: the steps, point budget, tolerance and guards (``ContinuationOptions``;
    default ``ContinuationOptions()``: ds 0.01, ds_min 1e-6, ds_max 0.05, 200 points, tol
    1e-9, ``StepGuards()``); each of ``ds``, ``ds_min``, ``ds_max``, ``max_points``, ``tol``,
    ``guards`` that is given replaces its field. The steps are arclength steps in the
    scaled variables (λ scaled by |stop − start|). ``dt``: the largest RK4 step (s; default
    the spec's). Returns the branch as a Dataset (see ``branch_dataset``).
    """
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol, guards=guards)
    system = as_system(system, n_balls, **parameters)
    ContinuedRange.check(system.model, param, start, stop)
    system = system.replace(**{param: start})
    first = shoot(system, None, period, guess, t0, dt=dt, settle=settle)
    if not first.converged:
        raise InputError(f"start: no periodic orbit found at {param} = {start:g} "
                         f"({first.message})")
    return _continue_from(first, param, start, stop, dt, options, progress)


def continue_from_orbit(orbit: PeriodicOrbit, *, param: str, stop: float,
                        ds: float | None = None, ds_min: float | None = None,
                        ds_max: float | None = None, max_points: int | None = None,
                        dt: float | None = None, tol: float | None = None,
                        progress: Progress = None, label: str = "",
                        guards: StepGuards | None = None,
                        options: ContinuationOptions | None = None) -> xr.Dataset:
    """Continue a branch from an already solved orbit of ``periodic.shoot`` (e.g. after
    branch switching) in ``param`` towards ``stop``; ``dt`` (s) defaults to the spec's;
    ``label``: the branch's name (default ``period …``); ``options`` and the keywords that
    replace its fields as in ``continue_orbits``."""
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol, guards=guards)
    start = orbit.values[param]
    return _continue_from(orbit, param, start, stop, dt, options, progress, label)


def _continue_from(first: PeriodicOrbit, param: str, start: float, stop: float,
                   dt: float | None, options: ContinuationOptions, progress: Progress,
                   label: str = "") -> xr.Dataset:
    """The ``ShootingProblem`` of the orbit ``first`` over [start, stop] (scales from the
    orbit), continued by ``continue_problem``."""
    if first.system is None:
        raise InputError("orbit: no System attached (continue from an orbit of shoot)")
    model = first.system.model
    per = as_period(model, first.period)
    # the step must stay below dt along the whole range (the period depends on λ)
    n_steps = _steps_for_range(first.system, per, param, (start, stop), dt)
    n = model.n_state
    prob = ShootingProblem(model, first.structure, per, model.parameter_names.index(param),
                         dict(first.values), first.t0, n_steps, np.ones(n), abs(stop - start))
    prob.s_z = orbit_scale(prob, first.z0)
    return continue_problem(prob, first.z0, stop, options, progress=progress, label=label)


def continue_problem(prob: ShootingProblem, z0: np.ndarray, stop: float,
                     options: ContinuationOptions | None = None, *,
                     progress: Progress = None, label: str = "") -> xr.Dataset:
    """Continue the branch of ``prob`` from the orbit through ``z0`` (the state at the
    section, the states' units) at the problem's own parameter value
    (``prob.values[prob.param_name]``) towards ``stop`` (the parameter's unit), with
    ``options`` (default ``ContinuationOptions()``). The orbit is first re-solved at that
    value with the problem's step count; ``prob.s_z`` must be set (e.g. ``orbit_scale``).
    ``label``: the branch's name (default ``period …``)."""
    options = options if options is not None else ContinuationOptions()
    param, lam = prob.param_name, prob.values[prob.param_name]
    first = start_point(prob, z0, lam, stop, options.tol)
    if first is None:
        raise InputError(f"start: the orbit at {param} = {lam:g} does not converge with "
                         f"{prob.n_steps} steps per period")
    first.ds = options.first_ds
    return trace_branch(prob, first, stop, options, progress=progress, label=label)


def start_point(prob: ShootingProblem, z0: np.ndarray, lam: float, stop: float, tol: float,
                tangent: np.ndarray | None = None) -> BranchPoint | None:
    """The first point of a branch: the orbit through ``z0`` at ``lam`` corrected by Newton
    (λ held fixed, or along ``tangent`` when given, which then is the point's tangent; else
    the tangent is oriented so that λ moves towards ``stop``). None when it does not
    converge."""
    w = np.concatenate([z0 / prob.s_z, [lam / prob.s_lam]])
    return start_at(prob, w, math.copysign(1.0, stop - lam), tol, tangent)


def _steps_for_range(system: System, per: Period, param: str, ends: tuple[float, float],
                     dt: float | None) -> int:
    """RK4 steps per period so that the step is at most ``dt`` (s; None: the spec's) at
    both ends of the range of ``param``, the step checked at each (``RunPlan.step``)."""
    steps = []
    for end in ends:
        at_end = system.replace(**{param: end})
        plan = RunPlan.step(at_end, dt)
        steps.append(steps_per_period(system.model, system.structure, per,
                                      dict(at_end.parameters), plan.dt))
    return max(steps)


def trace_branch(prob: ShootingProblem, first: BranchPoint, stop: float,
                 options: ContinuationOptions, *, progress: Progress = None, label: str = "",
                 attrs: dict | None = None) -> xr.Dataset:
    """The branch of ``prob`` traced by the engine from ``first`` (its tangent oriented the
    way to go, its ``ds`` the first step) towards ``stop`` (``options``), as a Dataset
    (``branch_dataset``; ``attrs``: more attributes) with the normal forms of its LP, PD
    and NS points (``with_normal_forms``)."""
    out = trace(prob, first, stop, options, progress=progress)
    ds = branch_dataset(prob.model, prob, out.points, prob.param_name, out.status, label,
                        refused_steps=out.refused, **(attrs or {}))
    return with_normal_forms(ds, prob, out.points)


def continue_from_branch(branch: xr.Dataset | str | Path, point: int = -1, *, stop: float,
                         ds: float | None = None, ds_min: float | None = None,
                         ds_max: float | None = None, max_points: int | None = None,
                         dt: float | None = None, tol: float | None = None,
                         progress: Progress = None, label: str = "",
                         guards: StepGuards | None = None,
                         options: ContinuationOptions | None = None) -> xr.Dataset:
    """Continue again from point ``point`` (negative: from the end) of a stored branch (a
    Dataset or netCDF file of ``continue_orbits``) towards ``stop`` (the parameter's unit),
    in either direction: the branch's tangent there is oriented so that the parameter
    moves towards ``stop``.

    The branch's own model (spec file, else name), balls, parameters, period, section time
    t0 and steps per period are used, and, when stored, its scales, its tangent and its
    planned step ``ds`` at the point (a ``ds`` of the options overrides it; neither: 0.01):
    continued over the same range, a restart reproduces the original points after
    ``point``. ``dt`` (s): more steps per period when the range needs them (default the
    spec's step). ``options`` and the other arguments as in ``continue_orbits``.
    """
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol, guards=guards)
    source = ""
    if not isinstance(branch, xr.Dataset):
        from analysis.io import open_result

        source, branch = str(branch), open_result(branch)
    attrs = branch.attrs
    param = str(attrs.get("param", ""))
    if not param or "z0" not in branch:
        raise InputError(f"branch: {source or 'the dataset'} is not a continuation branch "
                         "(no param attribute or z0)")
    size = branch.sizes["point"]
    if not -size <= point < size:
        raise InputError(f"point: must be in [{-size}, {size - 1}] (the branch has {size} "
                         f"points), got {point}")
    k = point % size
    lam = float(branch[param][k])
    ContinuedRange.check(system_of_attrs({**attrs, param: lam}).model, param, lam, stop)
    prob = _problem_of_branch(branch, lam, stop, dt)
    z0 = branch.z0.values[k]
    if prob.s_z is None:
        prob.s_z = orbit_scale(prob, z0)
    direction = math.copysign(1.0, stop - lam)
    tau = branch.tangent.values[k] if "tangent" in branch else None
    if tau is not None and tau[-1] * direction < 0:
        tau = -tau
    first = start_point(prob, z0, lam, stop, options.tol, tau)
    if first is None:
        raise InputError(f"point: the stored orbit at {param} = {lam:g} does not converge "
                         f"with {prob.n_steps} steps per period")
    stored_ds = float(branch.ds.values[k]) if "ds" in branch else 0.0
    first.ds = options.ds if options.ds is not None else \
        (stored_ds if stored_ds > 0 else DEFAULT_DS)
    first.special = str(branch.special.values[k])
    return trace_branch(prob, first, stop, options, progress=progress,
                 label=label or str(attrs.get("branch", "")),
                 attrs={"restarted_from": f"{source or 'branch'} point {k}"})


def _problem_of_branch(branch: xr.Dataset, lam: float, stop: float,
                       dt: float | None) -> ShootingProblem:
    """The ``ShootingProblem`` of a stored branch at ``param = lam``, with enough steps per
    period for the range to ``stop`` (at least the branch's own) and its scales (``s_z``
    None when the file has none: an older file)."""
    attrs = branch.attrs
    param = str(attrs["param"])
    system = system_of_attrs({**attrs, param: lam})
    model = system.model
    per = as_period(model, str(attrs["period"]))
    values = dict(system.parameters)
    n_steps = max(int(attrs["steps_per_period"]),
                  _steps_for_range(system, per, param, (lam, stop), dt))
    s_lam = float(attrs.get("param_scale", abs(stop - lam)))
    prob = ShootingProblem(model, system.structure, per, model.parameter_names.index(param),
                         values, float(attrs["t0"]), n_steps, np.ones(model.n_state), s_lam)
    prob.s_z = np.asarray(branch.state_scale.values, dtype=float) \
        if "state_scale" in branch else None
    return prob
