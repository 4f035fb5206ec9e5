"""Pseudo-arclength continuation of periodic orbits, with bifurcation detection.

Unknowns w = (z0 / s_z, λ / s_λ), n + 1 of them for a model of n states: the orbit's state at
the section (scaled per component by ``periodic.state_scale``) and the continuation
parameter (scaled by the requested range).
Equations: G(w) = (Φ_T(z0; λ) − z0) / s_z = 0 (shooting, ``analysis.integrate.flow``) plus the
arclength condition τ·(w − w_pred) = 0 of Keller's method; the bordered Newton matrix is built
from the monodromy matrix and ∂Φ/∂λ, both by AD (the period's own dependence on λ, e.g. on the
speed, included). The step adapts to the Newton iterations.

Special points, located by bisection on the arclength:
  * LP (fold): the parameter component of the tangent changes sign (a multiplier passes +1);
  * PD (period doubling): det(M + I) changes sign (a real multiplier passes −1);
  * BP (branch point): det(M − I) changes sign without a fold (a symmetry-breaking
    pitchfork, say);
  * NS (Neimark–Sacker): the number of complex multipliers outside the unit circle changes.
``switch_period_doubling`` starts the period-2 branch at a PD point.

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
from analysis.integrate.simulate import run_attrs
from analysis.model import BallCounts, Model, Structure, System, as_system
from analysis.stability.periodic import (
    PeriodicOrbit,
    as_period,
    shoot,
    state_scale,
    system_of_attrs,
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


def _correct(prob: _Problem, w_pred: np.ndarray, tau: np.ndarray, tol: float,
             max_iter: int = 8):
    """Newton on [G(w); τ·(w − w_pred)] = 0. Returns (w, jac, mono, iterations) or None."""
    w = w_pred.copy()
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
        if np.linalg.norm(dw) < tol and np.linalg.norm(g) < 1e3 * tol:
            g, jac, mono = prob.residual(w)
            return w, jac, mono, it
    return None


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
            iterations: int = 12) -> BranchPoint:
    """Bisection on the chord from a to b (corrected onto the branch) for the sign change of
    ``test``; returns the located point labelled ``kind``."""
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
        best = b
    best.special = kind
    return best


def _complex_outside(point: BranchPoint) -> int:
    """Complex multipliers outside the unit circle (beyond 1 + 1e-9, as ``n_unstable``:
    a conservative system's multipliers on the circle are not a Neimark–Sacker point)."""
    mu = point.multipliers
    return int(np.sum((np.abs(mu.imag) > 1e-9) & (np.abs(mu) > 1 + 1e-9)))


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
    settle: float = 0.5,
    progress: Callable[[str], None] | None = None,
    **parameters: float,
) -> xr.Dataset:
    """Continue a branch of periodic orbits in ``param`` from ``start`` towards ``stop``
    (the parameter's unit).

    ``system``: a ``System`` or a model (name, spec path, ``Model``) completed by
    ``n_balls`` and ``**parameters``. ``period``: as in ``periodic.shoot`` (text for
    ``Period.parse``; None: ``periodic.default_period``). The first orbit is found by
    ``periodic.shoot`` at ``param = start`` (from ``guess``, the state at ``t0`` s, or a
    simulation of ``settle`` s). ``ds``, ``ds_min``, ``ds_max`` are arclength steps in the
    scaled variables (λ scaled by |stop − start|). ``dt``: the largest RK4 step (s; default
    the spec's). Returns the branch as a Dataset (see ``branch_dataset``).
    """
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
                          dt, tol, progress)


def _continue_from(first: PeriodicOrbit, param: str, start: float, stop: float,
                   ds: float, ds_min: float, ds_max: float, max_points: int,
                   dt: float | None, tol: float, progress, label: str = "") -> xr.Dataset:
    if first.system is None:
        raise InputError("orbit: no System attached (continue from an orbit of shoot)")
    model = first.system.model
    per = as_period(model, first.period)
    values = dict(first.values)
    dt = float(model.simulation_defaults["dt"] if dt is None else dt)
    # the step must stay below dt along the whole range (the period depends on λ)
    n_steps = max(steps_per_period(model, first.structure, per, {**values, param: end}, dt)
                  for end in (start, stop))
    n = model.n_state
    prob = _Problem(model, first.structure, per, model.parameter_names.index(param), values,
                    first.t0, n_steps, np.ones(n), abs(stop - start))
    prob.s_z = orbit_scale(prob, first.z0)
    direction = math.copysign(1.0, stop - start)
    w = np.concatenate([first.z0 / prob.s_z, [start / prob.s_lam]])
    out = _correct(prob, w, np.eye(n + 1)[n], tol)  # re-solve at fixed λ with this step count
    if out is None:
        raise InputError(f"start: the orbit at {param} = {start:g} does not converge with "
                         f"{n_steps} steps per period")
    w, jac, mono, it = out
    branch = [_point(prob, w, jac, mono, None, direction, it)]
    lo, hi = min(start, stop), max(start, stop)
    status = "reached the end of the range"
    while len(branch) < max_points:
        prev = branch[-1]
        w_prev = _w(prob, prev)
        out = _correct(prob, w_prev + ds * prev.tangent, prev.tangent, tol)
        if out is None:
            ds /= 2
            if ds < ds_min:
                status = f"step fell below ds_min = {ds_min:g} (no convergence)"
                break
            continue
        w, jac, mono, it = out
        point = _point(prob, w, jac, mono, prev.tangent, direction, it)
        branch.extend(_special_points(prob, prev, point, tol, direction))
        branch.append(point)
        ds = min(ds * 1.5, ds_max) if it <= 3 else max(ds / 1.5, ds_min)
        if progress and len(branch) % 10 == 0:
            progress(f"{len(branch)} points, {param} = {point.lam:.6g}, "
                     f"{'stable' if point.stable else 'unstable'}")
        if not lo <= point.lam <= hi:
            break
    else:
        status = f"stopped after max_points = {max_points}"
    return branch_dataset(model, prob, branch, param, status, label)


def _special_points(prob, a: BranchPoint, b: BranchPoint, tol,
                    direction) -> list[BranchPoint]:
    """LP, PD and NS points between two consecutive branch points, located by bisection."""
    found = []
    for kind, test in (("LP", _lp_test), ("PD", _pd_test), ("BP", _bp_test)):
        if kind == "BP" and found and found[0].special == "LP":
            continue  # at a fold det(M − I) changes sign too
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
                   status: str, label: str = "") -> xr.Dataset:
    """The branch as a Dataset: ``param`` value, amplitude (of the first state variable),
    z0 (dims ``point`` × ``state``, the model's state names), the n multipliers (real and
    imaginary parts, dim ``k``), stability and special-point labels along ``point``; attrs
    from ``run_attrs`` (model, spec, balls per bearing, parameters, state names)."""
    mult = np.array([p.multipliers for p in branch])
    attrs = run_attrs(model, prob.structure, prob.values)
    attrs.update(param=param, period=str(prob.period), steps_per_period=prob.n_steps,
                 t0=prob.t0, status=status, branch=label or f"period {prob.period}")
    attrs.pop(param, None)
    return xr.Dataset(
        {param: ("point", np.array([p.lam for p in branch]),
                 {"units": model.units[param]}),
         "amplitude": ("point", np.array([p.amplitude for p in branch]),
                       {"units": model.state_units[model.state_names[0]],
                        "long_name": f"half peak-to-peak {model.state_names[0]} over one "
                                     "period"}),
         "z0": (("point", "state"), np.array([p.z0 for p in branch])),
         "multiplier_real": (("point", "k"), mult.real),
         "multiplier_imag": (("point", "k"), mult.imag),
         "multiplier_abs": (("point", "k"), np.abs(mult)),
         "stable": ("point", np.array([int(p.stable) for p in branch])),
         "special": ("point", np.array([p.special for p in branch], dtype=object)),
         "newton_iterations": ("point", np.array([p.newton_iterations for p in branch]))},
        coords={"point": np.arange(len(branch)), "state": list(model.state_names),
                "k": np.arange(1, model.n_state + 1)},
        attrs=attrs)


def switch_period_doubling(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                           kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The period-2 orbit born at the period doubling ``branch.point[point]`` (label PD).

    Steps ``offset`` × |range| into the side where the period-1 orbit is unstable, solves the
    period-1 orbit there, kicks it along the eigenvector of its multiplier below −1 by
    ``kick`` × the orbit size, and shoots for a fixed point of the doubled period. The result
    is checked to be a genuine period-2 orbit (Φ_T(z) ≠ z).
    """
    if str(branch.special.values[point]) != "PD":
        raise InputError(f"point: {point} is not a period-doubling point (label "
                         f"'{branch.special.values[point]}')")
    attrs = branch.attrs
    param = attrs["param"]
    base = system_of_attrs({**attrs, param: float(branch[param][point])})
    model = base.model
    lam = float(branch[param][point])
    unstable_side = [i for i in (point + 1, point - 1)
                     if 0 <= i < branch.sizes["point"] and not branch.stable.values[i]]
    if not unstable_side:
        raise InputError(f"point: no unstable period-1 orbit next to point {point}")
    step = float(branch[param][unstable_side[0]]) - lam
    lam += math.copysign(offset * _range(branch, param), step)
    system = base.replace(**{param: lam})
    period = Period.parse(attrs["period"])
    dt = dt or period_seconds(model, system.structure, period, dict(system.parameters)) / int(
        attrs["steps_per_period"])
    one = shoot(system, None, period, branch.z0.values[point], float(attrs["t0"]), dt=dt)
    mu, vectors = np.linalg.eig(one.monodromy)
    k = int(np.argmin(mu.real))
    if not (one.converged and mu[k].real < -1):
        raise InputError(f"point: no period-1 orbit with a multiplier below −1 at {param} = "
                         f"{lam:g} ({one.message}; multipliers {np.round(mu, 4)})")
    v = np.real(vectors[:, k])
    size = state_scale(one.z0, one.period_s, model.module.STATE_UNITS)
    guess = one.z0 + kick * size * v / np.max(np.abs(v / size))
    two = shoot(one.system, None, period.doubled(), guess, one.t0, dt=dt)
    if two.converged:
        half = evaluate(flow_map(model, one.structure, period, one.n_steps), two.z0, two.t0,
                        one.system.p)[0]
        if np.max(np.abs((half - two.z0) / size)) < 1e-6:
            two.converged = False
            two.message = "Newton fell back onto the period-1 orbit; try a larger kick"
    return two


def _range(branch: xr.Dataset, param: str) -> float:
    values = branch[param].values
    return float(np.ptp(values)) or abs(float(values[0])) or 1.0


def continue_from_orbit(orbit: PeriodicOrbit, *, param: str, stop: float, ds: float = 0.01,
                        ds_min: float = 1e-6, ds_max: float = 0.05, max_points: int = 200,
                        dt: float | None = None, tol: float = 1e-9,
                        progress: Callable[[str], None] | None = None,
                        label: str = "") -> xr.Dataset:
    """Continue a branch from an already solved orbit of ``periodic.shoot`` (e.g. after
    branch switching) in ``param`` towards ``stop``; ``dt`` (s) defaults to the spec's."""
    start = orbit.values[param]
    return _continue_from(orbit, param, start, stop, ds, ds_min, ds_max, max_points,
                          dt, tol, progress, label)
