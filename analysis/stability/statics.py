"""Static equilibrium under the constant loads, and the linearised bearing coefficients.

With the velocities zero and every bearing's cage held at an angle ψ, a model's generalised
force F(q, q̇; ψ) (N on a translation, N·m on a tilt; the forces of ``external_force`` and
the balls of every bearing, exactly as ``rhs`` sums them) has an equilibrium F(q*, 0; ψ) = 0.
About it the model is linear:

    K = −∂F/∂q   (stiffness, N/m; N/rad, N·m/m, N·m/rad for tilts)
    C = −∂F/∂q̇   (damping, N·s/m, …)

both by CasADi's automatic differentiation of the generated functions. For a one-body model
these are the 2×2 bearing coefficients kxx, kxy, kyx, kyy and cxx, …; for a model with
several bodies or tilts, the full matrix over its coordinates.

*Constant loads.* Forces that vary in time (unbalance P_u·(cos ωt, sin ωt), a harmonic force
F·cos ωt) are not part of the statics: F is averaged over ``TIME_SAMPLES`` instants evenly
spread over one shaft revolution, which removes exactly every harmonic of the shaft of order
1 … ``TIME_SAMPLES`` − 1 and keeps every constant load. At zero shaft speed nothing varies,
and F at t = 0 is used.

*Cage angle.* Every bearing's cage is turned to ψ (the ball i at θ_i = 2π(i−1)/N_b + ψ).
The coefficients repeat after one ball pitch 2π/N_b (after 2π/gcd(N_b…) when bearings have
different ball counts): ``coefficients`` solves the equilibrium at evenly spaced ψ over that
interval, and their mean over it (the periodic trapezoid rule, exact for a trigonometric
polynomial of degree below the number of angles) is the cage-averaged coefficient set.

*Solver.* Pseudo-transient continuation (damped Newton, (I/Δτ + K) δ = F with Δτ growing as
the residual falls), started from the zero displacement: inside a clearance K is zero and the
steps follow the load until balls engage; near the equilibrium the steps are Newton's. The
equilibrium is not unique where K is singular (one loaded ball gives no stiffness across
its line): the solve then stays on the symmetric branch it started on, and the result says so
(``singular``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError, check_count
from analysis.model import BallCounts, Model, System, as_system
from analysis.provenance import run_attrs

TIME_SAMPLES = 8
"""Instants over one shaft revolution over which time-varying forces are averaged."""
CAGE_ANGLES = 36
"""Default number of cage angles over one pitch."""
MAX_ITERATIONS = 400
RTOL = 1e-12
"""Convergence: |F| ≤ RTOL × (the size of the static load), N."""
ABSOLUTE_TOLERANCE = 1e-14
"""|F| below which any equilibrium counts as converged, N (loads near zero)."""
FIRST_STEP = 1e-7
"""Length of the first pseudo-time step, m (a tenth of a micrometre)."""


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium at one set of cage angles. Positions in the model's units (m,
    rad), in the order of ``coordinates``; matrices over (row, column) = coordinates."""

    coordinates: tuple[str, ...]
    cage_angle: float
    """ψ, rad: every bearing's cage angle."""
    position: np.ndarray
    stiffness: np.ndarray
    """K = −∂F/∂q at the equilibrium."""
    damping: np.ndarray
    """C = −∂F/∂q̇ at the equilibrium (q̇ = 0)."""
    residual: float
    """|F| at the solution, N (N·m on tilts)."""
    iterations: int
    singular: bool
    """K has a zero eigenvalue (relative 1e-9): the equilibrium is not unique along it."""


def _force_function(system: System) -> tuple[ca.Function, list[str]]:
    """F(q, v, ψ, p) → (F, ∂F/∂q, ∂F/∂v): the generalised force with every cage at ψ and
    time-varying loads averaged over one shaft revolution."""
    model = system.model
    names = model.state_names
    n_dof = len(names) // 2
    q, v = ca.SX.sym("q", n_dof), ca.SX.sym("v", n_dof)
    psi, p = ca.SX.sym("psi"), ca.SX.sym("p", len(model.parameter_names))
    z = ca.vertcat(q, v)
    angles = [(ca.cos(psi), ca.sin(psi)) for _ in model.bearing_names]
    t = ca.SX.sym("t")
    # The runtime's sum over the balls of every bearing with the cage angles given
    # explicitly (rhs ties them to t): the one place the balls are summed, reused.
    force = ca.vertcat(*model.module.mass(p)) * \
        system.functions.derivative(t, z, p, angles)[n_dof:]
    for period in _periods(model, p):
        if ca.depends_on(force, t):
            force = sum(ca.substitute(force, t, t + period * j / TIME_SAMPLES)
                        for j in range(TIME_SAMPLES)) / TIME_SAMPLES
    force = ca.cse(ca.substitute(force, t, ca.SX(0)))
    fun = ca.Function("static_force", [q, v, psi, p],
                      [force, ca.jacobian(force, q), ca.jacobian(force, v)])
    return fun, list(names[:n_dof])


def _periods(model: Model, p: ca.SX) -> list[ca.SX]:
    """Periods (s) over which time-varying forces are averaged: one shaft revolution (0 at
    zero speed: no averaging needed), and ``forcing_period`` when the model has one."""
    omega = model.module.shaft_speed(p)
    periods = [ca.if_else(omega > 0, 2 * math.pi / ca.fmax(omega, 1e-300), 0)]
    for name in model.role("forcing_period"):
        periods.append(p[model.parameter_names.index(name)])
    return periods


def cage_pitch(structure: Sequence[int]) -> float:
    """Cage-angle period of the coefficients, rad: 2π/gcd of the ball counts (2π without
    bearings)."""
    counts = [n for n in structure if n > 0]
    return 2 * math.pi / (math.gcd(*counts) if counts else 1)


def ball_pitches(structure: Sequence[int]) -> int:
    """Ball pitches of the bearing with most balls within one cage pitch
    (``cage_pitch``): max(N_b)/gcd(N_b…); 1 for one bearing. The coefficients vary within
    each of them, so ``coefficients`` samples each with ``n_angles`` angles (two bearings
    of 7 and 11 balls: 11 pitches in 2π, where 36 angles over 2π gave 3.3 per pitch, a
    sawtooth)."""
    counts = [n for n in structure if n > 0]
    return max(counts) // math.gcd(*counts) if counts else 1


def _solve(fun: ca.Function, q0: np.ndarray, psi: float, p: np.ndarray,
           coordinates: list[str]) -> Equilibrium:
    n = len(q0)
    v = np.zeros(n)

    def evaluate(q):
        f, dfdq, dfdv = fun(q, v, psi, p)
        return (np.array(f, dtype=float).reshape(-1), -np.array(dfdq, dtype=float),
                -np.array(dfdv, dtype=float))

    q = np.array(q0, dtype=float)
    f, k, c = evaluate(q)
    scale = max(float(np.linalg.norm(f)), float(np.linalg.norm(evaluate(np.zeros(n))[0])),
                1e-12)
    tol = max(RTOL * scale, ABSOLUTE_TOLERANCE)
    norm = float(np.linalg.norm(f))
    dtau = FIRST_STEP / max(norm, 1e-300)
    iterations = 0
    while norm > tol and iterations < MAX_ITERATIONS:
        iterations += 1
        lhs = np.eye(n) / dtau + k
        try:
            step = np.linalg.solve(lhs, f)
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(lhs, f, rcond=None)[0]
        trial = q + step
        f_new, k_new, c_new = evaluate(trial)
        norm_new = float(np.linalg.norm(f_new))
        if np.all(np.isfinite(f_new)) and norm_new <= norm * (1 + 1e-9):
            q, f, k, c, norm = trial, f_new, k_new, c_new, norm_new
            dtau = min(dtau * 4, 1e300)
        else:
            dtau /= 8
            if dtau * max(norm, 1e-300) < 1e-30:
                break
    if not norm <= tol:
        raise SimulationError(f"statics: no equilibrium found at cage angle {psi:.6g} rad "
                              f"(|F| = {norm:.3g} N after {iterations} steps); the loads "
                              "may exceed what the bearing can carry")
    eig = np.abs(np.linalg.eigvals(k)) if n else np.zeros(0)
    singular = bool(n and eig.min() <= 1e-9 * max(eig.max(), 1e-300))
    return Equilibrium(tuple(coordinates), float(psi), q, k, c, norm, iterations, singular)


def equilibrium(target: System | Model | str, n_balls: BallCounts = None,
                cage_angle: float = 0.0, guess: Sequence[float] | None = None,
                **parameters: float) -> Equilibrium:
    """The static equilibrium with every cage at ``cage_angle`` (rad) and its stiffness and
    damping matrices (see the module's notes). ``guess``: starting positions (default 0)."""
    if not math.isfinite(float(cage_angle)):
        raise InputError(f"cage_angle: must be a finite angle in rad, got {cage_angle!r}")
    system = as_system(target, n_balls, **parameters)
    fun, coordinates = _force_function(system)
    q0 = np.zeros(len(coordinates)) if guess is None else np.asarray(guess, dtype=float)
    if q0.shape != (len(coordinates),):
        raise InputError(f"guess: must be {len(coordinates)} numbers "
                         f"({', '.join(coordinates)}), got {guess!r}")
    return _solve(fun, q0, float(cage_angle), system.p, coordinates)


def coefficients(target: System | Model | str, n_balls: BallCounts = None,
                 n_angles: int = CAGE_ANGLES, **parameters: float) -> xr.Dataset:
    """Equilibrium, stiffness and damping over one cage pitch (``n_angles`` evenly spaced
    cage angles per ball pitch of the bearing with most balls, ``ball_pitches``: over the
    cage pitch from 0) and their cage-angle means.

    Returns a Dataset with coordinates ``cage_angle`` (rad), ``row`` and ``column`` (the
    model's position coordinates) and variables ``position`` (cage_angle, row; m or rad),
    ``stiffness`` and ``damping`` (cage_angle, row, column), ``stiffness_mean`` and
    ``damping_mean`` (row, column), ``residual`` and ``singular`` (cage_angle); attrs: the
    run provenance (model, spec, versions, every parameter, balls) and ``cage_pitch``.
    """
    check_count("n_angles", n_angles, 1, 3600)
    system = as_system(target, n_balls, **parameters)
    fun, coordinates = _force_function(system)
    pitch = cage_pitch(system.structure)
    total = n_angles * ball_pitches(system.structure)
    angles = pitch * np.arange(total) / total
    start = np.zeros(len(coordinates))  # every angle from the unloaded position: the same
    results = [_solve(fun, start, float(psi), system.p, coordinates) for psi in angles]
    return _dataset(system, results, angles, pitch)


def _dataset(system: System, results: list[Equilibrium], angles: np.ndarray,
             pitch: float) -> xr.Dataset:
    coordinates = list(results[0].coordinates)
    units = system.model.state_units
    stiffness = np.array([r.stiffness for r in results])
    damping = np.array([r.damping for r in results])
    ds = xr.Dataset(
        {"position": (("cage_angle", "row"), np.array([r.position for r in results]),
                      {"long_name": "static equilibrium", "units": ", ".join(
                          units[c] for c in coordinates)}),
         "stiffness": (("cage_angle", "row", "column"), stiffness,
                       {"long_name": "K = -dF/dq", "units": "N/m (N/rad, N*m/m, N*m/rad)"}),
         "damping": (("cage_angle", "row", "column"), damping,
                     {"long_name": "C = -dF/dq'", "units": "N*s/m (N*s/rad, N*m*s/m, N*m*s/rad)"}),
         "stiffness_mean": (("row", "column"), stiffness.mean(axis=0),
                            {"long_name": "K averaged over the cage pitch"}),
         "damping_mean": (("row", "column"), damping.mean(axis=0),
                          {"long_name": "C averaged over the cage pitch"}),
         "residual": ("cage_angle", np.array([r.residual for r in results]),
                      {"units": "N"}),
         "singular": ("cage_angle", np.array([r.singular for r in results]))},
        coords={"cage_angle": ("cage_angle", angles, {"units": "rad"}),
                "row": coordinates, "column": coordinates})
    values = dict(system.parameters)
    ds.attrs.update(run_attrs(system.model, system.structure, values))
    ds.attrs.update(kind="stiffness", cage_pitch=pitch, time_samples=TIME_SAMPLES)
    return ds


def balls_in_contact(system: System, position: Sequence[float], cage_angle: float = 0.0,
                     t: float = 0.0) -> dict[str, tuple[int, int]]:
    """``{bearing: (in contact, balls)}`` at the positions ``position`` (the model's
    coordinates, m or rad; velocities 0) with every cage at ``cage_angle`` rad: a ball is in
    contact when its load changes with the displacement (a ball inside the clearance carries
    at most the constant centrifugal part, which no displacement changes). A bearing with
    none in contact carries no load there: it adds nothing to the stiffness."""
    module, p = system.model.module, np.asarray(system.p, dtype=float)
    position = np.asarray(position, dtype=float)
    z = ca.SX.sym("z", 2 * len(position))
    state = ca.vertsplit(z)
    counts: dict[str, tuple[int, int]] = {}
    for row, n in zip(module.BEARINGS, system.structure, strict=True):
        name = row[0]
        load = getattr(module, f"ball_load_{name}")
        slopes = []
        for i in range(n):
            theta = 2 * math.pi * i / n + cage_angle
            q = ca.SX(load(math.cos(theta), math.sin(theta), i + 1, n, state, t, p))
            slopes.append(ca.jacobian(q, z))
        if not slopes:
            counts[name] = (0, 0)
            continue
        fun = ca.Function("ball_slopes", [z], [ca.vertcat(*slopes)])
        grad = np.array(fun(np.concatenate([position, np.zeros_like(position)])), dtype=float)
        counts[name] = (int(np.count_nonzero(np.any(grad != 0, axis=1))), int(n))
    return counts


def unloaded_note(counts: dict[str, tuple[int, int]]) -> str | None:
    """One line naming the bearings that carry no load (``balls_in_contact``), or None."""
    idle = [f"'{name}' (none of its {n} balls touches a race)"
            for name, (touching, n) in counts.items() if n and not touching]
    if not idle:
        return None
    which = "bearing " + idle[0] if len(idle) == 1 else "bearings " + ", ".join(idle)
    return (f"note: {which} carries no load at the static equilibrium: the rotor sits inside "
            "its clearance there, so it adds no stiffness; a load or a smaller clearance "
            "brings the balls into contact")


def static_load_note(target: System | Model | str, n_balls: BallCounts = None,
                     **parameters: float) -> str | None:
    """``unloaded_note`` at the static equilibrium with the cages at angle 0 (``simulate``'s
    line), or None: every bearing carries load, or no equilibrium was found (then the
    statics say nothing about the run)."""
    try:
        system = as_system(target, n_balls, **parameters)
        found = equilibrium(system)
    except (InputError, SimulationError, np.linalg.LinAlgError):
        return None
    return unloaded_note(balls_in_contact(system, found.position))


def check_planar(coordinates: Sequence[str]) -> None:
    """Raise InputError unless the coordinates are a one-body planar model's (x, y)."""
    if list(coordinates) != ["x", "y"]:
        raise InputError(f"model: bearing coefficients kxx … kyy need a one-body planar "
                         f"model (coordinates x, y); this one has {', '.join(coordinates)}")


def bearing_coefficients(matrix: np.ndarray, coordinates: Sequence[str],
                         letter: str) -> dict[str, float]:
    """``{"kxx": …, "kxy": …, "kyx": …, "kyy": …}`` (``letter`` "k" or "c") of a one-body
    model's 2×2 matrix over (x, y); kxy = −∂F_x/∂y as ROSS's BearingElement defines it."""
    check_planar(coordinates)
    m = np.asarray(matrix, dtype=float)
    return {f"{letter}{a}{b}": float(m[i, j])
            for i, a in enumerate("xy") for j, b in enumerate("xy")}


def ross_coefficients(target: System | Model | str, speeds_rpm: Sequence[float],
                      n_balls: BallCounts = None, n_angles: int = CAGE_ANGLES,
                      **parameters: float) -> dict:
    """Cage-averaged coefficients at each shaft speed, in the keywords ROSS's
    ``BearingElement`` takes: kxx, kxy, kyx, kyy (N/m), cxx, cxy, cyx, cyy (N·s/m), one value
    per speed, and ``frequency`` (the shaft speeds, rad/s). A one-body planar model only."""
    speeds = [float(s) for s in speeds_rpm]
    if not speeds or any(not math.isfinite(s) or s < 0 for s in speeds):
        raise InputError(f"speeds: must be one or more finite speeds ≥ 0 rpm, got {speeds_rpm!r}")
    system = as_system(target, n_balls, **parameters)
    check_planar(system.state_names[:system.n_state // 2])
    out: dict[str, list[float]] = {}
    for speed in speeds:
        ds = coefficients(system.replace(speed_rpm=speed), n_angles=n_angles)
        coords = [str(c) for c in ds.row.values]
        for key, value in {**bearing_coefficients(ds.stiffness_mean.values, coords, "k"),
                           **bearing_coefficients(ds.damping_mean.values, coords, "c")}.items():
            out.setdefault(key, []).append(value)
    out["frequency"] = [s * math.pi / 30 for s in speeds]
    return out
