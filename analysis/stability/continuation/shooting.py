"""Tracing a branch: the guarded predictor-corrector loop, and the ways to start one.

The step adapts to the Newton iterations, and every step must pass the ``StepGuards``
(Newton contraction, distance from the predictor, angles between the tangents and the
secant, the direction of λ, a located fold where the tangent's λ component flips): a
refused step is retried at half the step, so that a corrector landing on a neighbouring
branch (the period-1 orbit beside a period-3 one, say) is refused, not accepted silently.
The guards are tests with thresholds in the scaled variables, not a proof of connectedness.
Special points between accepted points are located by ``detect``.

Starts: ``continue_orbits`` (a model and a parameter range: the first orbit by shooting),
``continue_from_orbit`` (an orbit of ``periodic.shoot``, e.g. after branch switching),
``continue_from_branch`` (a point of a stored branch, either direction) and
``continue_problem`` (a ``BranchProblem`` built by hand). Each takes its settings as a
``ContinuationOptions`` (``options=``) or as keyword arguments, which build one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.flow import Period, steps_per_period
from analysis.integrate.plan import RunPlan
from analysis.model import BallCounts, Model, System, as_system
from analysis.provenance import system_of_attrs
from analysis.stability.continuation.dataset import branch_dataset
from analysis.stability.continuation.detect import fold_between, lp_test, points_between
from analysis.stability.continuation.options import (
    DEFAULT_DS,
    ContinuationOptions,
    StepGuards,
    options_with,
)
from analysis.stability.continuation.problem import (
    BranchPoint,
    BranchProblem,
    Newton,
    branch_point,
    newton,
    orbit_scale,
    scaled,
)
from analysis.stability.periodic import PeriodicOrbit, as_period, shoot

Progress = Callable[[str], None] | None
"""Where progress lines go (None: nowhere)."""


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
    mdl = system.model
    if param not in mdl.parameter_names:
        raise InputError(f"param: '{param}' is not a parameter of '{mdl.name}'; "
                         f"choose one of {', '.join(mdl.parameter_names)}")
    if start == stop:
        raise InputError("stop: must differ from start")
    system = system.replace(**{param: start})
    mdl.parameters({param: stop})  # range check of the end value
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
    """The ``BranchProblem`` of the orbit ``first`` over [start, stop] (scales from the
    orbit), continued by ``continue_problem``."""
    if first.system is None:
        raise InputError("orbit: no System attached (continue from an orbit of shoot)")
    model = first.system.model
    per = as_period(model, first.period)
    # the step must stay below dt along the whole range (the period depends on λ)
    n_steps = _steps_for_range(first.system, per, param, (start, stop), dt)
    n = model.n_state
    prob = BranchProblem(model, first.structure, per, model.parameter_names.index(param),
                         dict(first.values), first.t0, n_steps, np.ones(n), abs(stop - start))
    prob.s_z = orbit_scale(prob, first.z0)
    return continue_problem(prob, first.z0, stop, options, progress=progress, label=label)


def continue_problem(prob: BranchProblem, z0: np.ndarray, stop: float,
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


def start_point(prob: BranchProblem, z0: np.ndarray, lam: float, stop: float, tol: float,
                tangent: np.ndarray | None = None) -> BranchPoint | None:
    """The first point of a branch: the orbit through ``z0`` at ``lam`` corrected by Newton
    (λ held fixed, or along ``tangent`` when given, which then is the point's tangent; else
    the tangent is oriented so that λ moves towards ``stop``). None when it does not
    converge."""
    direction = math.copysign(1.0, stop - lam)
    w = np.concatenate([z0 / prob.s_z, [lam / prob.s_lam]])
    n = prob.n
    out = newton(prob, w, np.eye(n + 1)[n] if tangent is None else tangent, tol)
    if out is None:
        return None
    first = branch_point(prob, out.w, out.jac, out.mono, tangent, direction, out.iterations)
    if tangent is not None:
        first.tangent = tangent
    return first


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


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors (deg)."""
    cos = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))


def _step_refusal(prob: BranchProblem, a: BranchPoint, b: BranchPoint, newton: Newton,
                  ds: float, guards: StepGuards) -> str:
    """Why the step from ``a`` to ``b`` (corrected by ``newton`` from a predictor ds away)
    is refused by ``guards``; '' when it passes (the fold test is ``detect.fold_between``)."""
    if not guards.active:
        return ""
    if newton.contraction > guards.max_contraction:
        return (f"Newton contraction {newton.contraction:.2f} > "
                f"{guards.max_contraction:g}")
    if newton.distance > guards.max_correction * ds:
        return (f"the corrector moved {newton.distance / ds:.2f} ds > "
                f"{guards.max_correction:g} ds from the predictor")
    if b.angle > guards.max_angle:
        return f"the tangent turned {b.angle:.1f}° > {guards.max_angle:g}°"
    secant = scaled(prob, b) - scaled(prob, a)
    worst = max(_angle(secant, a.tangent), _angle(secant, b.tangent))
    if worst > guards.max_angle:
        return f"the secant is {worst:.1f}° > {guards.max_angle:g}° off a tangent"
    same_side = np.sign(a.tangent[-1]) == np.sign(b.tangent[-1])
    if same_side and secant[-1] * a.tangent[-1] < 0 and abs(secant[-1]) > 1e-9 * ds:
        return "the parameter moved against both tangents"
    return ""


def _step(prob: BranchProblem, prev: BranchPoint, ds: float, tol: float, direction: float,
          guards: StepGuards) -> tuple[list[BranchPoint], BranchPoint] | str:
    """One predictor-corrector step of ``ds`` from ``prev``: (special points located between,
    the new point), or the reason it is refused (no convergence, or a guard)."""
    corrected = newton(prob, scaled(prob, prev) + ds * prev.tangent, prev.tangent, tol)
    if corrected is None:
        return "no convergence"
    point = branch_point(prob, corrected.w, corrected.jac, corrected.mono, prev.tangent,
                         direction, corrected.iterations)
    point.angle = _angle(prev.tangent, point.tangent)
    point.contraction = corrected.contraction
    reason = _step_refusal(prob, prev, point, corrected, ds, guards)
    if reason:
        return reason
    lp = None
    if lp_test(prev) != 0 and np.sign(lp_test(prev)) != np.sign(lp_test(point)):
        lp = fold_between(prob, prev, point, tol, direction)
        if lp is None and guards.active:
            return "the parameter component of the tangent changed sign but no fold was found"
    return points_between(prob, prev, point, tol, direction, lp=lp), point


def trace_branch(prob: BranchProblem, first: BranchPoint, stop: float,
                 options: ContinuationOptions, *, progress: Progress = None, label: str = "",
                 attrs: dict | None = None) -> xr.Dataset:
    """Continue from ``first`` (its tangent oriented the way to go, its ``ds`` the first
    step) until λ leaves the range between ``first.lam`` and ``stop``, ``max_points``
    points, or a step refused even at ``ds_min`` (``options``); ``attrs``: more attributes
    of the branch Dataset."""
    param = prob.param_name
    ds_min, ds_max, max_points = options.ds_min, options.ds_max, options.max_points
    branch, ds = [first], first.ds
    lo, hi = min(first.lam, stop), max(first.lam, stop)
    status, refused = "reached the end of the range", 0
    while len(branch) < max_points:
        prev = branch[-1]
        result = _step(prob, prev, ds, options.tol, _direction(prev), options.guards)
        if isinstance(result, str):
            refused += result != "no convergence"
            ds /= 2
            if ds < ds_min:
                status = _refused_status(result, ds_min, param, prev.lam)
                break
            continue
        found, point = result
        branch.extend(found)
        branch.append(point)
        ds = min(ds * 1.5, ds_max) if point.newton_iterations <= 3 else max(ds / 1.5, ds_min)
        point.ds = ds
        if progress and len(branch) % 10 == 0:
            progress(f"{len(branch)} points, {param} = {point.lam:.6g}, "
                     f"{'stable' if point.stable else 'unstable'}")
        if not lo <= point.lam <= hi:
            break
    else:
        status = f"stopped after max_points = {max_points}"
    return branch_dataset(prob.model, prob, branch, param, status, label,
                          refused_steps=refused, **(attrs or {}))


def _direction(point: BranchPoint) -> float:
    """The sign of λ along the tangent (the start-up orientation of ``problem.tangent``)."""
    return math.copysign(1.0, point.tangent[-1])


def _refused_status(reason: str, ds_min: float, param: str, lam: float) -> str:
    """The status of a run stopped because no step down to ``ds_min`` was accepted."""
    if reason == "no convergence":
        return f"step fell below ds_min = {ds_min:g} (no convergence)"
    return (f"refused every step down to ds_min = {ds_min:g} from {param} = {lam:.8g} "
            f"({reason}): possibly a jump to another branch")


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
    if not math.isfinite(stop) or stop == lam:
        raise InputError(f"stop: must be finite and differ from {param} = {lam:g} at point {k}")
    prob = _problem_of_branch(branch, lam, stop, dt)
    prob.model.parameters({param: stop})  # range check of the end value
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
                       dt: float | None) -> BranchProblem:
    """The ``BranchProblem`` of a stored branch at ``param = lam``, with enough steps per
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
    prob = BranchProblem(model, system.structure, per, model.parameter_names.index(param),
                         values, float(attrs["t0"]), n_steps, np.ones(model.n_state), s_lam)
    prob.s_z = np.asarray(branch.state_scale.values, dtype=float) \
        if "state_scale" in branch else None
    return prob
