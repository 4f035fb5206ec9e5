"""Continuation of the invariant circle of the shaft map (``invariant_circle``) in a runtime
parameter, with the torus branch's step and an honest report of where it stops.

``CircleBranchProblem`` is the branch problem of ``torus_continuation``: unknowns
w = (U / s_U, λ / s_λ) (U the circle, point-major), equations G = F(U, λ) / s_U with
F = P(U) − (R_ρ(λ) ⊗ I) U. Its Jacobian is exact: ∂P/∂U and ∂P/∂λ are carried through the
RK4 (``ShaftMap.along``: the step h = T1(λ)/steps and the phases' dependence included), and
∂R_ρ/∂λ = ∂R/∂ρ · ∂ρ/∂λ (``shift_derivative``, ρ by AD). Its monodromy is empty, so
``continuation.branch_step`` (Keller's bordered Newton, the ``StepGuards``, folds) runs as for
the HB torus (``torus_continuation.trace_torus_branch``). The branch also stops when the
circle's Fourier tail (``invariant_circle.TAIL_FRACTION``) grows beyond ``tail_limit``: the
circle is no longer resolved by its N points (it loses smoothness).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.harmonic import blas_threads
from analysis.frequency.invariant_circle import (
    DEFAULT_POINTS,
    TAIL_FRACTION,
    CircleResponse,
    ShaftMap,
    circle_modes,
    regular_grid,
    shift_derivative,
    shift_matrix,
    solve_circle,
)
from analysis.frequency.torus_continuation import stop_report, trace_torus_branch
from analysis.frequency.torus_dataset import tori_dataset
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.continuation.options import ContinuationOptions, options_with
from analysis.stability.continuation.problem import ContinuedParameter

Progress = Callable[[str], None] | None

TAIL_LIMIT = 1e-2
"""Largest circle tail (its modes k > 0.4 N over its largest, states scaled) of a point the
circle branch keeps."""


@dataclass
class CircleBranchProblem(ContinuedParameter):
    """Circles of ``shaft`` as parameter number ``param_index`` varies, the others at
    ``values``; scales ``state_scale`` (per state) and ``s_lam`` (the parameter's unit)."""

    shaft: ShaftMap
    param_index: int
    values: dict[str, float]
    state_scale: np.ndarray
    s_lam: float
    tail_limit: float = TAIL_LIMIT
    s_z: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.s_z = np.tile(self.state_scale, self.shaft.points)

    @property
    def model(self) -> Model:
        return self.shaft.system.model

    @property
    def n(self) -> int:
        return self.shaft.points * self.shaft.system.n_state

    def circle(self, w: np.ndarray) -> np.ndarray:
        return (w[:-1] * self.s_z).reshape(self.shaft.points, -1)

    def residual(self, w: np.ndarray):
        """G(w), its Jacobian (n N × (n N + 1)) and an empty monodromy."""
        u, lam = self.circle(w), w[-1] * self.s_lam
        p, e = self.p(lam), np.eye(len(self.values))[self.param_index]
        points, n = u.shape
        phi = 2 * math.pi * np.arange(points) / points
        zt, jac, d = self.shaft.along(u, phi, p, e)
        rho, drho = (float(v) for v in self.shaft.rotation_function(p, e))
        shift = shift_matrix(points, rho)
        g = (zt - shift @ u).reshape(-1) / self.s_z
        full = -np.kron(shift, np.eye(n))
        for j in range(points):
            full[j * n:(j + 1) * n, j * n:(j + 1) * n] += jac[j]
        dlam = (d - drho * shift_derivative(points, rho) @ u).reshape(-1)
        jx = full * (self.s_z[None, :] / self.s_z[:, None])
        return g, np.column_stack([jx, dlam * self.s_lam / self.s_z]), np.zeros((0, 0))

    def residual_norm(self, w: np.ndarray) -> float:
        return float(np.max(np.abs(self.residual(w)[0])))

    def amplitude(self, w: np.ndarray) -> float:
        """(max − min)/2 of the first state over the circle (its unit)."""
        return float(np.ptp(self.circle(w)[:, 0]) / 2)

    def tail(self, u: np.ndarray) -> float:
        modes = circle_modes(u / self.state_scale[None, :])
        top = float(modes[1:].max())
        high = modes[np.arange(len(modes)) > TAIL_FRACTION * u.shape[0]]
        return float(high.max() / top) if top > 0 and high.size else 0.0


def continue_circle(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    param: str,
    start: float,
    stop: float,
    frequencies: str | tuple = "shaft,vc",
    points: int = DEFAULT_POINTS,
    dt: float | None = None,
    settle: float | None = None,
    tail_limit: float = TAIL_LIMIT,
    ds: float | None = None,
    ds_min: float | None = None,
    ds_max: float | None = None,
    max_points: int | None = None,
    tol: float | None = None,
    options: ContinuationOptions | None = None,
    progress: Progress = None,
    **parameters: float,
) -> xr.Dataset:
    """Continue the invariant circle of ``frequencies`` at ``points`` cage phases in
    ``param`` from ``start`` towards ``stop`` (the parameter's unit), the RK4 steps per
    shaft period fixed at those of ``start`` (h follows T1). The first circle is
    ``solve_circle`` at ``start``. Stops at the end of the range, after ``max_points``,
    when a step fails down to ``ds_min``, or when the circle's tail exceeds
    ``tail_limit`` (that point dropped). Returns the branch as the torus Dataset
    (``tori_dataset``, the parameter along ``point``; λ1 not computed), attrs ``status``
    and ``stop_report``."""
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol)
    system = as_system(system, n_balls, **parameters)
    model = system.model
    if param not in model.parameter_names:
        raise InputError(f"param: '{param}' is not a parameter of '{model.name}'; "
                         f"choose one of {', '.join(model.parameter_names)}")
    if not (math.isfinite(start) and math.isfinite(stop)) or start == stop:
        raise InputError(f"stop: must be finite and differ from start, got {start!r}, "
                         f"{stop!r}")
    model.parameters({param: stop})
    system = system.replace(**{param: start})
    first = solve_circle(system, None, frequencies, points, dt=dt, settle=settle,
                         convergence=False, stability=False)
    if not first.converged:
        raise InputError(f"start: no invariant circle found at {param} = {start:g} "
                         f"({first.message})")
    shaft = ShaftMap(first.system, first.frequencies, first.steps, first.samples,
                     first.points)
    prob = CircleBranchProblem(shaft, model.parameter_names.index(param),
                               dict(first.system.parameters), first.scale, abs(stop - start),
                               tail_limit)
    if prob.tail(first.circle) > tail_limit:
        raise InputError(f"points: the circle at {param} = {start:g} has a Fourier tail "
                         f"{prob.tail(first.circle):.2e} above tail_limit = {tail_limit:g}; "
                         "give more points")
    guarded = _TailGuard(prob)
    with blas_threads():
        branch, status, tried = trace_torus_branch(guarded, first.circle.reshape(-1), stop,
                                                   options, progress)
    if guarded.stopped:
        status = guarded.stopped
    tails = np.array([prob.tail(pt.z0.reshape(points, -1)) for pt in branch])
    fine = np.column_stack([np.full(len(branch), np.nan), tails])
    report = stop_report(prob, branch, status, fine, np.full(len(branch), np.nan), tried)
    report = report.replace("Last converged torus", "Last converged circle")
    report = report.replace("residual on the finer grid nan -> nan (xnan), border harmonics",
                            "circle tail")
    responses = []
    for pt in branch:
        sys_pt = first.system.replace(**{param: float(pt.lam)})
        u = pt.z0.reshape(points, -1)
        phi = 2 * math.pi * np.arange(points) / points
        _, _, states = shaft(u, phi, sys_pt.p)  # the map's function takes p
        w1, w2 = (2 * math.pi / float(per.seconds(model, sys_pt.structure, sys_pt.p))
                  for per in first.frequencies)
        responses.append(CircleResponse(
            system=sys_pt, frequencies=first.frequencies, circle=u, converged=True,
            iterations=pt.newton_iterations, residual=math.nan, message="", scale=first.scale,
            steps=first.steps, samples=first.samples,
            grid=regular_grid(states, u, 2 * math.pi * w2 / w1)))
    ts = responses[0].torus
    residuals = [prob.residual_norm(np.concatenate([pt.z0 / prob.s_z, [pt.lam / prob.s_lam]]))
                 for pt in branch]
    nan = np.full(len(branch), np.nan)
    values = {k: v for k, v in prob.values.items() if k != param}
    data = tori_dataset(
        ts, np.array([r.coefficients for r in responses]), [r.system.p for r in responses],
        np.array(residuals), nan, tails, nan, nan, nan, [pt.special for pt in branch],
        prob.state_scale,
        variables={param: ("point", np.array([pt.lam for pt in branch]),
                           {"units": model.units[param]}),
                   "circle": (("point", "state", "phi"),
                              np.array([r.circle.T for r in responses])),
                   "newton_iterations": ("point", np.array([pt.newton_iterations
                                                            for pt in branch])),
                   "ds": ("point", np.array([pt.ds for pt in branch]))},
        param=param, param_scale=prob.s_lam, status=status, stop_report=report,
        last_converged=float(branch[-1].lam), points=points, steps=first.steps)
    data = data.assign_coords(phi=("phi", 2 * np.pi * np.arange(points) / points,
                                   {"units": "rad"}))
    data.attrs.update(values)
    data.attrs.pop(param, None)
    data.attrs["method"] = ("invariant circle of the shaft-period map (quasi-periodic "
                            "shooting), continued; lambda1 not computed")
    data.attrs["solver"] = "shooting"
    return data


class _TailGuard:
    """The branch problem, whose ``residual`` reports no convergence (non-finite G) once a
    corrected circle's tail exceeds the limit, so the branch stops there with a status."""

    def __init__(self, prob: CircleBranchProblem) -> None:
        self._prob = prob
        self.stopped = ""

    def __getattr__(self, name):
        return getattr(self._prob, name)

    def residual(self, w):
        g, jac, mono = self._prob.residual(w)
        if self.stopped:
            return g * np.nan, jac, mono
        if np.max(np.abs(g)) < 1e-6:
            tail = self._prob.tail(self._prob.circle(w))
            if tail > self._prob.tail_limit:
                lam = w[-1] * self._prob.s_lam
                self.stopped = (f"stopped: the circle's Fourier tail {tail:.2e} exceeds "
                                f"{self._prob.tail_limit:g} at {self._prob.param_name} = "
                                f"{lam:.8g} (the circle is no longer resolved by its "
                                f"{self._prob.shaft.points} points)")
                return g * np.nan, jac, mono
        return g, jac, mono
