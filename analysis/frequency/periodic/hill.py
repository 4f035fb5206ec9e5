"""Stability of a harmonic-balance solution by Hill's method.

A perturbation y of the T-periodic response obeys y' = J(t) y with J = ∂f/∂z on the
response. Floquet: y = e^{λt} q(t) with q T-periodic, so q' = (J − λ) q, and in the
harmonic-balance basis (``analysis.frequency.periodic.harmonic``)

    (P J E − ω ∇) Q = λ Q:

the Floquet exponents are eigenvalues of the *Hill matrix* −∂R/∂X, the negated Jacobian of
the harmonic-balance residual (1/s). The n(2H + 1) eigenvalues hold n families λ + ikω
(k = −H … H, the same multiplier e^{λT} each), truncated: only the members near the middle
of each family are accurate. Which n to keep is the sorting problem of Hill's method:

* ``"centroid"`` (default; the symmetry criterion of Bentvelsen & Lazarus 2018): each
  eigenvector is written on the complex harmonics e^{ikωt} (k = −H … H); the n eigenvalues
  whose eigenvectors have the weighted mean harmonic index (weights |Q_k|², the states
  scaled to one unit) nearest 0 are kept;
* ``"central"`` (Lazarus & Thomas 2010): the n eigenvalues whose eigenvectors hold the
  largest share |Q_0|² on the central block k = 0.

Both members of a family can score alike (a real negative multiplier has members at
σ ± iω/2), so an eigenvalue that differs from one already kept by ikω (k ≠ 0, to
``FAMILY_TOL``·ω) is skipped: the kept exponents give n distinct Floquet families. A kept
exponent whose conjugate is in its own family (Im λ·T/π an integer to ``REAL_TOL``) gives a
real multiplier, set real: (−1)^m e^{Re λ T}, so that a PD point is a real multiplier
through −1 and not a narrow complex pair.

B. Bentvelsen, A. Lazarus, "Modal and stability analysis of structures in periodic elastic
states: application to the Ziegler column", Nonlinear Dyn. 91 (2018) 1349–1370.
A. Lazarus, O. Thomas, "A harmonic-based method for computing the stability of periodic
solutions of dynamical systems", C. R. Mécanique 338 (2010) 510–517.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError

FAMILY_TOL = 1e-3
"""Two eigenvalues λ, λ' are one Floquet family when |λ − λ' − ikω| < FAMILY_TOL·ω, k ≠ 0."""
REAL_TOL = 1e-6
"""A kept exponent with |Im λ·T/π − m| < REAL_TOL (m an integer) gives a real multiplier."""


def centroid_score(weights: np.ndarray, index: np.ndarray) -> np.ndarray:
    """|weighted mean harmonic index| of each eigenvector (rows of ``weights``)."""
    return np.abs(weights @ index) / weights.sum(axis=1)


def central_score(weights: np.ndarray, index: np.ndarray) -> np.ndarray:
    """1 − the share of each eigenvector on the central block k = 0."""
    return 1.0 - weights[:, index == 0].sum(axis=1) / weights.sum(axis=1)


SORTS: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "centroid": centroid_score, "central": central_score}
"""The sorting criteria: name -> score of each eigenvector (smallest kept first)."""


@dataclass(frozen=True)
class HillResult:
    """The kept Floquet exponents (1/s, complex), their multipliers e^{λT} and the score of
    each (the criterion's measure: 0 for an eigenvector centred on k = 0)."""

    exponents: np.ndarray
    multipliers: np.ndarray
    scores: np.ndarray

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.multipliers)))


def complex_weights(vectors: np.ndarray, n_state: int, harmonics: int,
                    state_scale: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """|Q_k|² per complex harmonic k = −H … H of each eigenvector (columns of ``vectors``,
    real cos/sin basis, harmonic-major), the states divided by ``state_scale``; returns
    (weights: vectors × (2H + 1), the index k of each column)."""
    size = 2 * harmonics + 1
    v = vectors.T.reshape(vectors.shape[1], size, n_state)
    if state_scale is not None:
        v = v / np.asarray(state_scale)[None, None, :]
    c0 = v[:, 0, :]
    a, b = v[:, 1::2, :], v[:, 2::2, :]
    plus, minus = (a - 1j * b) / 2, (a + 1j * b) / 2  # Q_k, Q_{-k}
    weights = np.concatenate([
        (np.abs(minus[:, ::-1, :]) ** 2).sum(axis=2), (np.abs(c0) ** 2).sum(axis=1)[:, None],
        (np.abs(plus) ** 2).sum(axis=2)], axis=1)
    return weights, np.arange(-harmonics, harmonics + 1, dtype=float)


DENSE_SIZE = 400
"""Largest Hill matrix whose eigenvalues are all computed (``method="auto"``); above it, the
``ARNOLDI_FAMILIES``·n eigenvalues nearest 0 by shift-invert Arnoldi (the middle members of
every family lie there; the spurious ones of the truncation lie near ±Hω), checked to hold
n distinct families, else all of them after all."""
ARNOLDI_FAMILIES = 4
"""Eigenvalues asked of Arnoldi per state (``DENSE_SIZE``)."""
METHODS = ("auto", "dense", "arnoldi")
"""How the Hill matrix's eigenvalues are found: all (``dense``), the nearest 0 by
shift-invert Arnoldi (``arnoldi``), or by size (``auto``: ``DENSE_SIZE``)."""


def hill_stability(jacobian: np.ndarray, n_state: int, harmonics: int, period_s: float,
                   sort: str = "centroid", state_scale: np.ndarray | None = None,
                   method: str = "auto") -> HillResult:
    """Floquet exponents and multipliers of a harmonic-balance solution from the Jacobian
    of its residual ``jacobian`` (∂R/∂X, n(2H + 1) square, 1/s, harmonic-major; the Hill
    matrix is its negative), the period ``period_s`` (s) and the sorting ``sort``
    (``SORTS``). ``state_scale``: the unit of each state in the eigenvectors' weights.
    ``method``: ``METHODS``."""
    if sort not in SORTS:
        raise InputError(f"sort: must be one of {', '.join(SORTS)}, got {sort!r}")
    if method not in METHODS:
        raise InputError(f"method: must be one of {', '.join(METHODS)}, got {method!r}")
    hill = -np.asarray(jacobian)
    size = hill.shape[0]
    k = min(size - 2, ARNOLDI_FAMILIES * n_state)
    if method == "arnoldi" or (method == "auto" and size > DENSE_SIZE and k >= n_state):
        found = _select(*_nearest_eigenpairs(hill, k), n_state, harmonics, period_s, sort,
                        state_scale)
        if found is not None:
            return found
    values, vectors = np.linalg.eig(hill)
    found = _select(values, vectors, n_state, harmonics, period_s, sort, state_scale)
    if found is None:
        raise InputError("Hill: fewer than n distinct Floquet families among the "
                         "eigenvalues (non-finite Jacobian?)")
    return found


def _nearest_eigenpairs(hill: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` eigenpairs of ``hill`` nearest 0: ARPACK in shift-invert mode on one LU
    factorisation."""
    import scipy.linalg
    import scipy.sparse.linalg

    lu = scipy.linalg.lu_factor(hill)
    inverse = scipy.sparse.linalg.LinearOperator(
        hill.shape, matvec=lambda v: scipy.linalg.lu_solve(lu, v), dtype=float)
    try:
        return scipy.sparse.linalg.eigs(hill, k=k, sigma=0.0, OPinv=inverse,
                                        ncv=min(hill.shape[0], 2 * k + 1), tol=1e-13)
    except (scipy.sparse.linalg.ArpackError, scipy.sparse.linalg.ArpackNoConvergence):
        return np.array([]), np.zeros((hill.shape[0], 0))


def _select(values: np.ndarray, vectors: np.ndarray, n_state: int, harmonics: int,
            period_s: float, sort: str, state_scale: np.ndarray | None) -> HillResult | None:
    """The n exponents of distinct families by the criterion ``sort``; None when the
    eigenvalues hold fewer than n families."""
    if values.size < n_state:
        return None
    weights, index = complex_weights(vectors, n_state, harmonics, state_scale)
    scores = SORTS[sort](weights, index)
    omega = 2 * math.pi / period_s
    kept: list[int] = []
    for j in np.argsort(scores, kind="stable"):
        lam = values[j]
        if not np.isfinite(lam):
            continue
        same = False
        for i in kept:
            shift = round(float((lam - values[i]).imag) / omega)
            if shift != 0 and abs(lam - values[i] - 1j * shift * omega) < FAMILY_TOL * omega:
                same = True
                break
        if not same:
            kept.append(int(j))
        if len(kept) == n_state:
            break
    if len(kept) < n_state:
        return None
    exponents = values[kept]
    return HillResult(exponents=exponents, multipliers=multipliers_of(exponents, period_s),
                      scores=scores[kept])


def multipliers_of(exponents: np.ndarray, period_s: float) -> np.ndarray:
    """e^{λT} of each exponent, real (exactly) when the exponent's conjugate lies in its
    own family (|Im λ·T/π − m| < ``REAL_TOL``): (−1)^m e^{Re λ T}."""
    out = np.exp(np.asarray(exponents, dtype=complex) * period_s)
    turns = np.asarray(exponents).imag * period_s / math.pi
    m = np.round(turns)
    real = np.abs(turns - m) < REAL_TOL
    out[real] = np.where(m[real] % 2 == 0, 1.0, -1.0) * np.exp(
        np.asarray(exponents)[real].real * period_s)
    return out
