"""Continuation of tori in a runtime parameter, and an honest report of where it stops: the
2-D HB torus family of the one engine (``analysis.stability.continuation.trace``).

The branch problem ``TorusBranchProblem`` is ``continuation.HarmonicBranchProblem`` for the
torus equations: unknowns w = (X / s_X, λ / s_λ), equations G = R(X, λ) / (ω1,0 s_i). Its
monodromy is empty (a torus has no Floquet multipliers; its stability is λ1, computed at
the converged points only), so the engine's step (Keller's bordered Newton, the same
``StepGuards`` in the same words, folds where the tangent's λ component flips) runs
unchanged, and its PD, BP and NS tests never fire.

The continuation stops at the end of the range, after ``max_points``, or when a step is
refused or fails down to ``ds_min``. Then ``torus_report`` says why, in numbers, from the
engine's ``Trace``: the last converged parameter value; the growth of the truncation
measures (``torus_solve``: ``residual_fine``, ``tail``) from the first point to the last;
the scaled residual of the predictor of the last step tried (how far the torus moved); and
λ1 along the branch (a torus whose λ1 approaches 0 loses its attraction: it breaks up or
bifurcates).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.periodic.continuation import (
    FourierBranchProblem,
    branch_variables,
    trace_from,
)
from analysis.frequency.periodic.harmonic import blas_threads
from analysis.frequency.torus.dataset import tori_dataset
from analysis.frequency.torus.equations import TorusSystem, check_frequencies
from analysis.frequency.torus.solve import (
    DRIFT_LIMIT,
    prepare_torus,
    solve_torus,
    torus_drift,
    torus_lambda1,
    truncation,
)
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
from analysis.stability.continuation.trace import Progress, Trace, stop_report


@dataclass
class TorusBranchProblem(FourierBranchProblem):
    """Tori of ``ts`` as parameter number ``param_index`` varies, the others at ``values``;
    scales ``state_scale`` (per state), ``s_lam`` (the parameter's unit) and ``omega_ref``
    (rad/s). No multipliers (an empty monodromy): λ1 is computed at the converged points."""

    ts: TorusSystem
    param_index: int
    values: dict[str, float]
    state_scale: np.ndarray
    s_lam: float
    omega_ref: float
    s_z: np.ndarray = field(init=False)
    noun = "torus"

    def __post_init__(self) -> None:
        self.s_z = np.tile(self.state_scale, self.ts.basis.size)

    @property
    def equations(self) -> TorusSystem:
        return self.ts

    def monodromy(self, jacobian: np.ndarray, p: np.ndarray) -> np.ndarray:
        return np.zeros((0, 0))

    def describe(self, point: BranchPoint) -> str:
        return f"{self.param_name} = {point.lam:.6g}"

    def amplitude(self, w: np.ndarray) -> float:
        """(max − min)/2 of the first state over the grid (its unit)."""
        z = self.ts.on_grid(w[:-1] * self.s_z)[..., 0]
        return float(np.ptp(z) / 2)


def continue_torus(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    param: str,
    start: float,
    stop: float,
    frequencies: str | tuple = "shaft,vc",
    harmonics: tuple[int, int] | str = (8, 4),
    samples: tuple[int, int] | None = None,
    shear: int = 0,
    dt: float | None = None,
    settle: float | None = None,
    stability: bool = True,
    lyapunov_duration: float = 2.0,
    stability_every: int = 1,
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
    """Continue the torus of ``frequencies`` with ``harmonics`` in ``param`` from ``start``
    towards ``stop`` (the parameter's unit); λ1 and the drift (``torus_solve``) with
    ``stability``, ``lyapunov_duration`` s each, at every ``stability_every``-th point and
    the last (NaN between). The first torus is ``solve_torus`` at ``start``.
    ``options`` and its keywords as in ``continue_harmonic``. Returns the branch Dataset
    (``tori_dataset`` with the parameter along ``point``) whose attrs ``status`` and
    ``stop_report`` say where and why it stopped."""
    options = options_with(options, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol, guards=guards)
    if isinstance(stability_every, bool) or not isinstance(stability_every, int) or \
            stability_every < 1:
        raise InputError(f"stability_every: must be a whole number >= 1, got "
                         f"{stability_every!r}", field="stability_every")
    system = as_system(system, n_balls, **parameters)
    model = system.model
    span = ContinuedRange.check(model, param, start, stop)
    system = system.replace(**{param: start})
    system, freqs, pair = prepare_torus(system, frequencies, harmonics)
    check_frequencies(system, freqs, pair, system.replace(**{param: stop}).p)
    first = solve_torus(system, None, freqs, pair, samples=samples, shear=shear, dt=dt,
                        settle=settle, stability=False)
    if not first.converged:
        raise InputError(f"start: no torus found at {param} = {start:g} ({first.message})")
    ts = first.torus
    prob = TorusBranchProblem(ts, span.index, dict(first.system.parameters), first.scale,
                              span.scale, ts.basis_omegas()[0])
    with blas_threads():
        out = trace_from(prob, first.coefficients, stop, options, progress=progress)
    branch = out.points
    lam1 = np.full((len(branch), 3), np.nan)
    fine = np.array([truncation(ts, pt.z0, prob.state_scale, prob.p(pt.lam)) for pt in branch])
    if stability:
        for j, pt in enumerate(branch):
            if j % stability_every and j != len(branch) - 1:
                continue
            lam1[j, :2] = torus_lambda1(ts, pt.z0, lyapunov_duration, dt, prob.p(pt.lam))
            lam1[j, 2] = torus_drift(ts, pt.z0, lyapunov_duration, dt, prob.p(pt.lam))
            if progress:
                progress(f"lambda1 at {param} = {pt.lam:.6g}: {lam1[j, 0]:.4g} 1/s, drift "
                         f"{lam1[j, 2]:.3g}")
    residuals = [prob.residual_norm(prob.unknowns(pt))
                 for pt in branch]
    report = torus_report(prob, out, fine, lam1[:, 0], lam1[:, 2])
    values = {k: v for k, v in prob.values.items() if k != param}
    data = tori_dataset(
        ts, np.array([pt.z0 for pt in branch]), [prob.p(pt.lam) for pt in branch],
        np.array(residuals), fine[:, 0], fine[:, 1], lam1[:, 0], lam1[:, 1], lam1[:, 2],
        [pt.special for pt in branch], prob.state_scale,
        variables=branch_variables(prob, branch),
        param=param, param_scale=prob.s_lam, status=out.status, stop_report=report,
        last_converged=float(branch[-1].lam))
    data.attrs.update({k: v for k, v in values.items()})
    data.attrs.pop(param, None)
    return data


def tried_residual(prob: ContinuedParameter, out: Trace) -> list[str]:
    """The scaled residual of the last predictor tried, as a report measure (none when no
    step failed)."""
    if out.last_tried is None:
        return []
    return [f"the last predictor tried had scaled residual "
            f"{prob.residual_norm(out.last_tried):.2e}"]


def torus_report(prob: TorusBranchProblem, out: Trace, fine: np.ndarray,
                 lambda1: np.ndarray, drift: np.ndarray | None = None) -> str:
    """Where and why the branch stopped, in one paragraph of numbers (``fine``: the
    truncation measures per point; ``drift``: of the trajectories from the tori,
    ``torus_solve.torus_drift``)."""
    measures = [f"Truncation: residual on the finer grid {fine[0, 0]:.2e} -> "
                f"{fine[-1, 0]:.2e} (x{fine[-1, 0] / fine[0, 0]:.3g}), border harmonics "
                f"{fine[0, 1]:.3g} -> {fine[-1, 1]:.3g} of the largest"]
    measures += tried_residual(prob, out)
    if np.isfinite(lambda1).any():
        good = lambda1[np.isfinite(lambda1)]
        measures.append(f"lambda1 {good[0]:.4g} -> {good[-1]:.4g} 1/s" +
                        (" (no longer attracting)" if good[-1] >= 0 else ""))
    if drift is not None and np.isfinite(drift).any():
        left = int(np.sum(drift > DRIFT_LIMIT))
        measures.append(f"the trajectory from the torus left it (drift > {DRIFT_LIMIT:g}) "
                        f"at {left} of {int(np.isfinite(drift).sum())} points")
    growth = fine[-1, 0] / fine[0, 0]
    why = ("the torus outgrew its harmonics (the finer-grid residual grew "
           f"{growth:.3g} times)" if growth > 10 or fine[-1, 1] > 0.3 else
           "Newton found no torus near the predictor although the harmonics still "
           "resolve the last one: the torus turns sharply, loses smoothness or "
           "ceases to exist there")
    if np.isfinite(lambda1).any() and lambda1[np.isfinite(lambda1)][-1] >= 0:
        why += "; it had lost its attraction (lambda1 >= 0)"
    return stop_report(out, prob, prob.noun, prob.model.units[prob.param_name], measures,
                       why)
