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
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Literal

import numpy as np

from analysis.errors import InputError, check_count
from analysis.forcing import period_parameter
from analysis.integrate.flow import (
    Period,
    evaluate,
    flow_map,
    orbit_states,
    period_seconds,
    steps_per_period,
)
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import BallCounts, Model, Structure, System, as_system
from analysis.provenance import state_at
from analysis.stability.classify import default_orbit_section

STABILITY_MARGIN = 1e-6
"""|μ| below 1 − margin counts as stable; within the margin the verdict is 'marginal'."""


@dataclass
class PeriodicOrbit:
    """Result of a shooting solve. States in the model's units (m, m/s, rad, rad/s) and in
    the order of ``state_names``; times in s."""

    model: str
    structure: Structure
    """Balls per bearing, in the order of the model's bearings (() without bearings)."""
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
    state_names: tuple[str, ...] = ()
    system: System | None = field(default=None, repr=False, compare=False)
    """The System solved (parameters as used: with ``ratio:p/q`` the adjusted ones)."""

    @property
    def n_balls(self) -> int | dict[str, int]:
        """Balls of the only bearing (0 without bearings), or bearing -> balls."""
        if len(self.structure) <= 1:
            return self.structure[0] if self.structure else 0
        names = self.system.model.bearing_names if self.system else \
            [str(i) for i in range(len(self.structure))]
        return dict(zip(names, self.structure, strict=True))

    @property
    def structure_label(self) -> str:
        """``N_b = 8``, ``N_b[left] = 8, N_b[right] = 10`` or ``no balls``."""
        if self.system is not None:
            return self.system.model.structure_label(self.structure)
        return f"N_b = {self.n_balls}"

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

    def _repr_html_(self) -> str:
        """The orbit in a notebook: model and balls, period, convergence, stability, the
        orbit's initial state (SI units) and every Floquet multiplier (modulus and angle)."""
        from html import escape

        facts = [("model", escape(self.model)), ("balls", escape(self.structure_label)),
                 ("period", f"{escape(self.period)}: {self.period_s:.6g} s from t0 = "
                            f"{self.t0:.6g} s ({self.n_steps} RK4 steps)"),
                 ("converged", f"{'yes' if self.converged else 'no'} after "
                               f"{self.iterations} iterations, residual {self.residual:.3g}"),
                 ("stability", f"{self.stability} (largest |μ| = "
                               f"{self.spectral_radius:.6g})")]
        units = self.system.model.state_units if self.system is not None else {}
        state = "".join(f"<tr><td><code>{escape(name)}</code></td><td>{value:.6g}</td>"
                        f"<td>{escape(units.get(name, ''))}</td></tr>"
                        for name, value in zip(self.state_names, self.z0, strict=False))
        multipliers = "".join(
            f"<tr><td>{i + 1}</td><td>{mu.real:.6g}</td><td>{mu.imag:.6g}</td>"
            f"<td>{abs(mu):.6g}</td><td>{math.degrees(np.angle(mu)):.4g}</td></tr>"
            for i, mu in enumerate(self.multipliers))
        return ('<div class="bearingdyn-orbit"><h4>periodic orbit</h4><table>'
                + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in facts)
                + "</table><table><thead><tr><th>state</th><th>at t0</th><th>unit</th>"
                "</tr></thead><tbody>" + state + "</tbody></table><table><thead><tr>"
                "<th>multiplier</th><th>real</th><th>imaginary</th><th>|μ|</th>"
                "<th>angle (°)</th></tr></thead><tbody>" + multipliers
                + "</tbody></table></div>")

    def as_dict(self) -> dict:
        return {
            "model": self.model, "n_balls": self.n_balls, "structure": list(self.structure),
            "period": self.period, "period_s": self.period_s, "t0": self.t0,
            "state_names": list(self.state_names), "z0": self.z0.tolist(),
            "converged": self.converged, "iterations": self.iterations,
            "residual": self.residual, "message": self.message,
            "multipliers_real": self.multipliers.real.tolist(),
            "multipliers_imag": self.multipliers.imag.tolist(),
            "multipliers_abs": np.abs(self.multipliers).tolist(),
            "stability": self.stability, "n_steps": self.n_steps,
        }


def state_scale(z: np.ndarray, period_s: float,
                units: Sequence[str] | None = None) -> np.ndarray:
    """Per-component scale for residuals (the state's units).

    The state is positions then their velocities (every generated model's order). Each
    position gets the largest |z| of the positions of the same unit (m or rad), each
    velocity the largest |z| of the velocities of its unit, at least its position group's
    size·2π/T. Without ``units`` all positions share one unit (the one-body rotor:
    max(|x|, |y|) and max(|vx|, |vy|, size·2π/T)).
    """
    z = np.abs(np.asarray(z, dtype=float))
    n = z.size
    half = n // 2
    units = list(units) if units is not None else ["q"] * half + ["v"] * (n - half)
    scale = np.empty(n)
    pos_units = units[:half]
    for unit in set(pos_units):
        group = [i for i in range(half) if pos_units[i] == unit]
        size = max(float(np.max(z[group])), 1e-300)
        vel = [i + half for i in group]
        scale[group] = size
        scale[vel] = max(float(np.max(z[vel])), size * 2 * math.pi / period_s)
    return scale


def default_period(model: Model) -> Period:
    """The period an analysis uses when none is given.

    One bearing: ``vc`` (the balanced rotor's forcing; give ``shaft`` or ``ratio:p/q``
    with unbalance). No bearings: ``param:forcing_period`` when the model has that
    parameter (e.g. ``mathieu``), else ``shaft`` (e.g. ``duffing``). Several bearings: no
    default (``InputError``): their VC frequencies differ and neither ``shaft`` nor one
    bearing's ``vc`` is in general a period of the forcing; name it, e.g. ``vc[left]:4``
    (= ``vc[right]:5`` for 8 and 10 balls on one cage speed).
    """
    section = default_orbit_section(model.bearing_names, period_parameter(model))
    if section is not None:  # the rule: analysis.stability.classify.SECTION_RULES
        return Period.parse(section)
    bearings = model.bearing_names
    raise InputError(f"period: model '{model.name}' has bearings {', '.join(bearings)}, "
                     f"each with its own VC frequency; give the period (e.g. "
                     f"vc[{bearings[0]}]:k, shaft:k or param:NAME)")


def as_period(model: Model, period: str | Period | None) -> Period:
    """``period`` parsed (``Period.parse``) and checked against ``model``; None: the
    ``default_period``."""
    per = default_period(model) if period is None else \
        period if isinstance(period, Period) else Period.parse(period)
    per.check(model)
    return per


def commensurate(model: Model, n_balls: BallCounts, values: dict[str, float],
                 ratio: Fraction) -> dict[str, float]:
    """Parameters with the outer race diameter adjusted so that VC/X equals ``ratio`` exactly.

    With unbalance the forcing has the frequencies X and VC = N_b·ρ·X (ρ = D_i/(D_i + D_o),
    paper Eq. 1), in general incommensurate; a periodic orbit exists only for a rational
    ρ·N_b = p/q. The returned values differ from ``values`` in ``outer_race_diameter`` only.
    Models with one bearing only.
    """
    structure = model.structure(n_balls)
    if len(structure) != 1:
        raise InputError(f"period: ratio:p/q needs a model with one bearing; model "
                         f"'{model.name}' has {len(structure)}")
    if "outer_race_diameter" not in values or "inner_race_diameter" not in values:
        raise InputError("period: ratio:p/q needs a model with race-diameter cage kinematics")
    rho = float(ratio) / structure[0]
    if not 0 < rho < 1:
        raise InputError(f"period: ratio {ratio} gives a cage/shaft ratio {rho:g} outside (0, 1)")
    adjusted = dict(values)
    adjusted["outer_race_diameter"] = values["inner_race_diameter"] * (1 - rho) / rho
    return adjusted


def _prepare(system: System, period: str | Period | None) -> tuple[System, Period]:
    per = as_period(system.model, period)
    if per.kind == "ratio":
        values = commensurate(system.model, system.structure, dict(system.parameters),
                              per.ratio)
        system = system.replace(**values)
    return system, per


SETTLE_PERIODS = 20
"""Fewest forcing periods simulated for the default guess (``default_settle``)."""


def default_settle(system: System, per: Period) -> float:
    """Simulated time (s) before the default guess, from the model's own time scales: the
    spec's transient (1 s for the bearing models, 300 s for Duffing), at least
    ``SETTLE_PERIODS`` periods ``per`` (the Mathieu spec has no transient)."""
    model = system.model
    period_s = period_seconds(model, system.structure, per, dict(system.parameters))
    return max(float(model.simulation_defaults.get("transient", 0.0)),
               SETTLE_PERIODS * period_s)


def default_guess(system: System, per: Period, settle: float | None,
                  dt: float) -> tuple[np.ndarray, float]:
    """The state after simulating about ``settle`` seconds (None: ``default_settle``) from
    the system's state, taken at a whole number n of periods, and the section time 0: the
    system is T-periodic, so the state at t = nT is a state at forcing phase 0 (keeping
    t0 = nT would make the section phase depend on T)."""
    model, values = system.model, dict(system.parameters)
    period_s = period_seconds(model, system.structure, per, values)
    settle = default_settle(system, per) if settle is None else float(settle)
    if not (math.isfinite(settle) and settle >= 0):
        raise InputError(f"settle: must be a finite number >= 0 s, got {settle!r}")
    n_periods = max(1, round(settle / period_s))
    t_end = n_periods * period_s
    steps = steps_per_period(model, system.structure, per, values, dt) * n_periods
    ds = simulate(system, duration=t_end, transient=0.0, dt=t_end / steps, save_every=steps)
    return state_at(ds, -1), 0.0


def shoot(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    period: str | Period | None = None,
    guess: np.ndarray | None = None,
    t0: float | None = None,
    *,
    segments: int = 1,
    dt: float | None = None,
    settle: float | None = None,
    tol: float = 1e-10,
    max_iter: int = 40,
    **parameters: float,
) -> PeriodicOrbit:
    """Find a periodic orbit by Newton shooting and its n Floquet multipliers.

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls`` and ``**parameters`` (SI units, speed in rpm). ``period``: text for
    ``Period.parse`` (``vc``, ``shaft:2``, ``ratio:16/5``, ``vc[left]``,
    ``param:forcing_period`` …) or a ``Period``; None: ``default_period``. ``guess`` (the
    state at time ``t0`` s, the model's state order) defaults to the end of a simulation of
    about ``settle`` s from the system's state (default: the spec's transient, at least
    ``SETTLE_PERIODS`` periods: ``default_settle``). ``segments`` > 1 selects multiple shooting.
    The RK4 step is at most ``dt`` (s; default: the spec's), adjusted so a whole number of
    steps fits the period. ``tol`` bounds the scaled residual |Φ_T(z0) − z0| / scale.
    """
    segments = check_count("segments", segments, 1, 64)
    system, per = _prepare(as_system(system, n_balls, **parameters), period)
    model, s, values = system.model, system.structure, dict(system.parameters)
    n = model.n_state
    dt = RunPlan.step(system, dt).dt
    if guess is None:
        guess, t0 = default_guess(system, per, settle, dt)
    t0 = 0.0 if t0 is None else float(t0)
    z = model.check_state(guess, "guess").copy()
    period_s = period_seconds(model, s, per, values)
    steps = steps_per_period(model, s, per, values, dt)
    steps += (-steps) % segments
    p = system.p
    flow = flow_map(model, s, per.segment(segments), steps // segments)
    scale = state_scale(z, period_s, model.module.STATE_UNITS)

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
        z, mono, iters, res, ok = z, np.full((n, n), np.nan), 0, np.inf, False
        msg = f"the flow from the guess is not finite ({exc}); try another guess or settle"
    common = dict(model=model.name, structure=s, period=str(per), period_s=period_s, t0=t0,
                  z0=z, monodromy=mono, iterations=iters, values=values, n_steps=steps,
                  state_names=model.state_names, system=system)
    if not np.all(np.isfinite(mono)):
        return PeriodicOrbit(multipliers=np.full(n, np.nan), converged=False,
                             residual=float(res),
                             message=msg if not ok else "non-finite monodromy matrix",
                             **common)
    return PeriodicOrbit(multipliers=np.linalg.eigvals(mono), converged=ok,
                         residual=float(res), message=msg, **common)


def divergence_integral(system: System, period: str | Period | None, z0: np.ndarray,
                        t0: float, n_steps: int) -> float:
    """∫ tr ∂f/∂z dt over one period (dimensionless) along the RK4 orbit from (z0, t0) with
    ``n_steps`` steps: composite Simpson's rule on the n_steps + 1 states (trapezoid on the
    last interval when n_steps is odd). By Liouville's formula det M = exp(this) for the
    flow; the RK4 map meets it to O(h⁴)."""
    model = system.model
    per = as_period(model, period)
    period_s = period_seconds(model, system.structure, per, dict(system.parameters))
    p = system.p
    z0 = model.check_state(z0, "z0")
    states = np.column_stack([z0, np.asarray(
        orbit_states(model, system.structure, per, n_steps)(z0, t0, p))])
    h = period_s / n_steps
    jac = system.functions.jac
    traces = np.array([np.trace(np.asarray(jac(t0 + k * h, states[:, k], p)))
                       for k in range(n_steps + 1)])
    from scipy.integrate import simpson

    return float(simpson(traces, dx=h))


def liouville_error(orbit: PeriodicOrbit) -> float:
    """|det M / exp(∫ tr J dt) − 1| for a solved orbit (``divergence_integral`` on the
    orbit's own RK4 steps): 0 for the exact flow, O(h⁴) for the RK4 map."""
    if orbit.system is None:
        raise InputError("orbit: no System attached (an orbit from shoot has one)")
    integral = divergence_integral(orbit.system, orbit.period, orbit.z0, orbit.t0,
                                   orbit.n_steps)
    return abs(float(np.linalg.det(orbit.monodromy)) / math.exp(integral) - 1)


BoundaryTest = Literal["radius", "PD", "LP"]


@dataclass(frozen=True)
class StabilityBoundary:
    """A parameter value where the periodic orbit changes stability (``param``'s unit)."""

    param: str
    value: float
    bracket: tuple[float, float]
    """Final bisection interval (the test changes sign inside it)."""
    test: str
    multipliers: np.ndarray
    """Floquet multipliers at ``value``."""
    evaluations: int
    orbit: PeriodicOrbit = field(repr=False)

    def as_dict(self) -> dict:
        return {"param": self.param, "value": self.value, "bracket": list(self.bracket),
                "test": self.test, "evaluations": self.evaluations,
                "multipliers_real": self.multipliers.real.tolist(),
                "multipliers_imag": self.multipliers.imag.tolist()}


def _boundary_test(test: str, orbit: PeriodicOrbit) -> float:
    mu = orbit.multipliers
    if test == "radius":
        return orbit.spectral_radius - (1 + STABILITY_MARGIN)
    if test == "PD":
        return float(np.real(np.prod(mu + 1)))
    return float(np.real(np.prod(mu - 1)))


def stability_boundary(
    system: System | Model | str | Path,
    param: str,
    low: float,
    high: float,
    *,
    n_balls: BallCounts = None,
    period: str | Period | None = None,
    test: BoundaryTest = "radius",
    dt: float | None = None,
    xtol: float | None = None,
    max_iter: int = 60,
    settle: float | None = None,
    guess: np.ndarray | None = None,
    **parameters: float,
) -> StabilityBoundary:
    """Bisect ``param`` in [``low``, ``high``] (its unit) for a stability boundary of the
    periodic orbit, solved by ``shoot`` at each value.

    ``test``: ``"radius"`` (the largest |μ| crosses 1 + ``STABILITY_MARGIN``: any loss of
    stability), ``"PD"`` (det(M + I) changes sign: a real multiplier crosses −1, the
    boundary of a period-doubling tongue) or ``"LP"`` (det(M − I): a multiplier crosses +1).
    The test must differ in sign at ``low`` and ``high``. ``xtol``: width of the final
    bracket (default 1e-10·|high − low|). ``period``, ``dt`` (s), ``settle`` (s) as in
    ``shoot``. Every solve starts from the same guess (``guess`` at time 0, else the state
    after ``settle`` s at ``low``), so the result does not depend on the bisection's path.
    """
    system = as_system(system, n_balls, **parameters)
    if param not in system.model.parameter_names:
        raise InputError(f"param: '{param}' is not a parameter of '{system.model.name}'; "
                         f"choose one of {', '.join(system.model.parameter_names)}")
    if test not in ("radius", "PD", "LP"):
        raise InputError(f"test: must be 'radius', 'PD' or 'LP', got {test!r}")
    if not (math.isfinite(low) and math.isfinite(high) and low != high):
        raise InputError(f"high: must differ from low, both finite; got {low!r}, {high!r}")
    xtol = 1e-10 * abs(high - low) if xtol is None else float(xtol)
    per = as_period(system.model, period)
    step = float(system.model.simulation_defaults["dt"] if dt is None else dt)
    t0 = 0.0
    if guess is None:
        guess, t0 = default_guess(system.replace(**{param: low}), per, settle, step)
    count = 0

    def solve(value: float) -> PeriodicOrbit:
        nonlocal count
        orbit = shoot(system.replace(**{param: value}), None, per, guess, t0, dt=step)
        count += 1
        if not orbit.converged:
            raise InputError(f"{param} = {value:g}: no periodic orbit ({orbit.message})")
        return orbit

    a, b = solve(low), solve(high)
    fa, fb = _boundary_test(test, a), _boundary_test(test, b)
    if np.sign(fa) == np.sign(fb):
        raise InputError(f"low, high: the {test} test has the same sign at {param} = {low:g} "
                         f"and {high:g} (no boundary between them, or two)")
    lo, hi, best = float(low), float(high), a
    for _ in range(max_iter):
        if abs(hi - lo) <= xtol:
            break
        mid = (lo + hi) / 2
        best = solve(mid)
        if np.sign(_boundary_test(test, best)) == np.sign(fa):
            lo = mid
        else:
            hi = mid
    value = (lo + hi) / 2
    best = solve(value)
    return StabilityBoundary(param=param, value=value, bracket=(lo, hi), test=test,
                             multipliers=best.multipliers, evaluations=count,
                             orbit=best)


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
            step = np.linalg.solve(mono - np.eye(len(z)), -r)
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
    n = len(z0)
    big_scale = np.tile(scale, m)

    def residual(xx):
        parts = xx.reshape(m, n)
        ends, blocks = zip(*(segment_map(parts[j], j) for j in range(m)), strict=True)
        r = np.concatenate([ends[j] - parts[(j + 1) % m] for j in range(m)])
        return np.linalg.norm(r / big_scale), r, blocks

    res, r, blocks = residual(x)
    for it in range(max_iter):
        if res < tol:
            return x[:n], _product(blocks), it, res, True, (
                f"converged in {it} Newton iterations ({m} segments)")
        jac = np.zeros((n * m, n * m))
        for j in range(m):
            jac[n * j:n * j + n, n * j:n * j + n] = blocks[j]
            k = (j + 1) % m
            jac[n * j:n * j + n, n * k:n * k + n] -= np.eye(n)
        try:
            step = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            return x[:n], _product(blocks), it, res, False, "singular Newton matrix"
        found = _backtrack(residual, x, step, res)
        if found is None:
            return x[:n], _product(blocks), it, res, False, _stalled(res)
        x, (res, r, blocks) = found
    ok = res < tol
    return (x[:n], _product(blocks), max_iter, res, ok,
            "converged" if ok else _no_convergence(max_iter, res))


def _product(blocks) -> np.ndarray:
    """Monodromy matrix A_{m−1} ⋯ A_1 A_0 of the segment Jacobians."""
    mono = np.eye(len(blocks[0]))
    for block in blocks:
        mono = block @ mono
    return mono


def _stalled(res: float) -> str:
    return (f"Newton stalled at scaled residual {res:.2e} (non-smooth contact, or no periodic "
            "orbit near the guess)")


def _no_convergence(max_iter: int, res: float) -> str:
    return f"no convergence in {max_iter} iterations (scaled residual {res:.2e})"
