"""Continuation of harmonic-balance responses in a runtime parameter.

The branch problem ``HarmonicBranchProblem`` has the unknowns w = (X / s_X, λ / s_λ): the
Fourier coefficients scaled per state (``solve.response_scale`` of the first response,
the same for every harmonic) and the parameter scaled by the requested range; its equations
G(w) = R(X, λ) / (ω_0 s_i) (ω_0 of the first response, fixed along the branch). It meets
the interface of ``analysis.stability.continuation``'s corrector: ``residual(w)`` gives
(G, [∂G/∂w], "monodromy"), where the monodromy is a matrix whose eigenvalues are Hill's
multipliers (``hill.hill_stability``), computed only when asked for (its eigenvalues, at a
branch point), so Keller's bordered Newton (``continuation.newton``), the branch points and
the location of LP, PD, BP and NS points by bisection (``continuation.detect``) are the
shooting branch's own, with the same tests.

The stepping loop is written here (``trace_harmonic_branch``) because the shooting loop
ends in a Dataset of shooting orbits; it applies the same ``StepGuards`` with the same
words (Newton contraction, distance from the predictor, tangent and secant angles, the
parameter's direction, a located fold where the tangent's λ component flips) and the same
step control, and stops the same ways (the end of the range, ``max_points``, a step refused
down to ``ds_min``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.harmonic import HarmonicSystem, blas_threads, check_harmonics
from analysis.frequency.hill import SORTS, hill_stability
from analysis.frequency.solve import (
    DENSE_POINTS,
    harmonic_balance,
    prepare,
    response_scale,
    responses_dataset,
)
from analysis.integrate.flow import Period
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.continuation.detect import fold_between, lp_test, points_between
from analysis.stability.continuation.options import (
    ContinuationOptions,
    StepGuards,
    options_with,
)
from analysis.stability.continuation.problem import (
    BranchPoint,
    ContinuedParameter,
    Newton,
    branch_point,
    newton,
    scaled,
)

Progress = Callable[[str], None] | None
"""Where progress lines go (None: nowhere)."""


class HillMonodromy:
    """A matrix with Hill's multipliers as eigenvalues (diag(μ)), computed from the
    Jacobian when first used as an array (``np.asarray``): the corrector asks for the
    residual at every iteration, and only the converged point's multipliers are needed."""

    def __init__(self, prob: HarmonicBranchProblem, jacobian: np.ndarray, period_s: float):
        self._prob, self._jacobian, self._period_s = prob, jacobian, period_s
        self._value: np.ndarray | None = None

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        if self._value is None:
            hs = self._prob.hs
            hill = hill_stability(self._jacobian, hs.n, hs.harmonics, self._period_s,
                                  self._prob.sort, self._prob.state_scale)
            self._value = np.diag(hill.multipliers)
        return self._value if dtype is None else self._value.astype(dtype)


@dataclass
class HarmonicBranchProblem(ContinuedParameter):
    """Harmonic-balance responses of ``hs`` (system, period, H, N) as the runtime parameter
    number ``param_index`` varies, the others at ``values`` (their units); scales
    ``state_scale`` (per state, its unit), ``s_lam`` (the parameter's unit) and ω_0
    ``omega_ref`` (rad/s) of the residual."""

    hs: HarmonicSystem
    param_index: int
    values: dict[str, float]
    state_scale: np.ndarray
    s_lam: float
    omega_ref: float
    sort: str = "centroid"
    s_z: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.s_z = np.tile(self.state_scale, 2 * self.hs.harmonics + 1)

    @property
    def model(self) -> Model:
        return self.hs.system.model

    @property
    def n(self) -> int:
        """Number of unknowns besides λ (the Fourier coefficients)."""
        return self.hs.size

    def residual(self, w: np.ndarray):
        """G(w) (n(2H + 1)), its Jacobian (n(2H + 1) × (n(2H + 1) + 1)) and a
        ``HillMonodromy``."""
        x, lam = w[:-1] * self.s_z, w[-1] * self.s_lam
        p = self.p(lam)
        r, jac, along = self.hs.evaluate(x, p, self.param_index)
        unit = self.omega_ref * self.s_z
        g = r / unit
        jx = jac * (self.s_z[None, :] / unit[:, None])
        jl = along * self.s_lam / unit
        return g, np.column_stack([jx, jl]), HillMonodromy(self, jac, self.hs.period_s(p))

    def residual_norm(self, w: np.ndarray) -> float:
        """max |G_i| at ``w`` (the scaled residual of ``solve``)."""
        x, lam = w[:-1] * self.s_z, w[-1] * self.s_lam
        r, _, _ = self.hs.evaluate(x, self.p(lam))
        return float(np.max(np.abs(r / (self.omega_ref * self.s_z))))

    def amplitude(self, w: np.ndarray) -> float:
        """(max − min)/2 of the first state over the period (its unit)."""
        return float(self.amplitudes(w[:-1] * self.s_z)[0])

    def amplitudes(self, coeffs: np.ndarray) -> np.ndarray:
        """(max − min)/2 of each state over the period (their units)."""
        z = self.hs.sample(coeffs, max(self.hs.samples, DENSE_POINTS))
        return np.ptp(z, axis=0) / 2


def continue_harmonic(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    param: str,
    start: float,
    stop: float,
    period: str | Period | None = None,
    harmonics: int = 10,
    samples: int | None = None,
    guess: np.ndarray | None = None,
    dt: float | None = None,
    settle: float | None = None,
    sort: str = "centroid",
    ds: float | None = None,
    ds_min: float | None = None,
    ds_max: float | None = None,
    max_points: int | None = None,
    tol: float | None = None,
    guards: StepGuards | None = None,
    options: ContinuationOptions | None = None,
    progress: Progress = None,
    **parameters: float,
) -> xr.Dataset:
    """Continue harmonic-balance responses in ``param`` from ``start`` towards ``stop``
    (the parameter's unit), with Hill's stability and LP, PD, BP and NS points.

    The first response is ``solve.harmonic_balance`` at ``param = start`` (``period``,
    ``harmonics``, ``samples``, ``guess``, ``dt``, ``settle``, ``sort`` as there).
    ``options`` and the keywords that replace its fields as in
    ``continuation.continue_orbits`` (scaled arclength steps: λ scaled by |stop − start|,
    the coefficients by their state's scale). Returns the branch Dataset
    (``harmonic_branch_dataset``).
    """
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol, guards=guards)
    if sort not in SORTS:
        raise InputError(f"sort: must be one of {', '.join(SORTS)}, got {sort!r}")
    system = as_system(system, n_balls, **parameters)
    model = system.model
    if param not in model.parameter_names:
        raise InputError(f"param: '{param}' is not a parameter of '{model.name}'; "
                         f"choose one of {', '.join(model.parameter_names)}")
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise InputError(f"stop: must be finite and differ from start, got {start!r}, "
                         f"{stop!r}")
    check_harmonics(harmonics, model.n_state)
    model.parameters({param: stop})  # range check of the end value
    system = system.replace(**{param: start})
    system, per = prepare(system, period)
    first = harmonic_balance(system, None, per, harmonics, samples=samples, guess=guess,
                             dt=dt, settle=settle, stability=False, sort=sort)
    if not first.converged:
        raise InputError(f"start: no periodic response found at {param} = {start:g} "
                         f"({first.message})")
    hs = HarmonicSystem(first.system, per, harmonics, samples)
    prob = HarmonicBranchProblem(hs, model.parameter_names.index(param),
                                 dict(first.system.parameters),
                                 response_scale(hs, first.coefficients, first.period_s),
                                 abs(stop - start), 2 * math.pi / first.period_s, sort)
    with blas_threads():
        return trace_harmonic_branch(prob, first.coefficients, stop, options,
                                     progress=progress)


def trace_harmonic_branch(prob: HarmonicBranchProblem, coeffs: np.ndarray, stop: float,
                          options: ContinuationOptions, *, progress: Progress = None
                          ) -> xr.Dataset:
    """Continue from the response ``coeffs`` (harmonic-major) at the problem's own
    parameter value towards ``stop`` until λ leaves the range, ``max_points`` points, or a
    step refused down to ``ds_min``."""
    param, lam0 = prob.param_name, prob.values[prob.param_name]
    direction = math.copysign(1.0, stop - lam0)
    w = np.concatenate([coeffs / prob.s_z, [lam0 / prob.s_lam]])
    out = newton(prob, w, np.eye(prob.n + 1)[-1], options.tol)
    if out is None:
        raise InputError(f"start: the response at {param} = {lam0:g} does not converge "
                         "again in the branch's unknowns")
    first = branch_point(prob, out.w, out.jac, out.mono, None, direction, out.iterations)
    first.ds = options.first_ds
    branch, ds = [first], first.ds
    lo, hi = min(lam0, stop), max(lam0, stop)
    status, refused = "reached the end of the range", 0
    while len(branch) < options.max_points:
        prev = branch[-1]
        result = _step(prob, prev, ds, options.tol, options.guards)
        if isinstance(result, str):
            refused += result != "no convergence"
            ds /= 2
            if ds < options.ds_min:
                status = (f"step fell below ds_min = {options.ds_min:g} (no convergence)"
                          if result == "no convergence" else
                          f"refused every step down to ds_min = {options.ds_min:g} from "
                          f"{param} = {prev.lam:.8g} ({result}): possibly a jump to another "
                          "branch")
                break
            continue
        found, point = result
        branch.extend(found)
        branch.append(point)
        ds = min(ds * 1.5, options.ds_max) if point.newton_iterations <= 3 else \
            max(ds / 1.5, options.ds_min)
        point.ds = ds
        if progress and len(branch) % 10 == 0:
            progress(f"{len(branch)} points, {param} = {point.lam:.6g}, "
                     f"{'stable' if point.stable else 'unstable'}")
        if not lo <= point.lam <= hi:
            break
    else:
        status = f"stopped after max_points = {options.max_points}"
    return harmonic_branch_dataset(prob, branch, status, refused_steps=refused)


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    cos = np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v))
    return math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))


def _refusal(prob: HarmonicBranchProblem, a: BranchPoint, b: BranchPoint, corrected: Newton,
             ds: float, guards: StepGuards) -> str:
    """Why ``guards`` refuse the step from a to b ('' when they pass): the tests of the
    shooting branch's guards, in its words."""
    if not guards.active:
        return ""
    if corrected.contraction > guards.max_contraction:
        return (f"Newton contraction {corrected.contraction:.2f} > "
                f"{guards.max_contraction:g}")
    if corrected.distance > guards.max_correction * ds:
        return (f"the corrector moved {corrected.distance / ds:.2f} ds > "
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


def _branch_point(prob: HarmonicBranchProblem, corrected: Newton,
                  previous: np.ndarray) -> BranchPoint:
    """``continuation.branch_point`` of a corrected step, its tangent from one bordered
    solve [∂G/∂w; τ_prev] τ = e_last (normalised, oriented along τ_prev) instead of an SVD:
    the same null vector, a tenth of the work at a few hundred unknowns."""
    border = np.vstack([corrected.jac, previous])
    rhs = np.zeros(border.shape[0])
    rhs[-1] = 1.0
    try:
        tau = np.linalg.solve(border, rhs)
    except np.linalg.LinAlgError:
        return branch_point(prob, corrected.w, corrected.jac, corrected.mono, previous,
                            math.copysign(1.0, previous[-1]), corrected.iterations)
    tau /= np.linalg.norm(tau)
    if np.dot(tau, previous) < 0:
        tau = -tau
    return BranchPoint(lam=corrected.w[-1] * prob.s_lam, z0=corrected.w[:-1] * prob.s_z,
                       multipliers=np.linalg.eigvals(corrected.mono), monodromy=corrected.mono,
                       tangent=tau, amplitude=prob.amplitude(corrected.w),
                       newton_iterations=corrected.iterations)


def _step(prob: HarmonicBranchProblem, prev: BranchPoint, ds: float, tol: float,
          guards: StepGuards) -> tuple[list[BranchPoint], BranchPoint] | str:
    direction = math.copysign(1.0, prev.tangent[-1])
    corrected = newton(prob, scaled(prob, prev) + ds * prev.tangent, prev.tangent, tol)
    if corrected is None:
        return "no convergence"
    point = _branch_point(prob, corrected, prev.tangent)
    point.angle = _angle(prev.tangent, point.tangent)
    point.contraction = corrected.contraction
    reason = _refusal(prob, prev, point, corrected, ds, guards)
    if reason:
        return reason
    lp = None
    if lp_test(prev) != 0 and np.sign(lp_test(prev)) != np.sign(lp_test(point)):
        lp = fold_between(prob, prev, point, tol, direction)
        if lp is None and guards.active:
            return "the parameter component of the tangent changed sign but no fold was found"
    return points_between(prob, prev, point, tol, direction, lp=lp), point


def branch_step(prob, prev: BranchPoint, ds: float, tol: float, guards: StepGuards
                ) -> tuple[list[BranchPoint], BranchPoint] | str:
    """One predictor–corrector step of ``ds`` from ``prev`` with the ``guards``: the special
    points found on the way and the new point, or why the step failed. Any problem with
    ``residual``, ``amplitude``, ``n``, ``s_z`` and ``s_lam`` (the torus branch's too)."""
    return _step(prob, prev, ds, tol, guards)


def harmonic_branch_dataset(prob: HarmonicBranchProblem, branch: list[BranchPoint],
                            status: str, **extra: object) -> xr.Dataset:
    """The branch as a Dataset (``solve.responses_dataset``: amplitude per state, stable,
    special, residual, coefficients, Hill's multipliers) with the parameter along ``point``
    (its unit), the tangent (dim ``w``) and the planned step ``ds``; attrs ``param``,
    ``param_scale``, ``sort``, ``status``, ``branch`` and ``extra``."""
    model, hs = prob.model, prob.hs
    param = prob.param_name
    residuals = [prob.residual_norm(np.concatenate([p.z0 / prob.s_z, [p.lam / prob.s_lam]]))
                 for p in branch]
    values = {k: v for k, v in prob.values.items() if k != param}
    system = hs.system.replace(**values)
    data = responses_dataset(
        system, str(hs.period), hs.harmonics, hs.samples, np.array([p.z0 for p in branch]),
        np.array([p.multipliers for p in branch]), np.array(residuals),
        [p.special for p in branch], prob.state_scale,
        variables={
            param: ("point", np.array([p.lam for p in branch]), {"units": model.units[param]}),
            "newton_iterations": ("point", np.array([p.newton_iterations for p in branch])),
            "tangent": (("point", "w"), np.array([p.tangent for p in branch])),
            "ds": ("point", np.array([p.ds for p in branch]))},
        param=param, param_scale=prob.s_lam, sort=prob.sort, status=status,
        branch=f"harmonic balance, period {hs.period}, H = {hs.harmonics}", **extra)
    data.attrs.pop(param, None)
    return data
