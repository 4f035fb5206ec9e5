"""Normal forms at the special points of a shooting branch: safe (supercritical) or dangerous
(subcritical) loss of stability.

At an LP, PD or NS point the orbit's state at the section is a fixed point of the period map
P(z; p) (``period_map``: the branch's RK4 steps, chained in the CasADi virtual machine, so
that nested forward AD gives its second and third derivatives exactly) with a critical
multiplier; ``analysis.stability.normal_forms.normal_form`` gives the fold coefficient a,
the flip coefficient c (c > 0 supercritical) or the first Lyapunov coefficient d (d < 0
supercritical), in the scaled states z / state_scale of the branch (dimensionless), with
the eigenvector of unit length there.

Non-smoothness: a ball whose contact deflection δ_i = X cos θ_i + Y sin θ_i − γ₀ (paper
Eq. 5; X, Y the bearing's race displacement, θ_i the ball's angle, γ₀ the clearance; defect
offsets not included) comes within ``CONTACT_TOLERANCE`` × γ₀ of zero at a step of the
orbit, or changes sign between two steps, makes the map non-smooth there: the Hertz law
k·δ₊^{3/2} has an unbounded second derivative at δ = 0, and the exact derivatives of the
discrete RK4 map then hold terms of a stage that happens to fall next to δ = 0, which the
flow does not have (measured on the balanced rotor, 50 N, N_b 8, PD at 8141.7 rpm: the AD
flip coefficient is −5.1·10⁴, subcritical, where simulation shows a supercritical doubling
with c ≈ +1.9·10⁴ from the period-2 amplitude). Such a point is flagged ``nonsmooth`` and
gets no coefficient.
"""

from __future__ import annotations

import math
from functools import cache

import casadi as ca
import numpy as np

from analysis.errors import InputError
from analysis.integrate.tangent import Carry, tangent_step
from analysis.stability.continuation.problem import BranchPoint
from analysis.stability.normal_forms import normal_form

CONTACT_TOLERANCE = 1e-3
"""A ball within this fraction of the clearance of the contact threshold (δ = 0) at a step
of the orbit makes the period map non-smooth there."""

KINDS = ("LP", "PD", "NS")
"""The special points that get a normal form."""


@cache
def _plain_step(model, structure: tuple[int, ...]) -> ca.Function:
    return tangent_step(model.functions(structure).rk4_step, Carry(), "plain_step").step


def period_map(prob) -> ca.Function:
    """``P(zs, p) -> zs'``: the period map of the shooting problem ``prob``
    (``ShootingProblem``) in its scaled states zs = z / s_z, its ``n_steps`` RK4 steps of
    h = T(p)/n_steps from t0 chained by ``fold`` in the virtual machine (differentiable to
    any order by CasADi's forward mode). Kept on ``prob``, so that the points of one
    branch share it and its derivative Functions."""
    key = (prob.n_steps, prob.t0, str(prob.period), np.asarray(prob.s_z, float).tobytes())
    cached = getattr(prob, "_period_map", None)
    if cached is not None and cached[0] == key:
        return cached[1]
    model, structure = prob.model, model_structure(prob)
    n, n_par = model.n_state, len(model.parameter_names)
    zs, p = ca.MX.sym("zs", n), ca.MX.sym("p", n_par)
    h = prob.period.seconds(model, structure, p) / prob.n_steps
    run = _plain_step(model, structure).fold(prob.n_steps)
    scale = ca.DM(np.asarray(prob.s_z, dtype=float))
    s_end = run(ca.vertcat(zs * scale, 0),
                *(ca.repmat(x, 1, prob.n_steps) for x in (p, h, prob.t0)))
    fn = ca.Function("period_map", [zs, p], [s_end[:n] / scale])
    prob._period_map = (key, fn)  # one map (so one set of derivative Functions) per branch
    return fn


def model_structure(prob) -> tuple[int, ...]:
    return prob.model.structure(prob.structure)


def ball_deflections(prob, z0: np.ndarray, lam: float, p: np.ndarray | None = None
                     ) -> np.ndarray:
    """δ (m) of every ball of every bearing (rows, bearing by bearing) at the section and
    after each RK4 step of the orbit through ``z0`` at ``lam`` (columns): the paper's Eq. 5
    with the bearing's station map, cage speed and clearance (the first clearance-role
    parameter of the bearing, half a diametral one); empty for a model without bearings."""
    model = prob.model
    module = model.module
    p = prob.p(lam) if p is None else p
    states = np.column_stack([z0, np.asarray(prob.orbit(z0, prob.t0, p))])
    h = float(prob.period.seconds(model, model_structure(prob), p)) / prob.n_steps
    t = prob.t0 + h * np.arange(states.shape[1])
    clearances = model.role("clearance")
    rows = []
    for k, (row, n_balls) in enumerate(zip(module.BEARINGS, model_structure(prob),
                                           strict=True)):
        name = row[0]
        x = sum(ax * states[j] for j, ax, _ in getattr(module, f"station_map_{name}")(p))
        y = sum(ay * states[j] for j, _, ay in getattr(module, f"station_map_{name}")(p))
        gamma = _clearance(model, clearances, k, p)
        psi = float(model.cage_speed(name, p)) * t
        for i in range(n_balls):
            theta = 2 * math.pi * i / n_balls + psi
            rows.append(x * np.cos(theta) + y * np.sin(theta) - gamma)
    return np.array(rows).reshape(-1, states.shape[1])


def _clearance(model, names: tuple[str, ...], k: int, p: np.ndarray) -> float:
    if not names:
        return 0.0
    name = names[min(k, len(names) - 1)]
    value = float(p[model.parameter_names.index(name)])
    return value / 2 if "diametral" in name else value


def at_contact_threshold(prob, z0: np.ndarray, lam: float, p: np.ndarray | None = None
                         ) -> bool:
    """Whether a ball's deflection is within ``CONTACT_TOLERANCE`` × its clearance of zero
    at a step of the orbit, or changes sign between two steps (``ball_deflections``; ``p``
    the parameter vector when it is not ``prob.p(lam)``, e.g. on a two-parameter curve)."""
    p = prob.p(lam) if p is None else p
    delta = ball_deflections(prob, z0, lam, p)
    if delta.size == 0:
        return False
    scale = max(abs(_clearance(prob.model, prob.model.role("clearance"), 0, p)),
                float(np.abs(delta).max()) * 1e-6, 1e-12)
    near = np.abs(delta) <= CONTACT_TOLERANCE * scale
    crossing = np.sign(delta[:, 1:]) * np.sign(delta[:, :-1]) < 0
    return bool(near.any() or crossing.any())


ORBIT_OFFSET = 1e-3
"""How far past a non-smooth PD (× the parameter's scale in the unknowns) its period-2 orbit
is solved for (``orbit_criticality``)."""
ORBIT_GUESSES = (1e-4, 3e-4, 1e-3, 3e-3, 1e-2)
"""Kicks along the critical eigenvector (scaled states) from which Newton looks for it."""
ORBIT_LIMIT = 0.05
"""Largest half-difference of a period-2 orbit's two section states (scaled) that counts
as the small orbit born at the point."""


def _newton(prob, z: np.ndarray, p: np.ndarray, iterates: int, tol: float = 1e-10,
            max_iter: int = 30) -> np.ndarray | None:
    """A fixed point of the ``iterates``-th iterate of the period map from ``z`` (the
    branch's compiled flow map and its monodromy matrices), or None."""
    from analysis.integrate.flow import evaluate

    s = np.asarray(prob.s_z, dtype=float)
    for _ in range(max_iter):
        x, jac = z, np.eye(z.size)
        for _ in range(iterates):
            x, mono, _ = evaluate(prob.flow, x, prob.t0, p)
            jac = mono @ jac
        res = (x - z) / s
        if not np.all(np.isfinite(res)):
            return None
        if np.abs(res).max() < tol:
            return z
        step = np.linalg.solve((jac - np.eye(z.size)) * s[None, :] / s[:, None], -res)
        z = z + step * s
    return None


def _monodromy(prob, z: np.ndarray, p: np.ndarray, iterates: int) -> tuple[np.ndarray, list]:
    from analysis.integrate.flow import evaluate

    jac, states = np.eye(z.size), [z]
    for _ in range(iterates):
        z, mono, _ = evaluate(prob.flow, z, prob.t0, p)
        jac = mono @ jac
        states.append(z)
    return jac, states


def orbit_criticality(prob, point: BranchPoint) -> str | None:
    """The criticality of the period doubling ``point`` from the period-2 orbit born there,
    where the map is not smooth enough for the normal form: ``ORBIT_OFFSET`` × the
    parameter's scale to each side, the period-1 orbit is solved (Newton on the branch's
    flow map) and, from kicks along its critical eigenvector (``ORBIT_GUESSES``), a small
    period-2 orbit (half-difference below ``ORBIT_LIMIT`` in the scaled states, not the
    period-1 orbit). "supercritical": a stable one on the side where the period-1 orbit is
    unstable; "subcritical": an unstable one on the side where it is stable; None when
    neither is found."""
    s = np.asarray(prob.s_z, dtype=float)
    for side in (1.0, -1.0):
        p = prob.p(point.lam + side * ORBIT_OFFSET * prob.s_lam)
        one = _newton(prob, point.z0, p, 1)
        if one is None:
            continue
        mono, _ = _monodromy(prob, one, p, 1)
        mu, vectors = np.linalg.eig(mono)
        k = int(np.argmin(mu.real))
        unstable = mu[k].real < -1
        v = np.real(vectors[:, k]) / s
        v = v / np.linalg.norm(v)
        for kick in ORBIT_GUESSES:
            two = _newton(prob, one + kick * v * s, p, 2)
            if two is None:
                continue
            mono2, states = _monodromy(prob, two, p, 2)
            half = np.abs((states[1] - states[0]) / s).max() / 2
            if not 1e-8 < half < ORBIT_LIMIT:
                continue
            stable = bool(np.all(np.abs(np.linalg.eigvals(mono2)) < 1))
            if unstable and stable:
                return "supercritical"
            if not unstable and not stable:
                return "subcritical"
    return None


def point_normal_form(prob, point: BranchPoint) -> dict:
    """``{"coefficient": c, "criticality": …, "nonsmooth": bool}`` of the LP, PD or NS
    ``point`` of the branch of ``prob``: the coefficient of ``normal_forms.normal_form``
    for the period map in the scaled states (criticality None at a fold), or no
    coefficient and ``nonsmooth`` True where a ball is at the contact threshold."""
    kind = point.special
    if kind not in KINDS:
        raise InputError(f"point: LP, PD or NS points have a normal form, got '{kind}'")
    if at_contact_threshold(prob, point.z0, point.lam):
        crit = orbit_criticality(prob, point) if kind == "PD" else None
        return {"coefficient": None, "criticality": crit, "nonsmooth": True}
    nf = normal_form(period_map(prob), point.z0 / prob.s_z, prob.p(point.lam), kind=kind)
    return {**nf.as_dict(), "nonsmooth": False}


def branch_normal_forms(prob, points: list[BranchPoint]) -> tuple[np.ndarray, np.ndarray]:
    """Per point of a branch: the normal-form coefficient (NaN where none) and the label
    ("supercritical", "subcritical", "fold", "nonsmooth" or "")."""
    coefficient = np.full(len(points), np.nan)
    label = np.array([""] * len(points), dtype=object)
    for j, point in enumerate(points):
        if point.special not in KINDS:
            continue
        try:
            out = point_normal_form(prob, point)
        except (InputError, np.linalg.LinAlgError):  # no critical multiplier of that kind
            continue
        if out["nonsmooth"]:
            label[j] = "nonsmooth" + (f" {out['criticality']}" if out["criticality"] else "")
            continue
        coefficient[j] = out["coefficient"]
        label[j] = out["criticality"] or "fold"
    return coefficient, label
