"""Continuation of the invariant circle of the shaft map (``invariant_circle``) in a runtime
parameter: the circle family of the one engine (``analysis.stability.continuation.trace``),
with an honest report of where it stops.

``CircleBranchProblem``: unknowns w = (U / s_U, λ / s_λ) (U the circle, point-major),
equations G = F(U, λ) / s_U with F = P(U) − (R_ρ(λ) ⊗ I) U. Its Jacobian is exact: ∂P/∂U
and ∂P/∂λ are carried through the RK4 (``ShaftMap.along``: the step h = T1(λ)/steps and
the phases' dependence included), and ∂R_ρ/∂λ = ∂R/∂ρ · ∂ρ/∂λ (``shift_derivative``, ρ by
AD). Its monodromy is empty, so the engine's step (Keller's bordered Newton, the
``StepGuards``, folds) runs as for the HB torus. Its ``accept`` hook stops the branch when a
corrected circle's Fourier tail (``circle.solve.TAIL_FRACTION``) grows beyond
``tail_limit``: the circle is no longer resolved by its N points (it loses smoothness).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.circle.solve import (
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
from analysis.frequency.periodic.continuation import branch_variables, trace_from
from analysis.frequency.periodic.harmonic import blas_threads
from analysis.frequency.torus.continuation import tried_residual
from analysis.frequency.torus.dataset import tori_dataset
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.continuation.options import ContinuationOptions, options_with
from analysis.stability.continuation.problem import (
    BranchPoint,
    ContinuedParameter,
    ContinuedRange,
)
from analysis.stability.continuation.trace import Hooks, Progress, Trace, stop_report

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
    tangent_method = "bordered"
    noun = "circle"

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

    def describe(self, point: BranchPoint) -> str:
        return f"{self.param_name} = {point.lam:.6g}"

    def too_rough(self, point: BranchPoint) -> str | None:
        """The ``accept`` hook: why the circle of ``point`` is not kept (its Fourier tail
        beyond ``tail_limit``), else None."""
        tail = self.tail(point.z0.reshape(self.shaft.points, -1))
        if tail <= self.tail_limit:
            return None
        return (f"the circle's Fourier tail {tail:.2e} exceeds {self.tail_limit:g} (the "
                f"circle is no longer resolved by its {self.shaft.points} points)")

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
    span = ContinuedRange.check(model, param, start, stop)
    system = system.replace(**{param: start})
    first = solve_circle(system, None, frequencies, points, dt=dt, settle=settle,
                         convergence=False, stability=False)
    if not first.converged:
        raise InputError(f"start: no invariant circle found at {param} = {start:g} "
                         f"({first.message})")
    shaft = ShaftMap(first.system, first.frequencies, first.steps, first.samples,
                     first.points)
    prob = CircleBranchProblem(shaft, span.index, dict(first.system.parameters), first.scale,
                               span.scale, tail_limit)
    if prob.tail(first.circle) > tail_limit:
        raise InputError(f"points: the circle at {param} = {start:g} has a Fourier tail "
                         f"{prob.tail(first.circle):.2e} above tail_limit = {tail_limit:g}; "
                         "give more points", field="points")
    with blas_threads():
        out = trace_from(prob, first.circle.reshape(-1), stop, options,
                         hooks=Hooks(accept=prob.too_rough), progress=progress)
    branch = out.points
    tails = np.array([prob.tail(pt.z0.reshape(points, -1)) for pt in branch])
    report = circle_report(prob, out, tails)
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
    residuals = [prob.residual_norm(prob.unknowns(pt))
                 for pt in branch]
    nan = np.full(len(branch), np.nan)
    values = {k: v for k, v in prob.values.items() if k != param}
    data = tori_dataset(
        ts, np.array([r.coefficients for r in responses]), [r.system.p for r in responses],
        np.array(residuals), nan, tails, nan, nan, nan, [pt.special for pt in branch],
        prob.state_scale,
        variables={**branch_variables(prob, branch),
                   "circle": (("point", "state", "phi"),
                              np.array([r.circle.T for r in responses]))},
        param=param, param_scale=prob.s_lam, status=out.status, stop_report=report,
        last_converged=float(branch[-1].lam), points=points, steps=first.steps)
    data = data.assign_coords(phi=("phi", 2 * np.pi * np.arange(points) / points,
                                   {"units": "rad"}))
    data.attrs.update(values)
    data.attrs.pop(param, None)
    data.attrs["method"] = ("invariant circle of the shaft-period map (quasi-periodic "
                            "shooting), continued; lambda1 not computed")
    data.attrs["solver"] = "shooting"
    data.attrs["series"] = ("the 2-D series and amplitude interpolate each circle's N1 x N "
                            "grid between its shaft phases (about 2e-3 of the amplitude low at "
                            "N_b = 10, 5000 rpm); one circle's amplitude is integrated")
    data.amplitude.attrs["long_name"] = ("(max - min)/2 of each state over the interpolated "
                                         "N1 x N grid of each circle (not integrated: about "
                                         "2e-3 low), in the state's unit")
    return data


def circle_report(prob: CircleBranchProblem, out: Trace, tails: np.ndarray) -> str:
    """Where and why the circle branch stopped, in one paragraph of numbers (``tails``: the
    circle's Fourier tail per point)."""
    measures = [f"Truncation: circle tail {tails[0]:.3g} -> {tails[-1]:.3g} of the largest"]
    why = ("the circle outgrew its points (its tail reached "
           f"{tails[-1]:.3g} of the largest)" if tails[-1] > 0.3 else
           "Newton found no circle near the predictor although its points still resolve "
           "the last one: the torus turns sharply, loses smoothness or ceases to exist "
           "there")
    return stop_report(out, prob, prob.noun, prob.model.units[prob.param_name],
                       measures + tried_residual(prob, out), why)
