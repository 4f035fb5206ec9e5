"""One periodic response by harmonic balance: the guess, Newton, Hill's stability and the
convergence in the number of harmonics.

``harmonic_balance`` solves R(X) = 0 (``analysis.frequency.periodic.harmonic``) by Newton's method
with a dense solve and a backtracking line search, in scaled unknowns: the coefficients of
state i divided by its scale s_i (``periodic.state_scale`` of the response: positions by
their largest value, velocities at least that times 2π/T) and its residual by ω·s_i, so the
residual is dimensionless and comparable with shooting's. The guess is the response of a
settled simulation (the state after about the spec's transient, at a whole number of
periods, then one more period sampled on the AFT grid and projected by FFT), as
``periodic.default_guess`` does for shooting. Stability is Hill's method
(``analysis.frequency.periodic.hill``) on the converged Jacobian.

``harmonic_convergence`` solves again with 2H harmonics (and the samples that go with them)
from the solution padded with zeros, and reports the residual of the H solution in the 2H
equations and the largest change of any state over the period, in units of its scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.periodic.harmonic import (
    HarmonicSystem,
    blas_threads,
    check_forced,
    check_harmonics,
    resize,
)
from analysis.frequency.periodic.hill import SORTS, HillResult, hill_stability
from analysis.integrate.flow import Period, period_seconds, steps_per_period
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import BallCounts, Model, System, as_system
from analysis.provenance import run_attrs
from analysis.stability.periodic import (
    STABILITY_MARGIN,
    as_period,
    commensurate,
    default_guess,
    state_scale,
)

DENSE_POINTS = 1024
"""Fewest phases per period on which amplitudes and changes of a response are measured."""


@dataclass
class PeriodicResponse:
    """A periodic response by harmonic balance. Coefficients harmonic-major
    (``harmonic.HarmonicSystem``), the states' units; times in s."""

    system: System = field(repr=False)
    period: str
    period_s: float
    harmonics: int
    samples: int
    coefficients: np.ndarray
    converged: bool
    iterations: int
    residual: float
    """Largest |R_i| / (ω s_i) at the solution (dimensionless)."""
    message: str
    scale: np.ndarray
    """Scale s_i of each state (its unit) in the unknowns and the residual."""
    exponents: np.ndarray = field(default_factory=lambda: np.array([]))
    """Hill's Floquet exponents (1/s, complex), empty without stability."""
    multipliers: np.ndarray = field(default_factory=lambda: np.array([]))
    """e^{λT} of the exponents."""
    jacobian: np.ndarray | None = field(default=None, repr=False)

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.system.state_names

    @property
    def n_state(self) -> int:
        return self.system.n_state

    def states(self, points: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(t: points, z: points × n) over one period from t = 0 (s, the states' units);
        default max(N, ``DENSE_POINTS``) points."""
        points = max(self.samples, DENSE_POINTS) if points is None else int(points)
        hs = HarmonicSystem(self.system, Period.parse(self.period) if isinstance(
            self.period, str) else self.period, self.harmonics, self.samples)
        return np.arange(points) * self.period_s / points, hs.sample(self.coefficients, points)

    def amplitude(self) -> dict[str, float]:
        """(max − min)/2 of each state over the period, its unit."""
        _, z = self.states()
        return dict(zip(self.state_names, (np.ptp(z, axis=0) / 2).tolist(), strict=True))

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else math.nan

    @property
    def stability(self) -> str:
        """'stable', 'unstable', 'marginal' (within ``STABILITY_MARGIN`` of the circle) or
        'unknown' (no stability computed)."""
        r = self.spectral_radius
        if not math.isfinite(r):
            return "unknown"
        if r < 1 - STABILITY_MARGIN:
            return "stable"
        return "unstable" if r > 1 + STABILITY_MARGIN else "marginal"

    def as_dict(self) -> dict:
        return {"model": self.system.model.name, "period": self.period,
                "period_s": self.period_s, "harmonics": self.harmonics,
                "samples": self.samples, "converged": self.converged,
                "iterations": self.iterations, "residual": self.residual,
                "message": self.message, "amplitude": self.amplitude(),
                "exponents_real": self.exponents.real.tolist(),
                "exponents_imag": self.exponents.imag.tolist(),
                "multipliers_real": self.multipliers.real.tolist(),
                "multipliers_imag": self.multipliers.imag.tolist(),
                "stability": self.stability}


def prepare(system: System, period: str | Period | None) -> tuple[System, Period]:
    """The System and its ``Period`` (``periodic.as_period``; ``ratio:p/q`` made exact by
    ``periodic.commensurate``), the model checked to be forced."""
    per = as_period(system.model, period)
    if per.kind == "ratio":
        system = system.replace(**commensurate(system.model, system.structure,
                                               dict(system.parameters), per.ratio))
    check_forced(system)
    period_seconds(system.model, system.structure, per, dict(system.parameters))
    return system, per


def simulated_guess(hs: HarmonicSystem, settle: float | None = None,
                    dt: float | None = None) -> np.ndarray:
    """Coefficients (harmonic-major) of the response of a settled simulation: the state
    after about ``settle`` s (``periodic.default_guess``) at phase 0, then one period of
    RK4 steps of at most ``dt`` (s; default the spec's) sampled on the N AFT phases."""
    system, per = hs.system, hs.period
    step = RunPlan.step(system, dt).dt
    z0, _ = default_guess(system, per, settle, step)
    values = dict(system.parameters)
    period_s = period_seconds(system.model, system.structure, per, values)
    per_sample = max(1, math.ceil(steps_per_period(system.model, system.structure, per,
                                                   values, step) / hs.samples))
    steps = per_sample * hs.samples
    run = simulate(system.replace(state=z0), duration=period_s, transient=0.0,
                   dt=period_s / steps, save_every=per_sample)
    z = np.column_stack([run[name].values[:hs.samples] for name in system.state_names])
    return hs.coefficients(z)


def response_scale(hs: HarmonicSystem, coeffs: np.ndarray, period_s: float) -> np.ndarray:
    """``periodic.state_scale`` of the largest |z_i| over the period of the response."""
    z = hs.sample(coeffs, max(hs.samples, DENSE_POINTS))
    return state_scale(np.abs(z).max(axis=0), period_s, hs.system.model.module.STATE_UNITS)


def newton_solve(hs: HarmonicSystem, coeffs: np.ndarray, p: np.ndarray, scale: np.ndarray,
                 tol: float, max_iter: int) -> tuple[np.ndarray, np.ndarray, int, float, bool,
                                                     str]:
    """Newton with backtracking on the scaled residual from ``coeffs``: (coefficients,
    Jacobian ∂R/∂X at them, iterations, scaled residual, converged, message)."""
    omega = 2 * math.pi / hs.period_s(p)
    sx = np.tile(scale, hs.size // hs.n)  # 2H + 1 columns (M of a torus)
    x = np.asarray(coeffs, dtype=float).copy()

    def scaled(xx):
        r, jac, _ = hs.evaluate(xx, p)
        return r / (omega * sx), jac

    g, jac = scaled(x)
    res = float(np.max(np.abs(g)))
    for it in range(max_iter):
        if not np.all(np.isfinite(g)):
            return x, jac, it, math.inf, False, "the residual is not finite (a diverging guess)"
        if res < tol:
            return x, jac, it, res, True, f"converged in {it} Newton iterations"
        try:
            step = np.linalg.solve(jac * (sx[None, :] / (omega * sx[:, None])), -g)
        except np.linalg.LinAlgError:
            return x, jac, it, res, False, "singular Newton matrix (a multiplier at +1?)"
        lam, norm = 1.0, float(np.linalg.norm(g))
        while lam > 1e-4:
            trial = x + lam * step * sx
            g_t, jac_t = scaled(trial)
            if np.all(np.isfinite(g_t)) and np.linalg.norm(g_t) < norm:
                break
            lam /= 2
        else:
            return x, jac, it, res, False, (f"Newton stalled at scaled residual {res:.2e} "
                                            "(no response near the guess, or too few "
                                            "harmonics)")
        x, g, jac = trial, g_t, jac_t
        res = float(np.max(np.abs(g)))
    ok = res < tol
    return x, jac, max_iter, res, ok, ("converged" if ok else
                                       f"no convergence in {max_iter} iterations (scaled "
                                       f"residual {res:.2e})")


def harmonic_balance(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    period: str | Period | None = None,
    harmonics: int = 10,
    *,
    samples: int | None = None,
    guess: np.ndarray | None = None,
    dt: float | None = None,
    settle: float | None = None,
    tol: float = 1e-10,
    max_iter: int = 40,
    stability: bool = True,
    sort: str = "centroid",
    **parameters: float,
) -> PeriodicResponse:
    """The periodic response of period ``period`` by harmonic balance with ``harmonics``
    H harmonics of ω = 2π/T, and its Floquet multipliers by Hill's method.

    ``system``: a ``System`` or a model completed by ``n_balls`` and ``**parameters`` (SI,
    speed in rpm). ``period``: as in ``periodic.shoot`` (``vc``, ``shaft``, ``vc[name]``,
    ``param:NAME``, ``shaft:k`` for a subharmonic response …; None: the model's default).
    ``samples``: AFT time samples N (default ``harmonic.fast_samples``). ``guess``:
    harmonic-major coefficients of any number of harmonics (cut or padded), else those of a
    settled simulation (``simulated_guess``: about ``settle`` s, RK4 steps of at most
    ``dt`` s). ``tol`` bounds the scaled residual max|R_i|/(ω s_i). ``sort``: Hill's
    eigenvalue sorting (``hill.SORTS``). A solve that does not converge is returned with
    ``converged`` False and its message, never raised.

    >>> r = harmonic_balance("duffing", None, "shaft", 7, linear_stiffness=1.0,
    ...                      cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3,
    ...                      speed_rpm=12.0)
    >>> r.converged, r.stability
    (True, 'stable')
    """
    if sort not in SORTS:
        raise InputError(f"sort: must be one of {', '.join(SORTS)}, got {sort!r}")
    system = as_system(system, n_balls, **parameters)
    check_harmonics(harmonics, system.n_state)
    system, per = prepare(system, period)
    hs = HarmonicSystem(system, per, harmonics, samples)
    p = system.p
    period_s = hs.period_s(p)
    if guess is None:
        coeffs = simulated_guess(hs, settle, dt)
    else:
        coeffs = resize(np.asarray(guess, dtype=float), system.n_state, hs.harmonics)
    scale = response_scale(hs, coeffs, period_s)
    with blas_threads():
        x, jac, iters, res, ok, msg = newton_solve(hs, coeffs, p, scale, tol, max_iter)
    response = PeriodicResponse(system=system, period=str(per), period_s=period_s,
                                harmonics=hs.harmonics, samples=hs.samples, coefficients=x,
                                converged=ok, iterations=iters, residual=res, message=msg,
                                scale=response_scale(hs, x, period_s) if ok else scale,
                                jacobian=jac)
    if stability and ok:
        with blas_threads():
            hill = hill_of(response, sort)
        response.exponents, response.multipliers = hill.exponents, hill.multipliers
    return response


def hill_of(response: PeriodicResponse, sort: str = "centroid") -> HillResult:
    """Hill's exponents and multipliers of a solved response (its Jacobian)."""
    return hill_stability(response.jacobian, response.n_state, response.harmonics,
                          response.period_s, sort, response.scale)


def harmonic_convergence(response: PeriodicResponse, factor: int = 2) -> dict[str, float]:
    """How the response moves when H grows ``factor`` times (N with it): solved again from
    the padded coefficients. Returns ``harmonics`` (H), ``harmonics_more`` (factor·H),
    ``residual`` (the H solution's), ``residual_in_more`` (the H solution, padded, in the
    factor·H equations), ``residual_more`` (the factor·H solution's) and ``change`` (the
    largest |z_i(t) change| over the period in units of s_i), with ``converged_more``."""
    hs = HarmonicSystem(response.system, Period.parse(response.period),
                        factor * response.harmonics, None)
    padded = resize(response.coefficients, response.n_state, hs.harmonics)
    r, _, _ = hs.evaluate(padded, response.system.p)
    omega = 2 * math.pi / response.period_s
    in_more = float(np.max(np.abs(r / (omega * np.tile(response.scale,
                                                       2 * hs.harmonics + 1)))))
    # at least one Newton step: solved below the padded solution's own residual
    more = harmonic_balance(response.system, None, response.period, hs.harmonics,
                            guess=padded, stability=False, tol=max(1e-14, 1e-3 * in_more))
    points = max(more.samples, DENSE_POINTS)
    _, z_h = response.states(points)
    _, z_more = more.states(points)
    return {"harmonics": response.harmonics, "harmonics_more": more.harmonics,
            "residual": response.residual,
            "residual_in_more": in_more,
            "residual_more": more.residual, "converged_more": more.converged,
            "change": float(np.max(np.abs(z_h - z_more) / response.scale[None, :]))}


def responses_dataset(system: System, period: str, harmonics: int, samples: int,
                      coefficients: np.ndarray, multipliers: np.ndarray,
                      residuals: np.ndarray, specials: list[str], state_scale: np.ndarray,
                      variables: dict | None = None, **extra: object) -> xr.Dataset:
    """Responses as a Dataset along ``point``: ``amplitude`` ((max − min)/2 of each state
    over the period, point × state, the states' units: coordinate ``state_units``),
    ``stable`` (Hill: every |μ| < 1 − ``STABILITY_MARGIN``), ``special`` (LP, PD, BP, NS,
    'grazing?' or ''), ``residual`` (max |R_i| / (ω s_i)), ``coefficients`` (point ×
    harmonic × state: c0, a1, b1, …), Hill's multipliers (real, imaginary, modulus; dim
    ``k``), ``state_scale``, and ``variables`` (name -> (dims, values[, attrs])); attrs:
    ``run_attrs`` of ``system`` (model, spec, balls, parameters, frequencies, versions),
    ``method``, ``period``, ``harmonics``, ``samples`` and ``extra``."""
    model = system.model
    n = system.n_state
    size = 2 * harmonics + 1
    coeffs = np.asarray(coefficients, dtype=float).reshape(-1, size, n)
    hs = HarmonicSystem(system, Period.parse(period), harmonics, samples)
    points = max(samples, DENSE_POINTS)
    amplitude = np.array([np.ptp(hs.sample(c.reshape(-1), points), axis=0) / 2
                          for c in coeffs])
    mult = np.asarray(multipliers, dtype=complex).reshape(len(coeffs), -1)
    stable = np.array([bool(m.size) and float(np.max(np.abs(m))) < 1 - STABILITY_MARGIN
                       for m in mult], dtype=int)
    attrs = run_attrs(model, system.structure, dict(system.parameters))
    attrs.update(method="harmonic balance (AFT), Hill stability", period=period,
                 harmonics=harmonics, samples=samples, **extra)
    units = model.state_units
    names = ["c0"] + [f"{kind}{k}" for k in range(1, harmonics + 1) for kind in ("a", "b")]
    data = {
        "amplitude": (("point", "state"), amplitude,
                      {"long_name": "(max - min)/2 of each state over one period, in the "
                                    "state's unit (coordinate state_units)"}),
        "stable": ("point", stable),
        "special": ("point", np.array(specials, dtype=object)),
        "residual": ("point", np.asarray(residuals, dtype=float),
                     {"long_name": "max |R_i| / (omega s_i) of the harmonic-balance "
                                   "equations"}),
        "coefficients": (("point", "harmonic", "state"), coeffs,
                         {"long_name": "Fourier coefficients: c0 + sum_k a_k cos(k w t) + "
                                       "b_k sin(k w t), w = 2 pi / T, t from 0 s"}),
        "multiplier_real": (("point", "k"), mult.real),
        "multiplier_imag": (("point", "k"), mult.imag),
        "multiplier_abs": (("point", "k"), np.abs(mult)),
        "state_scale": ("state", np.asarray(state_scale, dtype=float),
                        {"long_name": "scale of each state in the unknowns"}),
        **(variables or {})}
    return xr.Dataset(data, coords={
        "point": np.arange(len(coeffs)), "state": list(model.state_names),
        "state_units": ("state", [units[s] for s in model.state_names]),
        "harmonic": names, "k": np.arange(1, n + 1)}, attrs=attrs)


def response_dataset(response: PeriodicResponse) -> xr.Dataset:
    """One response as the Dataset of ``responses_dataset`` (one point, no parameter),
    with attrs ``period_s`` (s), ``converged``, ``iterations`` and ``message``."""
    return responses_dataset(
        response.system, response.period, response.harmonics, response.samples,
        response.coefficients[None, :], response.multipliers[None, :],
        np.array([response.residual]), [""], response.scale, period_s=response.period_s,
        converged=int(response.converged), iterations=response.iterations,
        message=response.message)
