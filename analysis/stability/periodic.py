"""Periodic orbits by shooting, and their Floquet multipliers.

A periodic orbit of period T solves Φ_T(z0, t0) = z0, where Φ_T is the fixed-step RK4 map over
one forcing period (``analysis.integrate.flow``). Newton's method needs ∂Φ_T/∂z0, the monodromy
matrix, which CasADi computes by AD through the integrator. Its eigenvalues are the Floquet
multipliers: the orbit is stable when all lie inside the unit circle.

*Single shooting* iterates on z0 alone; *multiple shooting* splits the period into m segments
with their own initial states and continuity conditions, which keeps Newton's linear systems
well conditioned when the flow over a whole period stretches strongly.

Non-smoothness: the Hertz contact force has a discontinuous second derivative where a ball
meets the race. The monodromy matrix is still well defined (the force is C¹), but Newton's
convergence degrades from quadratic to linear when the orbit grazes a contact (δ ≈ 0 at some
ball): a non-converged solve is reported as such in the result, never as an exception.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from analysis.errors import InputError
from analysis.integrate.flow import Period, evaluate, flow_map, period_seconds, steps_per_period
from analysis.integrate.simulate import simulate, state_at
from analysis.model import Model, load_model

STABILITY_MARGIN = 1e-6
"""|μ| below 1 − margin counts as stable; within the margin the verdict is 'marginal'."""


@dataclass
class PeriodicOrbit:
    """Result of a shooting solve. States in m and m/s, times in s."""

    model: str
    n_balls: int
    period: str
    period_s: float
    t0: float
    z0: np.ndarray
    monodromy: np.ndarray
    multipliers: np.ndarray
    converged: bool
    iterations: int
    residual: float
    """Scaled norm of Φ_T(z0) − z0 at the returned z0 (dimensionless)."""
    message: str
    values: dict[str, float] = field(default_factory=dict)
    n_steps: int = 0

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    @property
    def stability(self) -> str:
        """'stable', 'unstable' or 'marginal' (a multiplier on the unit circle)."""
        r = self.spectral_radius
        if r < 1 - STABILITY_MARGIN:
            return "stable"
        return "unstable" if r > 1 + STABILITY_MARGIN else "marginal"

    def as_dict(self) -> dict:
        return {
            "model": self.model, "n_balls": self.n_balls, "period": self.period,
            "period_s": self.period_s, "t0": self.t0, "z0": self.z0.tolist(),
            "converged": self.converged, "iterations": self.iterations,
            "residual": self.residual, "message": self.message,
            "multipliers_real": self.multipliers.real.tolist(),
            "multipliers_imag": self.multipliers.imag.tolist(),
            "multipliers_abs": np.abs(self.multipliers).tolist(),
            "stability": self.stability, "n_steps": self.n_steps,
        }


def state_scale(z: np.ndarray, period_s: float) -> np.ndarray:
    """Per-component scale for residuals: displacement size, and size·2π/T for velocities."""
    pos = max(float(np.max(np.abs(z[:2]))), 1e-300)
    vel = max(float(np.max(np.abs(z[2:]))), pos * 2 * math.pi / period_s)
    return np.array([pos, pos, vel, vel])


def commensurate(model: Model, n_balls: int, values: dict[str, float],
                 ratio: Fraction) -> dict[str, float]:
    """Parameters with the outer race diameter adjusted so that VC/X equals ``ratio`` exactly.

    With unbalance the forcing has the frequencies X and VC = N_b·ρ·X (ρ = D_i/(D_i + D_o),
    paper Eq. 1), in general incommensurate; a periodic orbit exists only for a rational
    ρ·N_b = p/q. The returned values differ from ``values`` in ``outer_race_diameter`` only.
    """
    if "outer_race_diameter" not in values or "inner_race_diameter" not in values:
        raise InputError("period: ratio:p/q needs a model with race-diameter cage kinematics")
    rho = float(ratio) / n_balls
    if not 0 < rho < 1:
        raise InputError(f"period: ratio {ratio} gives a cage/shaft ratio {rho:g} outside (0, 1)")
    adjusted = dict(values)
    adjusted["outer_race_diameter"] = values["inner_race_diameter"] * (1 - rho) / rho
    return adjusted


def _prepare(model: Model | str, n_balls: int | None, period: str | Period,
             values: dict[str, float]) -> tuple[Model, int, Period, dict[str, float]]:
    model = load_model(model) if isinstance(model, str) else model
    n = model.check_n_balls(n_balls)
    per = period if isinstance(period, Period) else Period.parse(period)
    if per.kind == "ratio":
        values = commensurate(model, n, values, per.ratio)
    return model, n, per, values


def default_guess(model: Model, n_balls: int, per: Period, values: dict[str, float],
                  settle: float, dt: float) -> tuple[np.ndarray, float]:
    """The state after simulating about ``settle`` seconds, taken at a whole number n of
    periods, and the section time 0: the system is T-periodic, so the state at t = nT is a
    state at forcing phase 0 (keeping t0 = nT would make the section phase depend on T)."""
    period_s = period_seconds(model, n_balls, per, values)
    n_periods = max(1, round(settle / period_s))
    t_end = n_periods * period_s
    steps = steps_per_period(model, n_balls, per, values, dt) * n_periods
    ds = simulate(model, n_balls, duration=t_end, transient=0.0, dt=t_end / steps,
                  save_every=steps, **values)
    return state_at(ds, -1), 0.0


def shoot(
    model: Model | str,
    n_balls: int | None = None,
    period: str | Period = "vc",
    guess: np.ndarray | None = None,
    t0: float | None = None,
    *,
    segments: int = 1,
    dt: float = 1e-5,
    settle: float = 0.5,
    tol: float = 1e-10,
    max_iter: int = 40,
    **parameters: float,
) -> PeriodicOrbit:
    """Find a periodic orbit by Newton shooting and its Floquet multipliers.

    ``guess`` (x, y, vx, vy at time ``t0``) defaults to the end of a simulation of about
    ``settle`` seconds. ``segments`` > 1 selects multiple shooting. The RK4 step is at most
    ``dt`` (s), adjusted so a whole number of steps fits the period. ``tol`` bounds the scaled
    residual |Φ_T(z0) − z0| / scale.
    """
    if not (isinstance(segments, int) and 1 <= segments <= 64):
        raise InputError(f"segments: must be an integer in [1, 64], got {segments!r}")
    mdl = load_model(model) if isinstance(model, str) else model
    model, n, per, values = _prepare(mdl, n_balls, period, mdl.parameters(parameters))
    if guess is None:
        guess, t0 = default_guess(model, n, per, values, settle, dt)
    t0 = 0.0 if t0 is None else float(t0)
    z = np.asarray(guess, dtype=float).copy()
    period_s = period_seconds(model, n, per, values)
    steps = steps_per_period(model, n, per, values, dt)
    steps += (-steps) % segments
    p = model.parameter_vector(values)
    flow = flow_map(model, n, per.segment(segments), steps // segments)
    scale = state_scale(z, period_s)

    def segment_map(zj: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray]:
        z_end, mono, _ = evaluate(flow, zj, t0 + j * period_s / segments, p)
        return z_end, mono

    try:
        if segments == 1:
            z, mono, iters, res, ok, msg = _newton_single(segment_map, z, scale, tol, max_iter)
        else:
            z, mono, iters, res, ok, msg = _newton_multiple(segment_map, z, segments, scale,
                                                            tol, max_iter)
    except np.linalg.LinAlgError as exc:  # non-finite states from a diverging guess
        z, mono, iters, res, ok = z, np.full((4, 4), np.nan), 0, np.inf, False
        msg = f"the flow from the guess is not finite ({exc}); try another guess or settle"
    if not np.all(np.isfinite(mono)):
        return PeriodicOrbit(model=model.name, n_balls=n, period=str(per), period_s=period_s,
                             t0=t0, z0=z, monodromy=mono, multipliers=np.full(4, np.nan),
                             converged=False, iterations=iters, residual=float(res),
                             message=msg if not ok else "non-finite monodromy matrix",
                             values=values, n_steps=steps)
    return PeriodicOrbit(model=model.name, n_balls=n, period=str(per), period_s=period_s,
                         t0=t0, z0=z, monodromy=mono, multipliers=np.linalg.eigvals(mono),
                         converged=ok, iterations=iters, residual=res, message=msg,
                         values=values, n_steps=steps)


def _backtrack(residual, x, step, res):
    """Halve the Newton step until the scaled residual decreases; None when it never does."""
    lam = 1.0
    while lam > 1e-4:
        trial = x + lam * step
        out = residual(trial)
        if out[0] < res:
            return trial, out
        lam /= 2
    return None


def _newton_single(segment_map, z, scale, tol, max_iter):
    """Newton on Φ(z) − z = 0 (one segment covering the period)."""

    def residual(zz):
        z_end, mono = segment_map(zz, 0)
        return np.linalg.norm((z_end - zz) / scale), z_end - zz, mono

    res, r, mono = residual(z)
    for it in range(max_iter):
        if res < tol:
            return z, mono, it, res, True, f"converged in {it} Newton iterations"
        try:
            step = np.linalg.solve(mono - np.eye(4), -r)
        except np.linalg.LinAlgError:
            return z, mono, it, res, False, "singular Newton matrix (a multiplier at +1)"
        found = _backtrack(residual, z, step, res)
        if found is None:
            return z, mono, it, res, False, _stalled(res)
        z, (res, r, mono) = found
    ok = res < tol
    return z, mono, max_iter, res, ok, "converged" if ok else _no_convergence(max_iter, res)


def _newton_multiple(segment_map, z0, m, scale, tol, max_iter):
    """Newton on Φ_j(z_j) − z_{j+1} = 0, j = 0…m−1 (cyclic), segments of T/m."""
    zs = [np.asarray(z0, dtype=float)]
    for j in range(m - 1):
        zs.append(segment_map(zs[-1], j)[0])
    x = np.concatenate(zs)
    big_scale = np.tile(scale, m)

    def residual(xx):
        parts = xx.reshape(m, 4)
        ends, blocks = zip(*(segment_map(parts[j], j) for j in range(m)), strict=True)
        r = np.concatenate([ends[j] - parts[(j + 1) % m] for j in range(m)])
        return np.linalg.norm(r / big_scale), r, blocks

    res, r, blocks = residual(x)
    for it in range(max_iter):
        if res < tol:
            return x[:4], _product(blocks), it, res, True, (
                f"converged in {it} Newton iterations ({m} segments)")
        jac = np.zeros((4 * m, 4 * m))
        for j in range(m):
            jac[4 * j:4 * j + 4, 4 * j:4 * j + 4] = blocks[j]
            k = (j + 1) % m
            jac[4 * j:4 * j + 4, 4 * k:4 * k + 4] -= np.eye(4)
        try:
            step = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            return x[:4], _product(blocks), it, res, False, "singular Newton matrix"
        found = _backtrack(residual, x, step, res)
        if found is None:
            return x[:4], _product(blocks), it, res, False, _stalled(res)
        x, (res, r, blocks) = found
    ok = res < tol
    return (x[:4], _product(blocks), max_iter, res, ok,
            "converged" if ok else _no_convergence(max_iter, res))


def _product(blocks) -> np.ndarray:
    """Monodromy matrix A_{m−1} ⋯ A_1 A_0 of the segment Jacobians."""
    mono = np.eye(4)
    for block in blocks:
        mono = block @ mono
    return mono


def _stalled(res: float) -> str:
    return (f"Newton stalled at scaled residual {res:.2e} (non-smooth contact, or no periodic "
            "orbit near the guess)")


def _no_convergence(max_iter: int, res: float) -> str:
    return f"no convergence in {max_iter} iterations (scaled residual {res:.2e})"
