"""Normal-form coefficients of a smooth map x ↦ f(x, α) at a fixed point with a critical multiplier.

The map is a CasADi ``Function`` of one input (x, n states) or two (x and the parameter vector
α), returning f(x, α) (n values). Its derivatives along directions are exact, by automatic
differentiation (nested ``ca.jtimes``), not finite differences:
A = ∂f/∂x, B(u, v) = D²f[u, v], C(u, v, w) = D³f[u, v, w] at (x0, α).

Coefficients (Kuznetsov & Meijer, SIAM J. Sci. Comput. 26 (2005) 1932–1954; Kuznetsov,
*Elements of Applied Bifurcation Theory*, 3rd ed., Sec. 4.4–4.7), with the critical
eigenvector q normalised to ⟨q, q⟩ = 1 and the adjoint p to ⟨p, q⟩ = 1, ⟨p, q⟩ = p̄ᵀq:

- fold (multiplier +1; Aq = q, Aᵀp = p): a = ½⟨p, B(q, q)⟩. Normal form η ↦ η + β + aη².
- flip (multiplier −1; Aq = −q, Aᵀp = −p): c = ⅙⟨p, C(q, q, q) + 3B(q, h₂)⟩,
  h₂ = (I − A)⁻¹B(q, q). Normal form η ↦ −(1 + β)η + cη³; its second iterate is
  η ↦ (1 + 2β)η − 2cη³, so past the flip (β > 0, the fixed point unstable) a period-2
  orbit of amplitude |η| = √(β/c) exists and is stable when c > 0: **c > 0 supercritical,
  c < 0 subcritical** (the map's convention; MatCont's period-doubling coefficient of a
  limit cycle, from the periodic normalisation of the flow, has the opposite sign).
- Neimark–Sacker (multipliers e^{±iθ}; Aq = e^{iθ}q, Aᴴp = e^{−iθ}p): the first Lyapunov
  coefficient d = ½ Re{e^{−iθ}⟨p, C(q, q, q̄) + 2B(q, h₁₁) + B(q̄, h₂₀)⟩},
  h₁₁ = (I − A)⁻¹B(q, q̄), h₂₀ = (e^{2iθ}I − A)⁻¹B(q, q). Normal form
  z ↦ e^{iθ}(1 + β)z(1 + d|z|²) + …: past the point (β > 0) an invariant circle of radius
  |z| = √(−β/d) exists and is stable when d < 0: **d < 0 supercritical, d > 0 subcritical**
  (the same sign as MatCont's, for maps and cycles).

``transversality`` gives β'(α) (the rate at which the critical multiplier leaves the unit
circle), and ``amplitude`` the leading-order amplitude of the new orbit, √(β/c) or √(−β/d),
in the eigenvector coordinate η = ⟨p, x − x0⟩ (|η| for the flip, |z| for Neimark–Sacker).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np

from analysis.errors import InputError

KINDS = ("LP", "PD", "NS")


@dataclass(frozen=True)
class NormalForm:
    """The normal form of a map at a critical fixed point: ``kind`` "LP" (fold), "PD" (flip)
    or "NS" (Neimark–Sacker); ``coefficient`` a, c or d (dimensionless per the eigenvector's
    unit normalisation: the state's units to the power 1 − order); ``criticality``
    "supercritical" or "subcritical" (None for a fold); ``multiplier`` the critical one;
    ``q``, ``p`` the eigenvector and adjoint (⟨q, q⟩ = 1, ⟨p, q⟩ = 1)."""

    kind: str
    coefficient: float
    criticality: str | None
    multiplier: complex
    q: np.ndarray
    p: np.ndarray

    def as_dict(self) -> dict:
        """The JSON form: {"coefficient": …, "criticality": …}."""
        return {"coefficient": float(self.coefficient), "criticality": self.criticality}


_BUILT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""The derivative Functions of each map (building them costs more than evaluating them)."""


def _derivative_functions(f: ca.Function) -> tuple[ca.Function, ca.Function, ca.Function]:
    """A(x, a), B(x, a, u, v), C(x, a, u, v, w) of ``f`` (a: the parameters, 0 values for
    a map of x alone), built once per map."""
    if f not in _BUILT:
        n = f.size1_in(0)
        n_par = f.size1_in(1) * f.size2_in(1) if f.n_in() == 2 else 0
        x, a = ca.MX.sym("x", n), ca.MX.sym("a", n_par)
        u, v, w = (ca.MX.sym(name, n) for name in "uvw")
        y = f(x) if f.n_in() == 1 else f(x, a)
        y = y[0] if isinstance(y, (list, tuple)) else y
        d2 = ca.jtimes(ca.jtimes(y, x, u), x, v)
        _BUILT[f] = (ca.Function("A", [x, a], [ca.jacobian(y, x)]),
                     ca.Function("B", [x, a, u, v], [d2]),
                     ca.Function("C", [x, a, u, v, w], [ca.jtimes(d2, x, w)]))
    return _BUILT[f]


class _Derivatives:
    """A, B(u, v), C(u, v, w) of ``f`` at (x0, α) by AD; complex directions by linearity."""

    def __init__(self, f: ca.Function, x0: np.ndarray, alpha: np.ndarray | None):
        n = f.size1_in(0)
        if x0.shape != (n,):
            raise InputError(f"x0: {n} values (the map's states), got {x0.shape}")
        self._jac, self._b, self._c = _derivative_functions(f)
        self.alpha = np.zeros(0) if alpha is None else alpha
        self.x0 = x0
        self.n = n

    def A(self) -> np.ndarray:
        return np.array(self._jac(self.x0, self.alpha), dtype=float)

    def B(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        out = np.zeros(self.n, dtype=complex)
        for cu, uu in _parts(u):
            for cv, vv in _parts(v):
                out += cu * cv * np.array(self._b(self.x0, self.alpha, uu, vv)).ravel()
        return out

    def C(self, u: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
        out = np.zeros(self.n, dtype=complex)
        for cu, uu in _parts(u):
            for cv, vv in _parts(v):
                for cw, ww in _parts(w):
                    out += cu * cv * cw * np.array(
                        self._c(self.x0, self.alpha, uu, vv, ww)).ravel()
        return out


def _parts(u: np.ndarray) -> list[tuple[complex, np.ndarray]]:
    """u = Σ coefficient·real vector (the real part, and i times the imaginary part)."""
    u = np.asarray(u)
    parts = [(1.0, np.real(u).astype(float))]
    if np.iscomplexobj(u) and np.any(np.imag(u) != 0):
        parts.append((1j, np.imag(u).astype(float)))
    return parts


def _eigvec(M: np.ndarray, mu: complex) -> np.ndarray:
    """The eigenvector of M for the eigenvalue closest to ``mu``."""
    vals, vecs = np.linalg.eig(M)
    k = int(np.argmin(np.abs(vals - mu)))
    return vecs[:, k]


def _critical(A: np.ndarray, kind: str | None) -> tuple[str, complex]:
    """The critical multiplier of A (of ``kind``, or the one nearest the unit circle)."""
    vals = np.linalg.eigvals(A)
    targets = {"LP": lambda m: abs(m - 1), "PD": lambda m: abs(m + 1),
               "NS": lambda m: abs(abs(m) - 1) if m.imag > 1e-9 else np.inf}
    if kind is None:
        dist = {k: min(targets[k](m) for m in vals) for k in KINDS}
        kind = min(dist, key=dist.get)
    if kind not in targets:
        raise InputError(f"kind: one of {', '.join(KINDS)}, got {kind!r}")
    mu = min(vals, key=targets[kind])
    if not np.isfinite(targets[kind](mu)):
        raise InputError("kind: NS needs a complex pair of multipliers, the map has none")
    return kind, complex(mu)


def _as_alpha(f: ca.Function, alpha) -> np.ndarray | None:
    if f.n_in() not in (1, 2):
        raise InputError(f"f: a CasADi Function of (x) or (x, α), got {f.n_in()} inputs")
    if f.n_in() == 1:
        return None
    if alpha is None:
        raise InputError("alpha: the map takes a parameter vector, got none")
    return np.atleast_1d(np.asarray(alpha, dtype=float))


def normal_form(f: ca.Function, x0, alpha=None, kind: str | None = None) -> NormalForm:
    """The normal form of ``f`` (CasADi Function of x, or of x and α) at its fixed point
    ``x0`` for the parameters ``alpha``: the fold, flip or Neimark–Sacker coefficient,
    ``kind`` "LP", "PD", "NS" or None (the multiplier nearest the unit circle decides).
    The critical multiplier is taken as it is (the point should be located to the
    tolerance wanted: the coefficient is evaluated there)."""
    alpha = _as_alpha(f, alpha)
    der = _Derivatives(f, np.asarray(x0, dtype=float), alpha)
    A = der.A()
    kind, mu = _critical(A, kind)
    if kind == "NS":
        return _neimark_sacker(der, A, mu)
    mu = 1.0 if kind == "LP" else -1.0
    q = np.real(_eigvec(A, mu))
    q = q / np.linalg.norm(q)
    p = np.real(_eigvec(A.T, mu))
    _check_pairing(p @ q, p)
    p = p / (p @ q)
    bqq = np.real(der.B(q, q))
    if kind == "LP":
        a = 0.5 * (p @ bqq)
        return NormalForm("LP", float(a), None, complex(mu), q, p)
    h2 = np.linalg.solve(np.eye(der.n) - A, bqq)
    c = (p @ np.real(der.C(q, q, q) + 3 * der.B(q, h2))) / 6.0
    return NormalForm("PD", float(c), "supercritical" if c > 0 else "subcritical",
                      complex(mu), q, p)


def _check_pairing(pairing: complex, p: np.ndarray) -> None:
    """``InputError`` when ⟨p, q⟩ vanishes: the critical multiplier is a Jordan block (a
    resonance, or a degenerate, e.g. conservative, map), where this normal form does not
    apply."""
    if not abs(pairing) > 1e-10 * np.linalg.norm(p):
        raise InputError("x0: the critical multiplier is a Jordan block (⟨p, q⟩ = 0): no "
                         "normal form of this kind there")


def _neimark_sacker(der: _Derivatives, A: np.ndarray, mu: complex) -> NormalForm:
    theta = math.atan2(mu.imag, mu.real)
    q = _eigvec(A, mu)
    q = q / np.linalg.norm(q)
    p = _eigvec(A.conj().T, np.conj(mu))
    _check_pairing(np.vdot(p, q), p)
    p = p / np.conj(np.vdot(p, q))  # ⟨p, q⟩ = p̄ᵀq = 1
    eye = np.eye(der.n)
    qb = np.conj(q)
    h20 = np.linalg.solve(np.exp(2j * theta) * eye - A, der.B(q, q))
    h11 = np.linalg.solve(eye - A, der.B(q, qb))
    inner = np.vdot(p, der.C(q, q, qb) + 2 * der.B(q, h11) + der.B(qb, h20))
    d = 0.5 * float(np.real(np.exp(-1j * theta) * inner))
    return NormalForm("NS", d, "supercritical" if d < 0 else "subcritical", mu, q, p)


def transversality(f: ca.Function, x0, alpha, nf: NormalForm, index: int = 0) -> float:
    """β'(α): the rate at which the critical multiplier leaves the unit circle as parameter
    ``index`` of α grows, along the fixed point (x0 moving as x0'(α) = (I − A)⁻¹f_α):
    d|μ|/dα for NS, −dμ/dα for PD (μ = −(1 + β)), dμ/dα for LP (μ = 1 + β: then β'
    is the fold's ⟨p, f_α⟩ instead, the fixed point not being a function of α there).
    Exact by AD, per the parameter's unit."""
    alpha = _as_alpha(f, alpha)
    if alpha is None:
        raise InputError("alpha: transversality needs a map of (x, α)")
    if not 0 <= index < alpha.size:
        raise InputError(f"index: 0 to {alpha.size - 1}, got {index}")
    n = f.size1_in(0)
    x = ca.MX.sym("x", n)
    a = ca.MX.sym("a", alpha.size)
    u = ca.MX.sym("u", n)
    y = f(x, a)
    e = np.zeros(alpha.size)
    e[index] = 1.0
    fa = ca.Function("fa", [x, a], [ca.jtimes(y, a, ca.DM(e))])
    dA = ca.Function("dA", [x, a, u], [ca.jtimes(ca.jtimes(y, x, u), a, ca.DM(e))])
    x0 = np.asarray(x0, dtype=float)
    f_alpha = np.array(fa(x0, alpha)).ravel()
    if nf.kind == "LP":
        return float(np.real(np.vdot(nf.p, f_alpha)))
    A = np.array(ca.Function("A", [x, a], [ca.jacobian(y, x)])(x0, alpha), dtype=float)
    x_alpha = np.linalg.solve(np.eye(n) - A, f_alpha)
    der = _Derivatives(f, x0, alpha)

    def dA_times(v: np.ndarray) -> np.ndarray:
        out = np.zeros(n, dtype=complex)
        for cv, vv in _parts(v):
            out += cv * np.array(dA(x0, alpha, vv)).ravel()
        return out + der.B(x_alpha, v)

    dmu = complex(np.vdot(nf.p, dA_times(nf.q)))
    if nf.kind == "PD":
        return float(-dmu.real)
    return float(np.real(np.conj(nf.multiplier) * dmu) / abs(nf.multiplier))


def amplitude(nf: NormalForm, beta: float) -> float:
    """The leading-order amplitude of the orbit born at the point, at distance ``beta``
    (β > 0: past the point, the fixed point unstable; β < 0 before it): |η| = √(β/c)
    for a flip, |z| = √(−β/d) for Neimark–Sacker, in η = ⟨p, x − x0⟩; NaN where the
    orbit does not exist on that side. For a fold, the two fixed points' |η| = √(−β/a)."""
    ratio = {"PD": beta / nf.coefficient if nf.coefficient else math.nan,
             "NS": -beta / nf.coefficient if nf.coefficient else math.nan,
             "LP": -beta / nf.coefficient if nf.coefficient else math.nan}[nf.kind]
    return math.sqrt(ratio) if ratio >= 0 else math.nan
