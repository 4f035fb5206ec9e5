"""Pseudo-arclength continuation of periodic orbits, with bifurcation detection.

Unknowns w = (z0 / s_z, λ / s_λ), n + 1 of them for a model of n states: the orbit's state at
the section (scaled per component by ``periodic.state_scale``) and the continuation
parameter (scaled by the requested range).
Equations: G(w) = (Φ_T(z0; λ) − z0) / s_z = 0 (shooting, ``analysis.integrate.flow``) plus the
arclength condition τ·(w − w_pred) = 0 of Keller's method; the bordered Newton matrix is built
from the monodromy matrix and ∂Φ/∂λ, both by AD (the period's own dependence on λ, e.g. on the
speed, included). The step adapts to the Newton iterations, and every step must pass the
``StepGuards`` (Newton contraction, distance from the predictor, angles between the tangents
and the secant, the direction of λ, a located fold where the tangent's λ component flips):
a refused step is retried at half the step, so that a corrector landing on a neighbouring
branch (the period-1 orbit beside a period-3 one, say) is refused, not accepted silently.
The guards are tests with thresholds in the scaled variables, not a proof of connectedness.

Special points, located by bisection on the arclength:
  * LP (fold): the parameter component of the tangent changes sign (a multiplier passes +1);
  * PD (period doubling): det(M + I) changes sign (a real multiplier passes −1);
  * BP (branch point): det(M − I) changes sign without a fold (a symmetry-breaking
    pitchfork, say);
  * NS (Neimark–Sacker): the number of complex multipliers outside the unit circle changes.
``switch_branch`` starts the period-2 branch at a PD point (``switch_period_doubling``) or the
asymmetric branch at a BP point (``switch_branch_point``); ``continue_from_branch`` restarts
from a point of a stored branch, in either direction.

Non-smoothness: where an orbit starts or stops touching a ball (grazing), the branch has a
kink that no smooth test function sees; continuation passes it, the multipliers jump, and a
stability change there is reported as 'grazing?' (a change of the unstable count without
LP/PD/NS test function sign change).
"""

from __future__ import annotations

import math
from collections.abc import Callable
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
from analysis.model import BallCounts, Model, Structure, System, as_system
from analysis.provenance import run_attrs, system_of_attrs
from analysis.stability.periodic import (
    PeriodicOrbit,
    as_period,
    shoot,
    state_scale,
)


@dataclass
class BranchPoint:
    """One converged orbit on the branch (λ in the parameter's own unit)."""

    lam: float
    z0: np.ndarray
    multipliers: np.ndarray
    monodromy: np.ndarray
    tangent: np.ndarray
    amplitude: float
    special: str = ""
    newton_iterations: int = 0
    ds: float = 0.0
    """Scaled arclength step planned from this point (what a restart from it uses)."""
    angle: float = 0.0
    """Angle between this point's tangent and the previous point's (deg)."""
    contraction: float = 0.0
    """Largest Newton contraction ratio |Δw_{k+1}| / |Δw_k| of the corrector (0: one
    iteration)."""

    @property
    def n_unstable(self) -> int:
        return int(np.sum(np.abs(self.multipliers) > 1 + 1e-9))

    @property
    def stable(self) -> bool:
        return self.n_unstable == 0


@dataclass
class _Problem:
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
    def param_name(self) -> str:
        return self.model.parameter_names[self.param_index]

    def p(self, lam: float) -> np.ndarray:
        p = self.model.parameter_vector(self.values)
        p[self.param_index] = lam
        return p

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


def orbit_scale(prob: _Problem, z0: np.ndarray) -> np.ndarray:
    """Per-component scales (``periodic.state_scale``) from the largest |z_i| over one period
    of the orbit through z0 (velocities at least size·2π/T)."""
    states = np.asarray(prob.orbit(z0, prob.t0, prob.p(prob.values[prob.param_name])))
    return state_scale(np.abs(states).max(axis=1),
                       period_seconds(prob.model, prob.structure, prob.period, prob.values),
                       prob.model.module.STATE_UNITS)


def _tangent(jac: np.ndarray, previous: np.ndarray | None, direction: float) -> np.ndarray:
    """Unit null vector of the n × (n + 1) Jacobian, oriented along ``previous`` (or by the
    sign of ``direction`` in λ at the start)."""
    tau = np.linalg.svd(jac)[2][-1]
    ref = np.dot(tau, previous) if previous is not None else tau[-1] * direction
    return -tau if ref < 0 else tau


@dataclass
class _Newton:
    """A converged corrector: the point, its Jacobian and monodromy matrix, the iterations,
    the largest contraction ratio |Δw_{k+1}| / |Δw_k| and the distance from the predictor
    (scaled variables)."""

    w: np.ndarray
    jac: np.ndarray
    mono: np.ndarray
    iterations: int
    contraction: float
    distance: float


def _newton(prob: _Problem, w_pred: np.ndarray, tau: np.ndarray, tol: float,
            max_iter: int = 8) -> _Newton | None:
    """Newton on [G(w); τ·(w − w_pred)] = 0 from the predictor ``w_pred``; None when it does
    not converge in ``max_iter`` iterations (or meets a non-finite value or a singular
    matrix). Steps below 100·tol (rounding level) do not count in the contraction ratio."""
    w = w_pred.copy()
    previous, contraction = None, 0.0
    for it in range(1, max_iter + 1):
        g, jac, mono = prob.residual(w)
        h = np.concatenate([g, [np.dot(tau, w - w_pred)]])
        if not np.all(np.isfinite(h)):
            return None
        try:
            dw = np.linalg.solve(np.vstack([jac, tau]), -h)
        except np.linalg.LinAlgError:
            return None
        w = w + dw
        size = float(np.linalg.norm(dw))
        if previous is not None and previous > 100 * tol:
            contraction = max(contraction, size / previous)
        previous = size
        if size < tol and np.linalg.norm(g) < 1e3 * tol:
            g, jac, mono = prob.residual(w)
            return _Newton(w, jac, mono, it, contraction, float(np.linalg.norm(w - w_pred)))
    return None


def _correct(prob: _Problem, w_pred: np.ndarray, tau: np.ndarray, tol: float,
             max_iter: int = 8):
    """Newton on [G(w); τ·(w − w_pred)] = 0. Returns (w, jac, mono, iterations) or None."""
    out = _newton(prob, w_pred, tau, tol, max_iter)
    return None if out is None else (out.w, out.jac, out.mono, out.iterations)


def _point(prob: _Problem, w: np.ndarray, jac: np.ndarray, mono: np.ndarray,
           previous: np.ndarray | None, direction: float, iterations: int) -> BranchPoint:
    return BranchPoint(lam=w[-1] * prob.s_lam, z0=w[:-1] * prob.s_z,
                       multipliers=np.linalg.eigvals(mono), monodromy=mono,
                       tangent=_tangent(jac, previous, direction),
                       amplitude=prob.amplitude(w), newton_iterations=iterations)


def _w(prob: _Problem, point: BranchPoint) -> np.ndarray:
    return np.concatenate([point.z0 / prob.s_z, [point.lam / prob.s_lam]])


def _lp_test(point: BranchPoint) -> float:
    """Parameter component of the tangent: changes sign at a fold (LP)."""
    return float(point.tangent[-1])


def _bp_test(point: BranchPoint) -> float:
    """det(M − I) = Π(μ − 1): changes sign when a real multiplier passes +1. Without a fold
    (LP) that is a branch point (BP), e.g. the symmetry-breaking pitchfork of the Duffing
    oscillator."""
    return float(np.real(np.prod(point.multipliers - 1)))


def _pd_test(point: BranchPoint) -> float:
    """det(M + I) = Π(μ + 1): changes sign when a real multiplier passes −1 (PD)."""
    return float(np.real(np.prod(point.multipliers + 1)))


def _locate(prob: _Problem, a: BranchPoint, b: BranchPoint, kind: str,
            test: Callable[[BranchPoint], float], tol: float, direction: float,
            iterations: int = 12, strict: bool = False) -> BranchPoint | None:
    """Bisection on the chord from a to b (corrected onto the branch) for the sign change of
    ``test``; returns the located point labelled ``kind`` (when no corrector converges: b,
    or None if ``strict``)."""
    wa, wb = _w(prob, a), _w(prob, b)
    chord = (wb - wa) / np.linalg.norm(wb - wa)
    sign_a = np.sign(test(a))
    lo, hi, best = 0.0, 1.0, None
    for _ in range(iterations):
        mid = (lo + hi) / 2
        out = _correct(prob, wa + mid * (wb - wa), chord, tol)
        if out is None:
            break
        w, jac, mono, it = out
        best = _point(prob, w, jac, mono, a.tangent, direction, it)
        if np.sign(test(best)) == sign_a:
            lo = mid
        else:
            hi = mid
    if best is None:  # no corrector converged inside the interval: b is the best estimate
        if strict:
            return None
        best = b
    best.special = kind
    return best


@dataclass(frozen=True)
class StepGuards:
    """Tests every continuation step must pass; a refused step is retried with half the
    arclength step ds, and the run stops (status ``refused …``) when even ``ds_min`` is
    refused. They keep the corrector on the branch it started from: a step that lands on
    another branch (a period-1 orbit next to a period-3 one, say) fails at least one.

    * ``max_contraction``: the largest Newton contraction ratio |Δw_{k+1}| / |Δw_k| of the
      corrector (quadratic convergence from a good predictor gives ≪ 0.1);
    * ``max_correction``: the largest distance of the corrected point from the predictor,
      in units of ds;
    * ``max_angle``: the largest angle (deg) between the tangents at the two ends of the
      step, and between the secant (the chord from one end to the other) and either tangent;
    * the parameter must move the way both tangents point unless their parameter components
      differ in sign, and when they do, a fold (LP) must be located between the ends (a
      corrected point where λ is extreme), else the step is refused.

    ``active = False`` turns every test off (the behaviour before the guards).
    """

    max_contraction: float = 0.5
    max_correction: float = 0.5
    max_angle: float = 30.0
    active: bool = True


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors (deg)."""
    cos = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))


def _step_refusal(prob: _Problem, a: BranchPoint, b: BranchPoint, newton: _Newton,
                  ds: float, guards: StepGuards) -> str:
    """Why the step from ``a`` to ``b`` (corrected by ``newton`` from a predictor ds away)
    is refused by ``guards``; '' when it passes (the fold test is ``_fold_between``)."""
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
    secant = _w(prob, b) - _w(prob, a)
    worst = max(_angle(secant, a.tangent), _angle(secant, b.tangent))
    if worst > guards.max_angle:
        return f"the secant is {worst:.1f}° > {guards.max_angle:g}° off a tangent"
    same_side = np.sign(a.tangent[-1]) == np.sign(b.tangent[-1])
    if same_side and secant[-1] * a.tangent[-1] < 0 and abs(secant[-1]) > 1e-9 * ds:
        return "the parameter moved against both tangents"
    return ""


def _fold_between(prob: _Problem, a: BranchPoint, b: BranchPoint, tol: float,
                  direction: float) -> BranchPoint | None:
    """The fold (LP) between ``a`` and ``b``, whose tangents' parameter components differ
    in sign: located by bisection and checked to be a parameter extremum (beyond both ends,
    up to 1e-3 of the step in λ). None when no corrector converges or the located point is
    not an extremum: then the sign change is no fold of one branch, and the step is
    refused."""
    lp = _locate(prob, a, b, "LP", _lp_test, tol, direction, strict=True)
    if lp is None:
        return None
    slack = 1e-3 * abs(b.lam - a.lam) + 1e-12 * prob.s_lam
    beyond_a = (lp.lam - a.lam) * np.sign(a.tangent[-1]) >= -slack
    beyond_b = (lp.lam - b.lam) * np.sign(b.tangent[-1]) <= slack
    return lp if beyond_a and beyond_b else None


def _complex_outside(point: BranchPoint) -> int:
    """Complex multipliers outside the unit circle (beyond 1 + 1e-9, as ``n_unstable``:
    a conservative system's multipliers on the circle are not a Neimark–Sacker point)."""
    mu = point.multipliers
    return int(np.sum((np.abs(mu.imag) > 1e-9) & (np.abs(mu) > 1 + 1e-9)))


MAX_BRANCH_POINTS = 100_000
"""Most points one branch or curve may have."""


def check_steps(ds: float | None, ds_min: float, ds_max: float, max_points: int,
                tol: float) -> None:
    """Raise ``InputError`` unless 0 < ds_min <= ds_max and ds > 0 (scaled arclength
    steps, each finite), 2 <= max_points <= ``MAX_BRANCH_POINTS`` and 0 < tol < 1;
    checked before any orbit is computed."""
    for name, value in (("ds_min", ds_min), ("ds_max", ds_max), ("tol", tol)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"{name}: must be a finite number > 0, got {value!r}")
    if ds_min > ds_max:
        raise InputError(f"ds_min: must be <= ds_max = {ds_max:g}, got {ds_min:g}")
    if ds is not None and not (isinstance(ds, (int, float)) and math.isfinite(ds) and ds > 0):
        raise InputError(f"ds: must be a finite number > 0 (kept within [ds_min, ds_max]), "
                         f"got {ds!r}")
    if not tol < 1:
        raise InputError(f"tol: must be in (0, 1), got {tol!r}")
    if isinstance(max_points, bool) or not isinstance(max_points, int) or \
            not 2 <= max_points <= MAX_BRANCH_POINTS:
        raise InputError(f"max_points: must be a whole number in [2, {MAX_BRANCH_POINTS}], "
                         f"got {max_points!r}")


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
    ds: float = 0.01,
    ds_min: float = 1e-6,
    ds_max: float = 0.05,
    max_points: int = 200,
    dt: float | None = None,
    tol: float = 1e-9,
    settle: float | None = None,
    progress: Callable[[str], None] | None = None,
    guards: StepGuards | None = None,
    **parameters: float,
) -> xr.Dataset:
    """Continue a branch of periodic orbits in ``param`` from ``start`` towards ``stop``
    (the parameter's unit).

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls`` and ``**parameters``. ``period``: as in ``periodic.shoot`` (text for
    ``Period.parse``; None: ``periodic.default_period``). The first orbit is found by
    ``periodic.shoot`` at ``param = start`` (from ``guess``, the state at ``t0`` s, or a
    simulation of about ``settle`` s; None: the model's own ``periodic.default_settle``).
    ``ds``, ``ds_min``, ``ds_max`` are arclength steps in the scaled variables (λ scaled by
    |stop − start|). ``dt``: the largest RK4 step (s; default the spec's). ``guards``: the
    tests every step must pass (default ``StepGuards()``). Returns the branch as a Dataset
    (see ``branch_dataset``).
    """
    check_steps(ds, ds_min, ds_max, max_points, tol)
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
    return _continue_from(first, param, start, stop, ds, ds_min, ds_max, max_points,
                          dt, tol, progress, guards=guards)


def _continue_from(first: PeriodicOrbit, param: str, start: float, stop: float,
                   ds: float, ds_min: float, ds_max: float, max_points: int,
                   dt: float | None, tol: float, progress, label: str = "",
                   guards: StepGuards | None = None) -> xr.Dataset:
    if first.system is None:
        raise InputError("orbit: no System attached (continue from an orbit of shoot)")
    model = first.system.model
    per = as_period(model, first.period)
    # the step must stay below dt along the whole range (the period depends on λ)
    n_steps = _steps_for_range(model, first.structure, per, first.values, param,
                               (start, stop), dt)
    n = model.n_state
    prob = _Problem(model, first.structure, per, model.parameter_names.index(param),
                    dict(first.values), first.t0, n_steps, np.ones(n), abs(stop - start))
    prob.s_z = orbit_scale(prob, first.z0)
    direction = math.copysign(1.0, stop - start)
    w = np.concatenate([first.z0 / prob.s_z, [start / prob.s_lam]])
    out = _newton(prob, w, np.eye(n + 1)[n], tol)  # re-solve at fixed λ with this step count
    if out is None:
        raise InputError(f"start: the orbit at {param} = {start:g} does not converge with "
                         f"{n_steps} steps per period")
    point = _point(prob, out.w, out.jac, out.mono, None, direction, out.iterations)
    point.ds = ds
    return _trace(prob, point, stop, ds_min, ds_max, max_points, tol, progress, label,
                  guards or StepGuards())


def _steps_for_range(model: Model, structure: Structure, per: Period, values: dict,
                     param: str, ends: tuple[float, float], dt: float | None) -> int:
    """RK4 steps per period so that the step is at most ``dt`` (s; None: the spec's) at
    both ends of the range of ``param``."""
    dt = float(model.simulation_defaults["dt"] if dt is None else dt)
    return max(steps_per_period(model, structure, per, {**values, param: end}, dt)
               for end in ends)


def _step(prob: _Problem, prev: BranchPoint, ds: float, tol: float, direction: float,
          guards: StepGuards) -> tuple[list[BranchPoint], BranchPoint] | str:
    """One predictor-corrector step of ``ds`` from ``prev``: (special points located between,
    the new point), or the reason it is refused (no convergence, or a guard)."""
    newton = _newton(prob, _w(prob, prev) + ds * prev.tangent, prev.tangent, tol)
    if newton is None:
        return "no convergence"
    point = _point(prob, newton.w, newton.jac, newton.mono, prev.tangent, direction,
                   newton.iterations)
    point.angle = _angle(prev.tangent, point.tangent)
    point.contraction = newton.contraction
    reason = _step_refusal(prob, prev, point, newton, ds, guards)
    if reason:
        return reason
    lp = None
    if _lp_test(prev) != 0 and np.sign(_lp_test(prev)) != np.sign(_lp_test(point)):
        lp = _fold_between(prob, prev, point, tol, direction)
        if lp is None and guards.active:
            return "the parameter component of the tangent changed sign but no fold was found"
    return _special_points(prob, prev, point, tol, direction, lp=lp), point


def _trace(prob: _Problem, first: BranchPoint, stop: float, ds_min: float, ds_max: float,
           max_points: int, tol: float, progress, label: str, guards: StepGuards,
           attrs: dict | None = None) -> xr.Dataset:
    """Continue from ``first`` (its tangent oriented the way to go, its ``ds`` the first
    step) until λ leaves the range between ``first.lam`` and ``stop``, ``max_points``
    points, or a step refused even at ``ds_min``."""
    param = prob.param_name
    branch, ds = [first], first.ds
    lo, hi = min(first.lam, stop), max(first.lam, stop)
    status, refused = "reached the end of the range", 0
    while len(branch) < max_points:
        prev = branch[-1]
        result = _step(prob, prev, ds, tol, _direction(prev), guards)
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
    """The sign of λ along the tangent (the start-up orientation of ``_tangent``)."""
    return math.copysign(1.0, point.tangent[-1])


def _refused_status(reason: str, ds_min: float, param: str, lam: float) -> str:
    """The status of a run stopped because no step down to ``ds_min`` was accepted."""
    if reason == "no convergence":
        return f"step fell below ds_min = {ds_min:g} (no convergence)"
    return (f"refused every step down to ds_min = {ds_min:g} from {param} = {lam:.8g} "
            f"({reason}): possibly a jump to another branch")


def _special_points(prob, a: BranchPoint, b: BranchPoint, tol, direction,
                    lp: BranchPoint | None = None) -> list[BranchPoint]:
    """LP, PD, BP and NS points between two consecutive branch points, located by
    bisection (``lp``: the fold already located between them)."""
    found = [lp] if lp is not None else []
    for kind, test in (("LP", _lp_test), ("PD", _pd_test), ("BP", _bp_test)):
        if kind == "BP" and found and found[0].special == "LP":
            continue  # at a fold det(M − I) changes sign too
        if kind == "LP" and lp is not None:
            continue
        if test(a) != 0 and np.sign(test(a)) != np.sign(test(b)):
            found.append(_locate(prob, a, b, kind, test, tol, direction))
    if _complex_outside(a) != _complex_outside(b):
        level = _complex_outside(a) + 0.5
        found.append(_locate(prob, a, b, "NS", lambda p: _complex_outside(p) - level, tol,
                             direction))
    if not found and a.n_unstable != b.n_unstable:
        b.special = "grazing?"
    return sorted(found, key=lambda p: np.dot(_w(prob, p) - _w(prob, a), a.tangent))


def branch_dataset(model: Model, prob: _Problem, branch: list[BranchPoint], param: str,
                   status: str, label: str = "", **extra: object) -> xr.Dataset:
    """The branch as a Dataset: ``param`` value, amplitude (of the first state variable),
    z0 (dims ``point`` × ``state``, the model's state names), the n multipliers (real and
    imaginary parts, dim ``k``), stability and special-point labels along ``point``; what a
    restart needs (``continue_from_branch``): the tangent (dim ``w``: the scaled state, then
    the parameter) and the planned step ``ds`` at each point, the scales ``state_scale``
    (the states' units) and attr ``param_scale`` (the parameter's unit), attrs ``t0`` (s),
    ``period`` and ``steps_per_period``; the guards' measures ``tangent_angle`` (deg) and
    ``newton_contraction``; attrs from ``run_attrs`` (model, spec, balls per bearing,
    parameters, state names) and ``extra``."""
    mult = np.array([p.multipliers for p in branch])
    attrs = run_attrs(model, prob.structure, prob.values)
    attrs.update(param=param, period=str(prob.period), steps_per_period=prob.n_steps,
                 t0=prob.t0, status=status, branch=label or f"period {prob.period}",
                 param_scale=prob.s_lam, **extra)
    attrs.pop(param, None)
    units = model.state_units
    return xr.Dataset(
        {param: ("point", np.array([p.lam for p in branch]),
                 {"units": model.units[param]}),
         "amplitude": ("point", np.array([p.amplitude for p in branch]),
                       {"units": units[model.state_names[0]],
                        "long_name": f"half peak-to-peak {model.state_names[0]} over one "
                                     "period"}),
         "z0": (("point", "state"), np.array([p.z0 for p in branch])),
         "multiplier_real": (("point", "k"), mult.real),
         "multiplier_imag": (("point", "k"), mult.imag),
         "multiplier_abs": (("point", "k"), np.abs(mult)),
         "stable": ("point", np.array([int(p.stable) for p in branch])),
         "special": ("point", np.array([p.special for p in branch], dtype=object)),
         "newton_iterations": ("point", np.array([p.newton_iterations for p in branch])),
         "tangent": (("point", "w"), np.array([p.tangent for p in branch]),
                     {"long_name": "unit tangent in the scaled variables (z0 / state_scale, "
                                   f"{param} / param_scale)"}),
         "ds": ("point", np.array([p.ds for p in branch]),
                {"long_name": "scaled arclength step planned from the point"}),
         "tangent_angle": ("point", np.array([p.angle for p in branch]),
                           {"units": "deg", "long_name": "angle from the previous tangent"}),
         "newton_contraction": ("point", np.array([p.contraction for p in branch])),
         "state_scale": ("state", np.asarray(prob.s_z, dtype=float),
                         {"long_name": "scale of each state in the unknowns"})},
        coords={"point": np.arange(len(branch)), "state": list(model.state_names),
                "k": np.arange(1, model.n_state + 1)},
        attrs=attrs)


@dataclass(frozen=True)
class _Switch:
    """What branch switching at a special point looks for: the critical multiplier (the
    smallest real part at a PD, the largest at a BP) must be beyond ``bound`` on the
    unstable side; the new orbit has the period ``period(base)`` and must not be the old
    orbit (``fallen_back``)."""

    kind: str
    critical: Callable[[np.ndarray], int]
    beyond: Callable[[float], bool]
    bound: str
    period: Callable[[Period], Period]
    orbit: str
    fallen_back: Callable[[PeriodicOrbit, PeriodicOrbit, np.ndarray], bool]


def _repeats_after_base_period(one: PeriodicOrbit, new: PeriodicOrbit,
                               size: np.ndarray) -> bool:
    """The period-2 orbit ``new`` is an orbit of ``one``'s period: Φ_T(z) = z."""
    model = one.system.model
    half = evaluate(flow_map(model, one.structure, as_period(model, one.period), one.n_steps),
                    new.z0, new.t0, one.system.p)[0]
    return bool(np.max(np.abs((half - new.z0) / size)) < 1e-6)


def _same_orbit(one: PeriodicOrbit, new: PeriodicOrbit, size: np.ndarray) -> bool:
    """``new`` is the orbit ``one`` again (same state at the section)."""
    return bool(np.max(np.abs((new.z0 - one.z0) / size)) < 1e-6)


SWITCHES = {
    "PD": _Switch("PD", lambda mu: int(np.argmin(mu.real)), lambda r: r < -1, "below −1",
                  Period.doubled, "period-1", _repeats_after_base_period),
    "BP": _Switch("BP", lambda mu: int(np.argmax(mu.real)), lambda r: r > 1, "above +1",
                  lambda per: per, "symmetric", _same_orbit),
}


def switch_branch(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                  kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The orbit born at the special point ``branch.point[point]``: the period-2 orbit at a
    period doubling (label PD), the asymmetric orbit at a symmetry-breaking pitchfork (BP).

    Steps ``offset`` × |range| into the side where the branch's orbit is unstable, solves
    that orbit there, kicks it along the eigenvector of its critical multiplier (below −1 at
    a PD, above +1 at a BP: the direction of the kernel of M ∓ I at the point) by ``kick`` ×
    the orbit size, and shoots for a fixed point of the doubled (PD) or the same (BP)
    period. The result is checked not to be the old orbit (``converged = False`` with the
    reason otherwise). ``dt`` (s): the RK4 step, default the branch's own.
    """
    kind = str(branch.special.values[point])
    if kind not in SWITCHES:
        raise InputError(f"point: {point} is not a PD or BP point (label '{kind}')")
    rule = SWITCHES[kind]
    attrs = branch.attrs
    param = attrs["param"]
    lam = float(branch[param][point])
    base = system_of_attrs({**attrs, param: lam})
    model = base.model
    unstable_side = [i for i in (point + 1, point - 1)
                     if 0 <= i < branch.sizes["point"] and not branch.stable.values[i]]
    if not unstable_side:
        raise InputError(f"point: no unstable {rule.orbit} orbit next to point {point}")
    step = float(branch[param][unstable_side[0]]) - lam
    lam += math.copysign(offset * _range(branch, param), step)
    system = base.replace(**{param: lam})
    period = Period.parse(attrs["period"])
    dt = dt or period_seconds(model, system.structure, period, dict(system.parameters)) / int(
        attrs["steps_per_period"])
    one = shoot(system, None, period, branch.z0.values[point], float(attrs["t0"]), dt=dt)
    mu, vectors = np.linalg.eig(one.monodromy)
    k = rule.critical(mu)
    if not (one.converged and rule.beyond(mu[k].real)):
        raise InputError(f"point: no {rule.orbit} orbit with a multiplier {rule.bound} at "
                         f"{param} = {lam:g} ({one.message}; multipliers {np.round(mu, 4)})")
    v = np.real(vectors[:, k])
    size = state_scale(one.z0, one.period_s, model.module.STATE_UNITS)
    guess = one.z0 + kick * size * v / np.max(np.abs(v / size))
    new = shoot(one.system, None, rule.period(period), guess, one.t0, dt=dt)
    if new.converged and rule.fallen_back(one, new, size):
        new.converged = False
        new.message = f"Newton fell back onto the {rule.orbit} orbit; try a larger kick"
    return new


def switch_period_doubling(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                           kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The period-2 orbit born at the period doubling ``branch.point[point]`` (label PD):
    ``switch_branch`` at a PD point. The result is checked to be a genuine period-2 orbit
    (Φ_T(z) ≠ z)."""
    if str(branch.special.values[point]) != "PD":
        raise InputError(f"point: {point} is not a period-doubling point (label "
                         f"'{branch.special.values[point]}')")
    return switch_branch(branch, point, offset=offset, kick=kick, dt=dt)


def switch_branch_point(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                        kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The asymmetric orbit born at the branch point ``branch.point[point]`` (label BP, a
    real multiplier through +1 without a fold: a symmetry-breaking pitchfork):
    ``switch_branch`` at a BP point. The result is checked not to be the symmetric orbit."""
    if str(branch.special.values[point]) != "BP":
        raise InputError(f"point: {point} is not a branch point (label "
                         f"'{branch.special.values[point]}')")
    return switch_branch(branch, point, offset=offset, kick=kick, dt=dt)


def first_point(branch: xr.Dataset, kind: str) -> int | None:
    """Index of the first point labelled ``kind`` (LP, PD, BP, NS) on ``branch``, or None."""
    found = np.nonzero(branch.special.values == kind)[0]
    return int(found[0]) if len(found) else None


def _range(branch: xr.Dataset, param: str) -> float:
    values = branch[param].values
    return float(np.ptp(values)) or abs(float(values[0])) or 1.0


def continue_from_orbit(orbit: PeriodicOrbit, *, param: str, stop: float, ds: float = 0.01,
                        ds_min: float = 1e-6, ds_max: float = 0.05, max_points: int = 200,
                        dt: float | None = None, tol: float = 1e-9,
                        progress: Callable[[str], None] | None = None,
                        label: str = "", guards: StepGuards | None = None) -> xr.Dataset:
    """Continue a branch from an already solved orbit of ``periodic.shoot`` (e.g. after
    branch switching) in ``param`` towards ``stop``; ``dt`` (s) defaults to the spec's;
    ``guards`` as in ``continue_orbits``."""
    start = orbit.values[param]
    return _continue_from(orbit, param, start, stop, ds, ds_min, ds_max, max_points,
                          dt, tol, progress, label, guards)


def continue_from_branch(branch: xr.Dataset | str | Path, point: int = -1, *, stop: float,
                         ds: float | None = None, ds_min: float = 1e-6, ds_max: float = 0.05,
                         max_points: int = 200, dt: float | None = None, tol: float = 1e-9,
                         progress: Callable[[str], None] | None = None, label: str = "",
                         guards: StepGuards | None = None) -> xr.Dataset:
    """Continue again from point ``point`` (negative: from the end) of a stored branch (a
    Dataset or netCDF file of ``continue_orbits``) towards ``stop`` (the parameter's unit),
    in either direction: the branch's tangent there is oriented so that the parameter
    moves towards ``stop``.

    The branch's own model (spec file, else name), balls, parameters, period, section time
    t0 and steps per period are used, and, when stored, its scales, its tangent and its
    planned step ``ds`` at the point (``ds`` overrides it): continued over the same range, a
    restart reproduces the original points after ``point``. ``dt`` (s): more steps per
    period when the range needs them (default the spec's step). Other arguments as in
    ``continue_orbits``.
    """
    check_steps(ds, ds_min, ds_max, max_points, tol)
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
    w = np.concatenate([z0 / prob.s_z, [lam / prob.s_lam]])
    n = prob.n
    out = _newton(prob, w, np.eye(n + 1)[n] if tau is None else tau, tol)
    if out is None:
        raise InputError(f"point: the stored orbit at {param} = {lam:g} does not converge "
                         f"with {prob.n_steps} steps per period")
    first = _point(prob, out.w, out.jac, out.mono, tau, direction, out.iterations)
    if tau is not None:
        first.tangent = tau
    stored_ds = float(branch.ds.values[k]) if "ds" in branch else 0.0
    first.ds = ds if ds is not None else (stored_ds if stored_ds > 0 else 0.01)
    first.special = str(branch.special.values[k])
    return _trace(prob, first, stop, ds_min, ds_max, max_points, tol, progress,
                  label or str(attrs.get("branch", "")), guards or StepGuards(),
                  attrs={"restarted_from": f"{source or 'branch'} point {k}"})


def _problem_of_branch(branch: xr.Dataset, lam: float, stop: float,
                       dt: float | None) -> _Problem:
    """The ``_Problem`` of a stored branch at ``param = lam``, with enough steps per period
    for the range to ``stop`` (at least the branch's own) and its scales (``s_z`` None when
    the file has none: an older file)."""
    attrs = branch.attrs
    param = str(attrs["param"])
    system = system_of_attrs({**attrs, param: lam})
    model = system.model
    per = as_period(model, str(attrs["period"]))
    values = dict(system.parameters)
    n_steps = max(int(attrs["steps_per_period"]),
                  _steps_for_range(model, system.structure, per, values, param, (lam, stop),
                                   dt))
    s_lam = float(attrs.get("param_scale", abs(stop - lam)))
    prob = _Problem(model, system.structure, per, model.parameter_names.index(param), values,
                    float(attrs["t0"]), n_steps, np.ones(model.n_state), s_lam)
    prob.s_z = np.asarray(branch.state_scale.values, dtype=float) \
        if "state_scale" in branch else None
    return prob


def special_points(branch: xr.Dataset) -> list[dict]:
    """The labelled points of a branch: label, point index, the parameter value (its unit)
    and the n multipliers (real and imaginary parts)."""
    param = branch.attrs["param"]
    return [{"kind": str(kind), "point": int(j), "value": float(branch[param].values[j]),
             "multipliers_real": branch.multiplier_real.values[j].tolist(),
             "multipliers_imag": branch.multiplier_imag.values[j].tolist()}
            for j, kind in enumerate(branch.special.values) if kind]


def special_point_lines(branch: xr.Dataset) -> list[str]:
    """One line per special point in the parameter's own unit, e.g.
    ``LP  speed_rpm = 7871.75 rpm  (point 41)``."""
    param = branch.attrs["param"]
    unit = str(branch[param].attrs.get("units", ""))
    return [f"{p['kind']}  {param} = {p['value']:.6g} {unit}".rstrip() + f"  (point {p['point']})"
            for p in special_points(branch)]


def branch_summary(branch: xr.Dataset) -> dict:
    """What a branch is, in plain types (``bearingdyn continue --json``): model, parameter
    and its unit, period, points, parameter range covered, stable points, status, refused
    steps, the special points (``special_points``) and where it restarted from."""
    attrs, param = branch.attrs, branch.attrs["param"]
    values = branch[param].values
    return {"branch": str(attrs.get("branch", "")), "model": str(attrs["model"]),
            "param": param, "units": str(branch[param].attrs.get("units", "")),
            "period": str(attrs["period"]), "points": int(branch.sizes["point"]),
            "range": [float(values.min()), float(values.max())],
            "stable_points": int(branch.stable.values.sum()),
            "status": str(attrs["status"]),
            "refused_steps": int(attrs.get("refused_steps", 0)),
            "restarted_from": str(attrs.get("restarted_from", "")) or None,
            "special_points": special_points(branch)}
