"""Two-parameter continuation of fold (LP), period-doubling (PD) and Neimark–Sacker (NS)
points of periodic orbits, with detection of codimension-two points.

A codimension-one point of a branch file (``analysis.stability.continuation``) is followed in
a second runtime parameter. Unknowns, all scaled as in ``continuation``:
``w = (z0 / s_z, [κ], λ1 / s_1, λ2 / s_2)``: the orbit's state at the section, for NS the
cosine κ = cos θ of the critical multipliers e^{±iθ}, the branch's parameter λ1 and the new
one λ2. Equations (a *minimally augmented* system, Govaerts, "Numerical Methods for
Bifurcations of Dynamical Equilibria", SIAM 2000, Ch. 4; Kuznetsov, "Elements of Applied
Bifurcation Theory", 3rd ed., Sec. 10.3):

* the periodic orbit, (Φ_T(z0; λ1, λ2) − z0) / s_z = 0 (n equations);
* the bordered test function(s) of A, with M̃ = S⁻¹ M S the scaled monodromy matrix
  (same multipliers), A = M̃ − I (LP), M̃ + I (PD) or M̃² − 2κ M̃ + I (NS):
  ``[[A, B], [Cᵀ, 0]] [V; G] = [0; I_r]`` with r = 1 (LP, PD: G = g = 0) or r = 2 (NS: two
  entries of the 2 × 2 matrix G vanish, the pair chosen for the best-conditioned Jacobian,
  Govaerts, Kuznetsov & Dhooge, SIAM J. Sci. Comput. 27 (2005) 231, for maps).
  B and C are the previous point's left and right null vectors (updated after every point,
  as MatCont does), so A's null vectors V and the left ones W (transposed system) keep
  their orientation along the curve.

Derivatives: the orbit rows from the flow map's AD (monodromy, ∂Φ/∂λ with the period's own
dependence on λ); the test rows from ∂g_ij/∂x = −W_iᵀ (∂A/∂x) V_j, where ∂A/∂x needs the
second derivatives of Φ: the gradients of the bilinear forms aᵀ M(z0, p) b with respect to
z0 and p are computed by reverse-mode AD (CasADi) through the RK4 flow map in the virtual
machine (``bilinear_gradients``): exact derivatives of the discrete map, no finite
differences. Keller's pseudo-arclength condition closes the system (``continuation.correct``).

Codimension-two points, located by bisection on the arclength where their test function
changes sign (Kuznetsov Sec. 9.2 and Ch. 9 for maps; the MatCont manual's LPC/PD/NS
curves), are the curve family's ``found_between`` hook of the one engine
(``continuation.trace``), the borders' update its ``after_accept`` and the end solved on
the bound its ``past_end``:

* on LP curves: CP (cusp: the fold's normal-form coefficient a = ½ pᵀB(q, q) vanishes),
  R1 (1:1 resonance: the +1 multiplier becomes a Jordan block, pᵀq = 0 with the null
  vectors q, p of M − I and Mᵀ − I), LPPD (fold–flip: det(M + I) = 0), LPNS (fold–NS: a
  complex pair crosses the unit circle);
* on PD curves: R2 (1:2 resonance: −1 becomes a Jordan block, pᵀq = 0), LPPD
  (det(M − I) = 0), PDNS (flip–NS), GPD (generalised flip: the flip coefficient c of
  ``normal_forms`` changes sign, the criticality changes);
* on NS curves: R1 (κ = 1), R2 (κ = −1), R3 (κ = −1/2), R4 (κ = 0), LPNS (det(M − I) = 0),
  PDNS (det(M + I) = 0), CH (Chenciner: the first Lyapunov coefficient d changes sign).
  GPD and CH need a smooth map: where a ball is at the contact threshold their test
  functions are NaN and no sign change is counted. Beyond |κ| = 1 the NS curve continues
  as a neutral saddle (real multipliers μ, 1/μ), not an NS curve.

Degenerate (conservative) systems whose test functions vanish identically along the curve
(the undamped Mathieu equation: −1 is a double multiplier everywhere on its PD curve) get
no label: a sign change counts only when the test function exceeds ``TEST_GUARD`` at one of
the two points.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.flow import Period, evaluate
from analysis.integrate.tangent import Carry, tangent_step
from analysis.model import Model, Structure
from analysis.provenance import run_attrs, system_of_attrs
from analysis.stability.continuation import (
    ContinuationOptions,
    ContinuedRange,
    Hooks,
    Newton,
    ShootingProblem,
    StepGuards,
    correct,
    options_with,
    orbit_scale,
    tangent,
    trace,
)

KINDS = ("LP", "PD", "NS")
TEST_GUARD = 1e-6
"""A sign change of a codimension-two test function counts only when |test| exceeds this
at one of the two points (test functions are normalised: dimensionless, O(1))."""
NS_ENTRIES = ((0, 0), (0, 1), (1, 0), (1, 1))


@cache
def bilinear_gradients(model: Model, structure: Structure, period: Period, n_steps: int,
                       r: int) -> ca.Function:
    """``grad(z0, t0, p, A, B) -> (Gz, Gp)``: column i of Gz (n × r) and Gp (n_par × r) is
    the gradient with respect to z0 and p of the bilinear form a_iᵀ M(z0, t0, p) b_i (A, B:
    n × r), M the monodromy matrix of the RK4 map of ``flow.flow_map`` (``n_steps`` steps
    of h = T(p)/n_steps, the period's dependence on p included).

    M b_i is carried step by step as a tangent vector (Y' = A Y: ``tangent.tangent_step``
    with ``s = [z; k; vec(Y)]``, z the state after step k at time ``t0 + k·h``) and the
    gradient of aᵀ M b is taken by reverse-mode AD (CasADi, virtual machine) through those
    steps: the second derivatives of the discrete RK4 map, exactly, at the cost of a few
    flows of n (r + 1) states. These give ∂A/∂x of the bordered test functions, and the
    fold's normal-form coefficient pᵀB(q, q) = ∇_z(pᵀ M q)·q."""
    structure = model.structure(structure)
    n, n_par = model.n_state, len(model.parameter_names)
    z0, t0, p = ca.MX.sym("z0", n), ca.MX.sym("t0"), ca.MX.sym("p", n_par)
    a, b = ca.MX.sym("a", n, r), ca.MX.sym("b", n, r)
    h = period.seconds(model, structure, p) / n_steps
    step = tangent_step(model.functions(structure).rk4_step, Carry(directions=r),
                        "tangent_step").step
    run = step.fold(n_steps)
    s_end = run(ca.vertcat(z0, 0, ca.vec(b)),
                *(ca.repmat(x, 1, n_steps) for x in (p, h, t0)))
    y = ca.reshape(s_end[n + 1:], n, r)
    phi = ca.sum1(a * y).T
    return ca.Function("bilinear_gradients", [z0, t0, p, a, b],
                       [ca.jacobian(phi, z0).T, ca.jacobian(phi, p).T],
                       ["z0", "t0", "p", "A", "B"], ["Gz", "Gp"])


def bordered(a: np.ndarray, b: np.ndarray, c: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve ``[[A, B], [Cᵀ, 0]] [V; G] = [0; I_r]`` and its transpose
    ``[[Aᵀ, C], [Bᵀ, 0]] [W; G] = [0; I_r]`` (B, C: n × r). Returns V, W (n × r) and G
    (r × r); G is singular exactly where A has a null space of dimension r (Govaerts
    2000, Sec. 3.2)."""
    n, r = b.shape
    big = np.block([[a, b], [c.T, np.zeros((r, r))]])
    rhs = np.vstack([np.zeros((n, r)), np.eye(r)])
    sol = np.linalg.solve(big, rhs)
    w = np.linalg.solve(big.T, rhs)[:n]
    return sol[:n], w, sol[n:]


@dataclass
class CurvePoint:
    """One converged point of a codimension-one curve (parameters in their own units)."""

    w: np.ndarray
    lam1: float
    lam2: float
    kappa: float
    z0: np.ndarray
    multipliers: np.ndarray
    tangent: np.ndarray
    right: np.ndarray
    """Right null vector(s) V of A (scaled coordinates), n × r."""
    left: np.ndarray
    """Left null vector(s) W of A (scaled coordinates), n × r."""
    tests: dict[str, float]
    amplitude: float
    special: str = ""
    newton_iterations: int = 0
    marked: bool = False
    ds: float = 0.0
    angle: float = 0.0
    contraction: float = 0.0


@dataclass
class _CurveProblem(ShootingProblem):
    """``continuation.ShootingProblem`` with a second parameter and the augmented equations:
    the curve family of the engine, bounded by the second parameter (``param_name``; the
    branch's is ``param1``)."""

    kind: str = "LP"
    index2: int = 0
    s_lam2: float = 1.0
    borders: tuple[np.ndarray, np.ndarray] | None = None
    entries: tuple[tuple[int, int], ...] = ((0, 0),)
    cache_: dict = field(default_factory=dict)

    def __post_init__(self):
        super().__post_init__()
        self.r = 2 if self.kind == "NS" else 1
        self.grad = bilinear_gradients(self.model, self.structure, self.period, self.n_steps,
                                       8 if self.kind == "NS" else 1)

    @property
    def param1(self) -> str:
        """The branch's parameter."""
        return self.model.parameter_names[self.param_index]

    @property
    def param_name(self) -> str:
        """The second parameter, whose range bounds the curve."""
        return self.model.parameter_names[self.index2]

    def point(self, corrected: Newton, tau: np.ndarray) -> CurvePoint:
        """The ``CurvePoint`` of a converged corrector with unit tangent ``tau``."""
        w = corrected.w
        e = self.evaluate_all(w)
        z, kappa, lam1, lam2 = self.split(w)
        return CurvePoint(w=w.copy(), lam1=lam1, lam2=lam2, kappa=kappa, z0=z,
                          multipliers=np.linalg.eigvals(e["mono"]), tangent=tau,
                          right=e["v"].copy(), left=e["wl"].copy(),
                          tests=_tests(self, e, kappa), amplitude=self.amplitude(w),
                          newton_iterations=corrected.iterations)

    def unknowns(self, point: CurvePoint) -> np.ndarray:
        return point.w

    def value(self, point: CurvePoint) -> float:
        return point.lam2

    def describe(self, point: CurvePoint) -> str:
        return f"{self.param1} = {point.lam1:.6g}, {self.param_name} = {point.lam2:.6g}"

    @property
    def n_extra(self) -> int:
        """Unknowns after z0: [κ,] λ1, λ2."""
        return 3 if self.kind == "NS" else 2

    def split(self, w: np.ndarray) -> tuple[np.ndarray, float, float, float]:
        """(z0, κ, λ1, λ2) in model units from the scaled unknowns (κ = NaN unless NS)."""
        n = self.n
        kappa = float(w[n]) if self.kind == "NS" else math.nan
        return w[:n] * self.s_z, kappa, w[-2] * self.s_lam, w[-1] * self.s_lam2

    def pw(self, lam1: float, lam2: float) -> np.ndarray:
        p = self.p(lam1)
        p[self.index2] = lam2
        return p

    def matrix(self, ms: np.ndarray, kappa: float) -> np.ndarray:
        """A(M̃, κ) of the test functions."""
        eye = np.eye(self.n)
        if self.kind == "LP":
            return ms - eye
        if self.kind == "PD":
            return ms + eye
        return ms @ ms - 2 * kappa * ms + eye

    def _test_rows(self, ms, kappa, v, wl, z, p) -> np.ndarray:
        """∂g_ij/∂(x, [κ,] λ1, λ2) of the entries ``self.entries`` (NS: all four, rows in
        NS_ENTRIES order; LP, PD: one) in the scaled unknowns."""
        entries = NS_ENTRIES if self.kind == "NS" else ((0, 0),)
        lefts, rights = [], []
        for i, j in entries:
            if self.kind == "NS":  # ∂(M̃² − 2κM̃) = ∂M̃ (M̃ − 2κ) + M̃ ∂M̃
                lefts += [wl[:, i], ms.T @ wl[:, i]]
                rights += [(ms - 2 * kappa * np.eye(self.n)) @ v[:, j], v[:, j]]
            else:
                lefts.append(wl[:, i])
                rights.append(v[:, j])
        a = np.column_stack(lefts) / self.s_z[:, None]
        b = np.column_stack(rights) * self.s_z[:, None]
        gz, gp = (np.asarray(m) for m in self.grad(z, self.t0, p, a, b))
        per = len(lefts) // len(entries)
        gz = gz.reshape(self.n, len(entries), per).sum(axis=2)
        gp = gp.reshape(-1, len(entries), per).sum(axis=2)
        rows = [-(gz * self.s_z[:, None]).T]
        if self.kind == "NS":
            rows.append(np.array([[2 * wl[:, i] @ ms @ v[:, j]] for i, j in entries]))
        rows.append(-np.column_stack([gp[self.param_index] * self.s_lam,
                                      gp[self.index2] * self.s_lam2]))
        return np.hstack(rows)

    def evaluate_all(self, w: np.ndarray) -> dict:
        """Everything at w: residual, Jacobian, monodromy, null vectors, G (cached by w)."""
        key = w.tobytes()
        if key in self.cache_:
            return self.cache_[key]
        n = self.n
        z, kappa, lam1, lam2 = self.split(w)
        p = self.pw(lam1, lam2)
        z_end, mono, dp = evaluate(self.flow, z, self.t0, p)
        ms = mono * self.s_z[None, :] / self.s_z[:, None]
        jz = ms - np.eye(n)
        jp = dp[:, [self.param_index, self.index2]] * np.array(
            [self.s_lam, self.s_lam2])[None, :] / self.s_z[:, None]
        orbit = np.hstack([jz, np.zeros((n, self.n_extra - 2)), jp])
        b, c = self.borders
        v, wl, g = bordered(self.matrix(ms, kappa), b, c)
        rows = self._test_rows(ms, kappa, v, wl, z, p) if np.all(np.isfinite(ms)) else \
            np.full((len(NS_ENTRIES) if self.kind == "NS" else 1, n + self.n_extra), np.nan)
        out = dict(g_orbit=(z_end - z) / self.s_z, orbit_jac=orbit, mono=mono, ms=ms,
                   v=v, wl=wl, G=g, test_rows=rows, z=z, p=p)
        self.cache_.clear()
        self.cache_[key] = out
        return out

    def residual(self, w: np.ndarray):
        """H(w) (n + r), its Jacobian ((n + r) × (n + r + 1)) and the monodromy matrix:
        the interface of ``continuation.correct``."""
        e = self.evaluate_all(w)
        entries = NS_ENTRIES if self.kind == "NS" else ((0, 0),)
        idx = [entries.index(ij) for ij in self.entries]
        h = np.concatenate([e["g_orbit"], [e["G"][i, j] for i, j in self.entries]])
        return h, np.vstack([e["orbit_jac"], e["test_rows"][idx]]), e["mono"]

    def amplitude(self, w: np.ndarray) -> float:
        """Half the peak-to-peak of the first state variable over one period (its unit)."""
        z, _, lam1, lam2 = self.split(w)
        states = np.asarray(self.orbit(z, self.t0, self.pw(lam1, lam2)))
        return float(np.ptp(states[0])) / 2

    def choose_entries(self, w: np.ndarray) -> None:
        """NS: the two entries of G whose rows give the best-conditioned Jacobian."""
        if self.kind != "NS":
            return
        e = self.evaluate_all(w)
        best, best_sigma = self.entries, -1.0
        for k1 in range(4):
            for k2 in range(k1 + 1, 4):
                jac = np.vstack([e["orbit_jac"], e["test_rows"][[k1, k2]]])
                sigma = np.linalg.svd(jac, compute_uv=False)[-1]
                if sigma > best_sigma:
                    best, best_sigma = (NS_ENTRIES[k1], NS_ENTRIES[k2]), sigma
        self.entries = best

    def update_borders(self, point: CurvePoint) -> None:
        """B, C := the point's left and right null vectors, orthonormalised."""
        self.borders = (np.linalg.qr(point.left)[0] * np.sign(np.diag(
            np.linalg.qr(point.left)[1]))[None, :],
            np.linalg.qr(point.right)[0] * np.sign(np.diag(
                np.linalg.qr(point.right)[1]))[None, :])


# --- codimension-two test functions ---------------------------------------------------

def _unit_pairing(v: np.ndarray, wl: np.ndarray) -> float:
    """pᵀq of the unit null vectors: 0 where the critical multiplier is a Jordan block."""
    return float(wl[:, 0] @ v[:, 0] / (np.linalg.norm(wl[:, 0]) * np.linalg.norm(v[:, 0])))


def _det_other(ms: np.ndarray, shift: float) -> float:
    """det(M̃ + shift·I) over the multipliers, normalised by its largest factor."""
    mu = np.linalg.eigvals(ms)
    return float(np.real(np.prod((mu + shift) / np.maximum(1.0, np.abs(mu + shift)))))


def _normal_form(prob: _CurveProblem, e: dict) -> float:
    """Fold normal-form coefficient a = ½ pᵀB(q, q) with |q| = 1, pᵀq = 1 (Kuznetsov
    Sec. 9.2 (maps): the cusp where a = 0); B(q, q) = ∂_z(M̃ q)·q by ``bilinear_gradients``
    (scaled coordinates); q and p oriented by the borders (continuous along the curve)."""
    v, wl = e["v"][:, 0], e["wl"][:, 0]
    row = -e["test_rows"][0][:prob.n]  # ∂(pᵀM̃q)/∂z
    return float(0.5 * (row @ v) / (np.linalg.norm(v) * (wl @ v)))


def _tests(prob: _CurveProblem, e: dict, kappa: float) -> dict[str, float]:
    """The codimension-two test functions of the curve's kind at one point."""
    ms, v, wl = e["ms"], e["v"], e["wl"]
    if prob.kind == "LP":
        return {"CP": _normal_form(prob, e), "R1": _unit_pairing(v, wl),
                "LPPD": _det_other(ms, 1.0), "LPNS": _complex_outside(ms)}
    if prob.kind == "PD":
        return {"R2": _unit_pairing(v, wl), "LPPD": _det_other(ms, -1.0),
                "PDNS": _complex_outside(ms), "GPD": _criticality_test(prob, e)}
    return {"R1": kappa - 1, "R2": kappa + 1, "R3": kappa + 0.5, "R4": kappa,
            "LPNS": _det_other(ms, -1.0), "PDNS": _det_other(ms, 1.0),
            "CH": _criticality_test(prob, e)}


def _criticality_test(prob: _CurveProblem, e: dict) -> float:
    """The flip coefficient c (PD curves: GPD, the generalised flip, where it changes
    sign) or the first Lyapunov coefficient d (NS curves: CH, the Chenciner point) of the
    period map at the point (``continuation.normal_form``, in the scaled states); NaN where
    a ball is at the contact threshold (the map is not smooth: no coefficient) or no
    critical multiplier of the kind is found."""
    from analysis.stability.continuation.normal_form import at_contact_threshold, period_map
    from analysis.stability.normal_forms import normal_form

    z, p = e["z"], e["p"]
    if not np.all(np.isfinite(z)) or at_contact_threshold(prob, z, 0.0, p):
        return math.nan
    try:
        return normal_form(period_map(prob), z / prob.s_z, p, kind=prob.kind).coefficient
    except (InputError, np.linalg.LinAlgError):
        return math.nan


def _complex_outside(ms: np.ndarray) -> float:
    """Number of complex multipliers outside the unit circle, + 0.5 (a step function whose
    change marks a complex pair crossing the circle; a critical NS pair on the curve
    itself is not counted: |μ| within 1e-6 of 1)."""
    mu = np.linalg.eigvals(ms)
    return float(np.sum((np.abs(mu.imag) > 1e-9) & (np.abs(mu) > 1 + 1e-6))) + 0.5


def _make_point(prob: _CurveProblem, w: np.ndarray, jac: np.ndarray, previous, direction,
                iterations: int) -> CurvePoint:
    """The point at the converged ``w``, its tangent by SVD along ``previous`` (None: by
    ``direction``)."""
    return prob.point(Newton(w, jac, None, iterations, 0.0, 0.0),
                      tangent(jac, previous, direction))


def _locate(prob: _CurveProblem, a: CurvePoint, b: CurvePoint, label: str,
            tol: float, iterations: int = 14) -> CurvePoint:
    """Bisection on the chord from a to b (each trial corrected onto the curve) for the sign
    change of the test ``label``."""
    chord = (b.w - a.w) / np.linalg.norm(b.w - a.w)
    sign_a = np.sign(a.tests[label])
    lo, hi, best = 0.0, 1.0, None
    for _ in range(iterations):
        mid = (lo + hi) / 2
        out = correct(prob, a.w + mid * (b.w - a.w), chord, tol)
        if out is None:
            break
        best = _make_point(prob, out[0], out[1], a.tangent, 1.0, out[3])
        if np.sign(best.tests[label]) == sign_a:
            lo = mid
        else:
            hi = mid
    best = best or b
    best.special = label
    return best


def _codim2(prob: _CurveProblem, a: CurvePoint, b: CurvePoint, tol: float
            ) -> list[CurvePoint]:
    """Codimension-two points between two consecutive points of the curve."""
    found = []
    for label, fa in a.tests.items():
        fb = b.tests[label]
        if not (math.isfinite(fa) and math.isfinite(fb)):
            continue  # no value at one end (GPD, CH at a non-smooth point)
        if np.sign(fa) != np.sign(fb) and fa != 0 and max(abs(fa), abs(fb)) > TEST_GUARD:
            found.append(_locate(prob, a, b, label, tol))
    return found


def _at_value(prob: _CurveProblem, a: CurvePoint, b: CurvePoint, index: int, value: float,
              tol: float) -> CurvePoint | None:
    """The point of the curve between a and b where unknown ``index`` (scaled) equals
    ``value``: Newton with that unknown fixed, from the linear interpolation."""
    t = (value - a.w[index]) / (b.w[index] - a.w[index])
    guess = a.w + t * (b.w - a.w)
    guess[index] = value
    out = correct(prob, guess, np.eye(len(guess))[index], tol)
    if out is None:
        return None
    return _make_point(prob, out[0], out[1], a.tangent, 1.0, out[3])


# --- the start point ----------------------------------------------------------------

POINT_SYNTAX = re.compile(r"^(LP|PD|NS)(?:\[(\d+)\])?$")


def parse_point(text: str) -> tuple[str, int]:
    """``"PD"`` -> ("PD", 1); ``"NS[2]"`` -> ("NS", 2): the k-th point (from 1, in the
    branch's order) labelled LP, PD or NS."""
    match = POINT_SYNTAX.match(text.strip())
    if not match or (match.group(2) is not None and int(match.group(2)) < 1):
        raise InputError(f"point: must be LP, PD or NS, optionally with [k] (k = 1, 2, … "
                         f"along the branch), got {text!r}")
    return match.group(1), int(match.group(2) or 1)


def _branch_index(branch: xr.Dataset, kind: str, k: int) -> int:
    labels = [str(s) for s in branch.special.values]
    where = [i for i, s in enumerate(labels) if s == kind]
    if len(where) < k:
        found = ", ".join(f"{s}" for s in labels if s) or "none"
        raise InputError(f"point: the branch has {len(where)} {kind} point(s), not {k} "
                         f"(special points: {found})")
    return where[k - 1]


def _initial_kappa(multipliers: np.ndarray) -> float:
    """cos θ of the complex pair nearest the unit circle (an NS point of the branch)."""
    mu = multipliers[np.abs(multipliers.imag) > 1e-12]
    if len(mu) == 0:
        raise InputError("point: no complex multipliers at this NS point")
    pick = mu[np.argmin(np.abs(np.abs(mu) - 1))]
    return float(pick.real / abs(pick))


def _initial_borders(prob: _CurveProblem, w: np.ndarray) -> None:
    """B, C from the singular vectors of A's smallest singular values at the start."""
    z, kappa, lam1, lam2 = prob.split(w)
    mono = evaluate(prob.flow, z, prob.t0, prob.pw(lam1, lam2))[1]
    ms = mono * prob.s_z[None, :] / prob.s_z[:, None]
    u, _, vt = np.linalg.svd(prob.matrix(ms, kappa))
    prob.borders = (u[:, -prob.r:], vt[-prob.r:].T)


# --- the curve --------------------------------------------------------------------------

CURVE_OPTIONS = ContinuationOptions(max_points=300)
"""The default settings of a curve: ``ContinuationOptions()`` with 300 points."""


def continue_curve(branch: xr.Dataset | str | Path, point: str, *, param: str, stop: float,
                   ds: float | None = None, ds_min: float | None = None,
                   ds_max: float | None = None, max_points: int | None = None,
                   tol: float | None = None, marks: Sequence[float] = (),
                   progress: Callable[[str], None] | None = None,
                   options: ContinuationOptions | None = None) -> xr.Dataset:
    """Follow the LP, PD or NS point ``point`` (``"PD"``, ``"LP[2]"``, …: ``parse_point``)
    of ``branch`` (a Dataset or netCDF file of ``continuation.continue_orbits``) in the
    branch's parameter and ``param``, from the branch's value of ``param`` towards ``stop``
    (its unit).

    The curve ends where ``param`` leaves the interval between its start value and ``stop``
    (that end point solved exactly at the bound), after ``max_points`` points or when the
    step falls below ``ds_min``. ``marks``: values of ``param`` where a point is solved
    exactly (``marked`` = 1), e.g. to compare with an independent solution. ``options``:
    the steps, point budget and tolerance (``continuation.ContinuationOptions``, its guards
    unused; default ``CURVE_OPTIONS``); each of ``ds``, ``ds_min``, ``ds_max``,
    ``max_points``, ``tol`` that is given replaces its field. The steps are scaled
    arclength steps (``param`` scaled by |stop − start|, the branch parameter by its range
    on the branch). The RK4 step count per period is the branch's. Returns the curve as a
    Dataset (``curve_dataset``).
    """
    options = options_with(options, CURVE_OPTIONS, ds=ds, ds_min=ds_min, ds_max=ds_max,
                           max_points=max_points, tol=tol)
    tol = options.tol
    ContinuedRange.finite_stop(stop)
    source = "" if isinstance(branch, xr.Dataset) else str(branch)
    if not isinstance(branch, xr.Dataset):
        from analysis.io import open_result

        branch = open_result(branch)
    if "special" not in branch or "param" not in branch.attrs:
        raise InputError("branch: not a branch file of `bearingdyn continue` (no special "
                         "points)")
    kind, k = parse_point(point)
    index = _branch_index(branch, kind, k)
    prob, w = _start_problem(branch, index, kind, param, stop)
    start = w[-1] * prob.s_lam2
    direction = math.copysign(1.0, stop - start)
    _initial_borders(prob, w)
    out = correct(prob, w, np.eye(len(w))[-1], tol)  # solve at the start value of param
    if out is None:
        raise InputError(f"point: the {kind} point at {prob.param1} = "
                         f"{float(w[-2] * prob.s_lam):g} does not converge as a {kind} "
                         f"point of the augmented system")
    prob.choose_entries(out[0])
    out = correct(prob, out[0], np.eye(len(w))[-1], tol)
    first = _make_point(prob, out[0], out[1], None, direction, out[3])
    prob.update_borders(first)
    first.ds = options.first_ds
    out = trace(prob, first, stop, dataclasses.replace(options, guards=StepGuards(active=False)),
                hooks=_curve_hooks(prob, marks, tol, (min(start, stop), max(start, stop))),
                progress=progress)
    return curve_dataset(prob, out.points, param, out.status, kind,
                         source or str(branch.encoding.get("source", "")))


def _start_problem(branch: xr.Dataset, index: int, kind: str, param: str, stop: float
                   ) -> tuple[_CurveProblem, np.ndarray]:
    attrs = branch.attrs
    p1 = str(attrs["param"])
    lam1 = float(branch[p1].values[index])
    system = system_of_attrs({**attrs, p1: lam1})
    model = system.model
    ContinuedRange.check(model, param, system.parameters.get(param, math.nan), stop,
                         exclude=p1)
    values = dict(system.parameters)
    start = values[param]
    n = model.n_state
    lam_range = float(np.ptp(branch[p1].values)) or abs(lam1) or 1.0
    prob = _CurveProblem(model, system.structure, Period.parse(str(attrs["period"])),
                         model.parameter_names.index(p1), values, float(attrs["t0"]),
                         int(attrs["steps_per_period"]), np.ones(n), lam_range, kind=kind,
                         index2=model.parameter_names.index(param),
                         s_lam2=abs(stop - start))
    z0 = branch.z0.values[index].astype(float)
    scale = orbit_scale(prob, z0)
    prob.s_z = scale if np.max(scale) > 1e-100 else np.ones(n)  # the origin: unit scales
    extra = [_initial_kappa(branch_multipliers(branch, index))] if kind == "NS" else []
    w = np.concatenate([z0 / prob.s_z, extra, [lam1 / prob.s_lam, start / prob.s_lam2]])
    return prob, w


def branch_multipliers(branch: xr.Dataset, index: int) -> np.ndarray:
    """The Floquet multipliers of point ``index`` of a branch file."""
    return branch.multiplier_real.values[index] + 1j * branch.multiplier_imag.values[index]


def _curve_hooks(prob: _CurveProblem, marks: Sequence[float], tol: float,
                 box: tuple[float, float]) -> Hooks:
    """The curve family's plug-ins of the engine: the codimension-two points and the marks
    between two points (``found_between``), the end solved on the bound of ``box``
    (``past_end``) and the borders and NS entries updated after each point
    (``after_accept``)."""
    lo, hi = box

    def found_between(prev: CurvePoint, point: CurvePoint) -> list[CurvePoint]:
        found = _codim2(prob, prev, point, tol) + _marks(prob, prev, point, marks, tol)
        return sorted(found, key=lambda f: float(np.dot(f.w - prev.w, prev.tangent)))

    def past_end(prev: CurvePoint, point: CurvePoint, found: list
                 ) -> tuple[list, CurvePoint]:
        bound = lo if point.lam2 < lo else hi
        end = _at_value(prob, prev, point, len(point.w) - 1, bound / prob.s_lam2, tol)
        return [f for f in found if lo <= f.lam2 <= hi], end or point

    def after_accept(point: CurvePoint) -> None:
        prob.update_borders(point)
        prob.choose_entries(point.w)

    return Hooks(found_between=found_between, past_end=past_end, after_accept=after_accept)


def _marks(prob: _CurveProblem, a: CurvePoint, b: CurvePoint, marks: Sequence[float],
           tol: float) -> list[CurvePoint]:
    """Points solved exactly where ``param`` passes a value of ``marks`` between a and b."""
    out = []
    for value in marks:
        if (a.lam2 - value) * (b.lam2 - value) < 0:
            found = _at_value(prob, a, b, len(a.w) - 1, value / prob.s_lam2, tol)
            if found is not None:
                found.marked = True
                out.append(found)
    return out


def curve_dataset(prob: _CurveProblem, curve: list[CurvePoint], param: str, status: str,
                  kind: str, branch_file: str = "") -> xr.Dataset:
    """The curve as a Dataset along ``point``: both parameters as data variables named
    after themselves (with units), κ = cos θ and θ (NS), z0 (``point`` × ``state``), the
    multipliers, the amplitude, the codimension-two test functions (``test_<label>``), the
    ``special`` labels and ``marked``; attrs from ``run_attrs`` plus ``curve`` (LP, PD or
    NS), ``param1`` (the branch's), ``param2``, ``period``, ``steps_per_period``, ``t0``,
    ``status``, ``branch_file``."""
    model = prob.model
    p1 = prob.param1
    mult = np.array([p.multipliers for p in curve])
    attrs = run_attrs(model, prob.structure, prob.values)
    for name in (p1, param):
        attrs.pop(name, None)
    attrs.update(kind="curve", curve=kind, param1=p1, param2=param, period=str(prob.period),
                 steps_per_period=prob.n_steps, t0=prob.t0, status=status,
                 branch_file=branch_file)
    units = model.units
    data = {
        p1: ("point", np.array([p.lam1 for p in curve]), {"units": units[p1]}),
        param: ("point", np.array([p.lam2 for p in curve]), {"units": units[param]}),
        "amplitude": ("point", np.array([p.amplitude for p in curve]),
                      {"units": model.state_units[model.state_names[0]]}),
        "z0": (("point", "state"), np.array([p.z0 for p in curve])),
        "multiplier_real": (("point", "k"), mult.real),
        "multiplier_imag": (("point", "k"), mult.imag),
        "multiplier_abs": (("point", "k"), np.abs(mult)),
        "special": ("point", np.array([p.special for p in curve], dtype=object)),
        "marked": ("point", np.array([int(p.marked) for p in curve])),
        "newton_iterations": ("point", np.array([p.newton_iterations for p in curve])),
    }
    if kind == "NS":
        kappa = np.array([p.kappa for p in curve])
        data["kappa"] = ("point", kappa, {"long_name": "cos θ of the critical multipliers"})
        data["theta"] = ("point", np.arccos(np.clip(kappa, -1, 1)), {"units": "rad"})
    for label in curve[0].tests:
        data[f"test_{label}"] = ("point", np.array([p.tests[label] for p in curve]))
    return xr.Dataset(data, coords={"point": np.arange(len(curve)),
                                    "state": list(model.state_names),
                                    "k": np.arange(1, model.n_state + 1)}, attrs=attrs)


def special_lines(curve: xr.Dataset) -> list[str]:
    """One line per codimension-two point: ``CP at forcing_amplitude = 0.1234 N,
    speed_rpm = 12.3 rpm``."""
    p1, p2 = curve.attrs["param1"], curve.attrs["param2"]
    lines = []
    for i, label in enumerate(curve.special.values):
        if label:
            words = [f"{name} = {float(curve[name].values[i]):.6g} "
                     f"{curve[name].attrs.get('units', '')}".rstrip() for name in (p2, p1)]
            if "kappa" in curve:
                words.append(f"θ = {float(curve.theta.values[i]):.4g} rad")
            lines.append(f"{label} at " + ", ".join(words))
    return lines
