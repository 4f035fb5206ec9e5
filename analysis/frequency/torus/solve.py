"""One quasi-periodic response (a 2-torus) by harmonic balance: the guess, Newton, its
truncation measures, its largest Lyapunov exponent, and its time series at any t.

``solve_torus`` solves the torus equations of ``analysis.frequency.torus.equations`` by the same
Newton as periodic harmonic balance (``solve.newton_solve``: dense solve, backtracking, the
residual of state i scaled by ω1·s_i). The guess is the least-squares fit of the series to
a settled simulation (``TorusSystem.fit``: the states of ``simulate`` after about the
spec's transient, over ``fit_duration`` s), since on a torus no single period exists to
sample. Its stability is λ1 of the trajectory started on the torus at t = 0 (the state
u(0, 0)), by ``analysis.stability.lyapunov`` (the tangent dynamics of the model itself, not
of the truncated series): λ1 < 0 an attracting torus (stable), λ1 > 0 not.

Two measures tell how well H1, H2 resolve the torus (the residual at the N1 × N2 samples is
zero to Newton's tolerance whatever H): ``residual_fine``, the scaled residual of the same
coefficients on a grid twice as fine in each hyper-time (aliasing and the force the series
cannot hold), and ``tail``, the largest amplitude of a harmonic on the border of the set
(|k1| = H1 or |k2| = H2) relative to the largest of any non-constant harmonic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.frequency.periodic.harmonic import blas_threads, check_forced
from analysis.frequency.periodic.solve import newton_solve
from analysis.frequency.torus.equations import (
    TorusSystem,
    check_frequencies,
    check_phases,
    check_torus_harmonics,
    parse_frequencies,
    resize_torus,
)
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.periodic import state_scale

FIT_SAMPLES = 6000
"""Simulated states the guess's least-squares fit uses (at most)."""


@dataclass
class TorusResponse:
    """A quasi-periodic response by torus harmonic balance. Coefficients harmonic-major
    (``torus.TorusSystem``), the states' units; times s, frequencies rad/s."""

    torus: TorusSystem = field(repr=False)
    coefficients: np.ndarray
    converged: bool
    iterations: int
    residual: float
    """Largest |R_i| / (ω1 s_i) at the solution on the N1 × N2 grid."""
    message: str
    scale: np.ndarray
    residual_fine: float = math.nan
    tail: float = math.nan
    lambda1: float = math.nan
    """Largest Lyapunov exponent (1/s) of the trajectory started on the torus (NaN: not
    computed)."""
    lambda1_ci95: float = math.nan
    drift: float = math.nan
    """``torus_drift`` over the λ1 run's length (NaN: not computed)."""
    jacobian: np.ndarray | None = field(default=None, repr=False)

    @property
    def system(self) -> System:
        return self.torus.system

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.system.state_names

    def states(self, t: np.ndarray) -> np.ndarray:
        """z(t) = u(ω1 t, ω2 t) (len(t) × n) at the times ``t`` (s)."""
        return self.torus.at_times(self.coefficients, t)

    def amplitude(self) -> dict[str, float]:
        """(max − min)/2 of each state over the N1 × N2 grid (its unit)."""
        z = self.torus.on_grid(self.coefficients).reshape(-1, self.torus.n)
        return dict(zip(self.state_names, (np.ptp(z, axis=0) / 2).tolist(), strict=True))

    @property
    def stability(self) -> str:
        """``stability_of`` λ1, its half-width and the drift."""
        return stability_of(self.lambda1, self.lambda1_ci95, self.drift)


DRIFT_LIMIT = 1.0
"""Largest ``torus_drift`` of a torus called stable. The trajectory from an attracting
torus ends within the series' truncation error of it (measured at N_b = 10, 5000 rpm: 0.94
at H = 6,3, 0.35 at 8,4, 0.13 at 20,10, largest over the states); beyond one amplitude it
has left the torus for another attractor, whose λ1 was measured, and the torus is called
unstable (at 7471 rpm, H = 8,4: 1.3, the trajectory ending on a torus of half the
amplitude). Below it the drift does not decide: a saddle torus within the truncation error
of an attracting one is not told apart (docs/frequency.md, Tori)."""


def stability_of(lambda1: float, ci95: float, drift: float) -> str:
    """'stable' (λ1 < 0 beyond its 95 % half-width and the trajectory stays on the torus:
    drift <= ``DRIFT_LIMIT``), 'unstable' (λ1 > 0 beyond it, or the trajectory left the
    torus), 'marginal', or 'unknown' (λ1 not computed)."""
    if not math.isfinite(lambda1):
        return "unknown"
    if math.isfinite(drift) and drift > DRIFT_LIMIT:
        return "unstable"
    ci = ci95 if math.isfinite(ci95) else 0.0
    if lambda1 + ci < 0:
        return "stable"
    return "unstable" if lambda1 - ci > 0 else "marginal"


def prepare_torus(system: System, frequencies, harmonics) -> tuple[System, tuple, tuple]:
    """The checks of a torus before any work: forced model, two base frequencies of it,
    harmonics within the memory bound, frequencies incommensurate within the harmonics."""
    check_forced(system)
    freqs = frequencies if isinstance(frequencies, tuple) and len(frequencies) == 2 and \
        not isinstance(frequencies[0], str) else parse_frequencies(frequencies, system.model)
    pair = check_torus_harmonics(harmonics, system.n_state)
    check_frequencies(system, freqs, pair)
    return system, freqs, pair


def settled_run(system: System, torus: TorusSystem, settle: float | None,
                duration: float | None, dt: float | None) -> tuple[np.ndarray, np.ndarray]:
    """(t, z) of a simulation after ``settle`` s (default the spec's transient) over
    ``duration`` s (default 30 periods of the slowest basis frequency, at least 1 s), at
    most ``FIT_SAMPLES`` states."""
    model = system.model
    settle = float(model.simulation_defaults["transient"] if settle is None else settle)
    w = [abs(v) for v in torus.basis_omegas() if abs(v) > 0]
    if duration is None:
        duration = max(1.0, 30 * 2 * math.pi / min(w))
    step = RunPlan.step(system, dt).dt
    every = max(1, round(duration / step / FIT_SAMPLES))
    run = simulate(system, duration=settle + duration, transient=settle, dt=step,
                   save_every=every)
    t = run.t.values
    return t, np.column_stack([run[name].values for name in system.state_names])


def solve_torus(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    frequencies: str | tuple = "shaft,vc",
    harmonics: tuple[int, int] | str = (8, 4),
    *,
    samples: tuple[int, int] | None = None,
    shear: int = 0,
    guess: np.ndarray | None = None,
    guess_harmonics: tuple[int, int] | None = None,
    dt: float | None = None,
    settle: float | None = None,
    fit_duration: float | None = None,
    tol: float = 1e-10,
    max_iter: int = 40,
    stability: bool = True,
    lyapunov_duration: float = 2.0,
    **parameters: float,
) -> TorusResponse:
    """The quasi-periodic response on the torus of the base frequencies ``frequencies``
    (``"F1,F2"``: ``shaft``, ``vc``, ``vc[name]``, ``param:NAME``) with ``harmonics``
    (H1, H2), and its λ1.

    ``system``: a ``System`` or a model completed by ``n_balls`` and ``**parameters`` (SI,
    speed in rpm). ``samples``: the grid (N1, N2) (default ``torus.torus_samples``).
    ``shear``: m of the harmonic set (``TorusSystem.shear``; 0: the rectangle
    |k1| ≤ H1, |k2| ≤ H2 in F1, F2). ``guess``: harmonic-major coefficients of the harmonics
    ``guess_harmonics`` (default the same), else the fit to a simulation settled for
    ``settle`` s over ``fit_duration`` s with RK4 steps of at most ``dt`` s. ``tol`` bounds
    the scaled residual max|R_i|/(ω1 s_i). ``stability``: λ1 over ``lyapunov_duration`` s
    from u(0, 0). A solve that does not converge is returned with ``converged`` False and
    its message, never raised.
    """
    system = as_system(system, n_balls, **parameters)
    system, freqs, pair = prepare_torus(system, frequencies, harmonics)
    ts = TorusSystem(system, freqs, pair, samples, int(shear))
    t, z = settled_run(system, ts, settle, fit_duration, dt)
    check_phases(system, freqs, ts.rhs, t[:: max(1, len(t) // 50)], z[:: max(1, len(t) // 50)])
    if guess is None:
        with blas_threads():
            coeffs = ts.fit(t, z)
    else:
        coeffs = resize_torus(guess, system.n_state, guess_harmonics or pair, pair)
    scale = state_scale(np.abs(z).max(axis=0), ts.period_s(system.p),
                        system.model.module.STATE_UNITS)
    with blas_threads():
        x, jac, iters, res, ok, msg = newton_solve(ts, coeffs, system.p, scale, tol, max_iter)
    response = TorusResponse(torus=ts, coefficients=x, converged=ok, iterations=iters,
                             residual=res, message=msg, scale=scale, jacobian=jac)
    if ok:
        response.residual_fine, response.tail = truncation(ts, x, scale)
        if stability:
            response.lambda1, response.lambda1_ci95 = torus_lambda1(ts, x, lyapunov_duration,
                                                                    dt)
            response.drift = torus_drift(ts, x, lyapunov_duration, dt)
    return response


def truncation(ts: TorusSystem, coeffs: np.ndarray, scale: np.ndarray,
               p: np.ndarray | None = None) -> tuple[float, float]:
    """(``residual_fine``, ``tail``) of the module docstring at the parameters ``p``."""
    p = ts.system.p if p is None else p
    fine = TorusSystem(ts.system, ts.frequencies, ts.harmonics,
                       (2 * ts.samples[0], 2 * ts.samples[1]), ts.shear)
    r = fine.residual(coeffs, p)
    unit = ts.basis_omegas(p)[0] * np.tile(scale, ts.basis.size)
    x = np.asarray(coeffs).reshape(ts.basis.size, ts.n) / scale[None, :]
    amp = np.hypot(x[1::2], x[2::2]).max(axis=1)
    border = (np.abs(ts.basis.index[:, 0]) == ts.harmonics[0]) | \
        (np.abs(ts.basis.index[:, 1]) == ts.harmonics[1])
    top = float(amp.max())
    return float(np.max(np.abs(r / unit))), float(amp[border].max() / top) if top > 0 else 0.0


def _run_from(ts: TorusSystem, coeffs: np.ndarray, dt: float | None,
              p: np.ndarray | None) -> tuple[System, np.ndarray, float]:
    """The System at parameters ``p`` (None: the torus's own), the torus's state u(0, 0)
    there and the RK4 step (s; ``dt`` None: the spec's) of a run started on it."""
    system = ts.system
    if p is not None:
        system = system.replace(**dict(zip(system.model.parameter_names, p, strict=True)))
    z0 = ts.at_times(coeffs, np.array([0.0]), system.p)[0]
    return system, z0, RunPlan.step(system, dt).dt


def torus_lambda1(ts: TorusSystem, coeffs: np.ndarray, duration: float,
                  dt: float | None = None, p: np.ndarray | None = None
                  ) -> tuple[float, float]:
    """(λ1, its 95 % half-width), 1/s, of the trajectory from u(0, 0) at t = 0
    (``lyapunov``: the model's own tangent dynamics over ``duration`` s, a tangent
    transient of a tenth of it)."""
    from analysis.stability.lyapunov import lyapunov

    if not (math.isfinite(duration) and duration > 0):
        raise InputError(f"lyapunov_duration: must be a finite number > 0 s, got {duration!r}",
                         field="lyapunov_duration")
    system, z0, step = _run_from(ts, coeffs, dt, p)
    res = lyapunov(system.replace(state=z0), duration=duration, transient=duration / 10,
                   tangent_transient=duration / 10, dt=step, n_exponents=1)
    return float(res.exponents.values[0]), float(res.ci95.values[0])


def torus_drift(ts: TorusSystem, coeffs: np.ndarray, duration: float,
                dt: float | None = None, p: np.ndarray | None = None) -> float:
    """How far the trajectory from u(0, 0) ends from the torus: the largest
    |z(t) − u(ω1 t, ω2 t)| over the last half of ``duration`` s, in units of the torus's
    amplitude ((max − min)/2 on its grid), largest over the states. About the truncation
    error of the series (``docs/frequency.md``) when the torus attracts; of the order of 1
    when the trajectory leaves it for another attractor (λ1 is then that attractor's)."""
    system, z0, step = _run_from(ts, coeffs, dt, p)
    run = simulate(system.replace(state=z0), duration=duration, transient=duration / 2,
                   dt=step, save_every=10)
    z = np.column_stack([run[name].values for name in system.state_names])
    mine = ts.at_times(coeffs, run.t.values, system.p)
    amp = np.ptp(ts.on_grid(coeffs).reshape(-1, ts.n), axis=0) / 2
    return float(np.max(np.max(np.abs(z - mine), axis=0) / np.maximum(amp, 1e-300)))
