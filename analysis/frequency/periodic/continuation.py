"""Continuation of harmonic-balance responses in a runtime parameter: the periodic HB family
of the one engine (``analysis.stability.continuation.trace``).

The branch problem ``HarmonicBranchProblem`` has the unknowns w = (X / s_X, λ / s_λ): the
Fourier coefficients scaled per state (``solve.response_scale`` of the first response,
the same for every harmonic) and the parameter scaled by the requested range; its equations
G(w) = R(X, λ) / (ω_0 s_i) (ω_0 of the first response, fixed along the branch). Its
``residual(w)`` gives (G, [∂G/∂w], "monodromy"), where the monodromy is a matrix whose
eigenvalues are Hill's multipliers (``hill.hill_stability``), computed only when asked for
(its eigenvalues, at a branch point), so Keller's bordered Newton, the ``StepGuards``, the
step control, the stop statuses and the location of LP, PD, BP and NS points by bisection
(``continuation.detect``) are the shooting branch's own. Its tangent is the bordered solve
(``tangent_method = "bordered"``: the SVD's null vector at a tenth of the work for a few
hundred unknowns).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.periodic.harmonic import HarmonicSystem, blas_threads, check_harmonics
from analysis.frequency.periodic.hill import SORTS, hill_stability
from analysis.frequency.periodic.solve import (
    DENSE_POINTS,
    harmonic_balance,
    prepare,
    response_scale,
    responses_dataset,
)
from analysis.integrate.flow import Period
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.continuation.options import (
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
from analysis.stability.continuation.trace import Progress, Trace, trace


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


class FourierBranchProblem(ContinuedParameter):
    """What the harmonic-balance families share (periodic HB here, 2-D HB tori in
    ``torus.continuation``): unknowns w = (X / s_X, λ / s_λ) of the Fourier coefficients X
    of ``equations`` (a ``HarmonicSystem`` or ``TorusSystem``: ``evaluate``, ``residual``,
    ``size``, ``system``), equations G = R(X, λ) / (ω_0 s_i) with ω_0 ``omega_ref``
    (rad/s); the tangent by the bordered solve. A family adds ``equations``, ``amplitude``
    and ``monodromy(jacobian, p)`` (a matrix whose eigenvalues are its multipliers)."""

    omega_ref: float
    tangent_method = "bordered"

    @property
    def model(self) -> Model:
        return self.equations.system.model

    @property
    def n(self) -> int:
        """Number of unknowns besides λ (the Fourier coefficients)."""
        return self.equations.size

    def residual(self, w: np.ndarray):
        """G(w) (m), its Jacobian (m × (m + 1)) and the family's ``monodromy``."""
        x, lam = w[:-1] * self.s_z, w[-1] * self.s_lam
        p = self.p(lam)
        r, jac, along = self.equations.evaluate(x, p, self.param_index)
        unit = self.omega_ref * self.s_z
        g = r / unit
        jx = jac * (self.s_z[None, :] / unit[:, None])
        jl = along * self.s_lam / unit
        return g, np.column_stack([jx, jl]), self.monodromy(jac, p)

    def residual_norm(self, w: np.ndarray) -> float:
        """max |G_i| at ``w`` (the scaled residual of a single solve)."""
        x, lam = w[:-1] * self.s_z, w[-1] * self.s_lam
        r = self.equations.residual(x, self.p(lam))
        return float(np.max(np.abs(r / (self.omega_ref * self.s_z))))


@dataclass
class HarmonicBranchProblem(FourierBranchProblem):
    """Harmonic-balance responses of ``hs`` (system, period, H, N) as the runtime parameter
    number ``param_index`` varies, the others at ``values`` (their units); scales
    ``state_scale`` (per state, its unit), ``s_lam`` (the parameter's unit) and ω_0
    ``omega_ref`` (rad/s) of the residual; Hill's multipliers sorted by ``sort``."""

    hs: HarmonicSystem
    param_index: int
    values: dict[str, float]
    state_scale: np.ndarray
    s_lam: float
    omega_ref: float
    sort: str = "centroid"
    s_z: np.ndarray = field(init=False)
    noun = "response"

    def __post_init__(self) -> None:
        self.s_z = np.tile(self.state_scale, 2 * self.hs.harmonics + 1)

    @property
    def equations(self) -> HarmonicSystem:
        return self.hs

    def monodromy(self, jacobian: np.ndarray, p: np.ndarray) -> HillMonodromy:
        """Hill's multipliers, computed when first used (``HillMonodromy``)."""
        return HillMonodromy(self, jacobian, self.hs.period_s(p))

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
    span = ContinuedRange.check(model, param, start, stop)
    check_harmonics(harmonics, model.n_state)
    system = system.replace(**{param: start})
    system, per = prepare(system, period)
    first = harmonic_balance(system, None, per, harmonics, samples=samples, guess=guess,
                             dt=dt, settle=settle, stability=False, sort=sort)
    if not first.converged:
        raise InputError(f"start: no periodic response found at {param} = {start:g} "
                         f"({first.message})")
    hs = HarmonicSystem(first.system, per, harmonics, samples)
    prob = HarmonicBranchProblem(hs, span.index, dict(first.system.parameters),
                                 response_scale(hs, first.coefficients, first.period_s),
                                 span.scale, 2 * math.pi / first.period_s, sort)
    with blas_threads():
        out = trace_from(prob, first.coefficients, stop, options, progress=progress)
    return harmonic_branch_dataset(prob, out.points, out.status, refused_steps=out.refused)


def trace_from(prob: ContinuedParameter, coeffs: np.ndarray, stop: float,
               options: ContinuationOptions, **engine: object) -> Trace:
    """The engine's trace of ``prob`` (an HB, torus or circle problem) from the unknowns
    ``coeffs`` at the problem's own parameter value towards ``stop``; ``engine``: the
    ``hooks`` and ``progress`` of ``trace``."""
    param, lam0 = prob.param_name, prob.values[prob.param_name]
    w = np.concatenate([coeffs / prob.s_z, [lam0 / prob.s_lam]])
    first = start_at(prob, w, math.copysign(1.0, stop - lam0), options.tol)
    if first is None:
        raise InputError(f"start: the {prob.noun} at {param} = {lam0:g} does not converge "
                         "again in the branch's unknowns")
    first.ds = options.first_ds
    return trace(prob, first, stop, options, **engine)


def branch_variables(prob: ContinuedParameter, branch: list[BranchPoint]) -> dict:
    """The Dataset variables every branch of ``analysis.frequency`` has along ``point``:
    the parameter (its unit), the Newton iterations and the planned step ``ds``."""
    param = prob.param_name
    return {param: ("point", np.array([pt.lam for pt in branch]),
                    {"units": prob.model.units[param]}),
            "newton_iterations": ("point", np.array([pt.newton_iterations for pt in branch])),
            "ds": ("point", np.array([pt.ds for pt in branch]))}


def harmonic_branch_dataset(prob: HarmonicBranchProblem, branch: list[BranchPoint],
                            status: str, **extra: object) -> xr.Dataset:
    """The branch as a Dataset (``solve.responses_dataset``: amplitude per state, stable,
    special, residual, coefficients, Hill's multipliers) with the parameter along ``point``
    (its unit), the tangent (dim ``w``) and the planned step ``ds``; attrs ``param``,
    ``param_scale``, ``sort``, ``status``, ``branch`` and ``extra``."""
    hs = prob.hs
    param = prob.param_name
    residuals = [prob.residual_norm(prob.unknowns(p))
                 for p in branch]
    values = {k: v for k, v in prob.values.items() if k != param}
    system = hs.system.replace(**values)
    data = responses_dataset(
        system, str(hs.period), hs.harmonics, hs.samples, np.array([p.z0 for p in branch]),
        np.array([p.multipliers for p in branch]), np.array(residuals),
        [p.special for p in branch], prob.state_scale,
        variables={**branch_variables(prob, branch),
                   "tangent": (("point", "w"), np.array([p.tangent for p in branch]))},
        param=param, param_scale=prob.s_lam, sort=prob.sort, status=status,
        branch=f"harmonic balance, period {hs.period}, H = {hs.harmonics}", **extra)
    data.attrs.pop(param, None)
    return data
