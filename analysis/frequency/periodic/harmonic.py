"""The harmonic-balance equations of a periodic response, evaluated by AFT in CasADi.

A T-periodic response of the first-order system z' = f(t, z, p) (n states, positions then
velocities, the model's units) is written as a truncated real Fourier series of ω = 2π/T,

    z(t) = c_0 + Σ_{k=1..H} (a_k cos kωt + b_k sin kωt),

whose n(2H + 1) coefficients are the unknowns, stored harmonic by harmonic:
X = [c_0; a_1; b_1; …; a_H; b_H] (each block the n states, the states' units). The
residual is the Galerkin projection of z' − f on the same harmonics,

    R(X, p) = ω ∇ X − P f(t_j, E X, p),   t_j = j T / N,  j = 0 … N − 1,

with E the N × (2H + 1) synthesis matrix (the samples of 1, cos kωt, sin kωt), P its
discrete Fourier projection (P E = I for N ≥ 2H + 1) and ∇ the derivative of the series
(a'_k = kω b_k, b'_k = −kω a_k). This is the alternating frequency–time (AFT) scheme of
NLvib and pyHarm: the force is evaluated in time, on the N samples, by the model's own
generated ``rhs`` mapped over the samples (``rhs.map(N)``), so nothing about the model is
known here: any System whose right-hand side depends on time.

The Jacobian ∂R/∂X = ω ∇ − P diag(∂f/∂z(t_j)) E is exact: ∂f/∂z is the model's generated
``jac`` (CasADi AD) on the samples, and its Fourier projection is assembled from the FFT of
each entry (a Toeplitz-plus-Hankel matrix of its Fourier coefficients, identical to the
product of the three matrices, aliasing included). ∂R/∂p along one parameter, the period's
own dependence on it included (T(p): the shaft speed moves every t_j and ω), comes from one
forward AD sweep through the mapped ``rhs``. Nothing is smoothed: the Hertz contact
max(0, δ)^1.5 is evaluated as the model writes it (C¹, the Jacobian exact where it exists).

Sampling: N = ``scipy.fft.next_fast_len(max(4H + 1, 64))`` by default. Products of a
degree-H series with a contact force alias into the kept harmonics unless N is well above
2H + 1; the residual is always that of the N samples, and ``analysis.frequency.periodic.solve``
reports how the solution moves when H (and N with it) doubles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np
import scipy.fft

from analysis.budgets import DENSE_MEMORY
from analysis.errors import InputError
from analysis.integrate.flow import Period
from analysis.model import System
from analysis.threads import BLAS_THREADS, blas_threads  # noqa: F401  (their home)

MAX_UNKNOWNS = 20_000
"""Most Fourier unknowns n(2H + 1) of one solve: the dense Newton matrix and the Hill
matrix are (n(2H + 1))² doubles each (3.2 GB at this bound)."""

"""Bytes the dense matrices of one solve may take (``check_size``): the Jacobian, its LU
factors, the complex Hill matrix and its eigenvectors, about 6·(n(2H + 1))² doubles."""


def fast_samples(harmonics: int, samples: int | None = None) -> int:
    """Time samples N of the AFT for ``harmonics`` H: ``samples`` when given (at least
    2H + 1), else ``scipy.fft.next_fast_len(max(4H + 1, 64))``."""
    if samples is None:
        return int(scipy.fft.next_fast_len(max(4 * harmonics + 1, 64)))
    if not (isinstance(samples, int) and samples >= 2 * harmonics + 1):
        raise InputError(f"samples: must be a whole number >= 2H + 1 = {2 * harmonics + 1}, "
                         f"got {samples!r}", field="samples")
    return samples


def matrix_bytes(n_state: int, harmonics: int) -> int:
    """Bytes of the dense matrices of one solve with Hill's stability (``DENSE_MEMORY``)."""
    size = n_state * (2 * harmonics + 1)
    return 6 * 8 * size * size


def check_harmonics(harmonics: object, n_state: int, what: str = "harmonics") -> int:
    """``harmonics`` as a whole number H >= 1 whose dense matrices fit ``DENSE_MEMORY``
    and ``MAX_UNKNOWNS``; ``InputError`` (one line) before any work otherwise."""
    if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) \
            or harmonics < 1:
        raise InputError(f"{what}: must be a whole number >= 1, got {harmonics!r}", field=what)
    harmonics = int(harmonics)
    unknowns = n_state * (2 * harmonics + 1)
    need = matrix_bytes(n_state, harmonics)
    if unknowns > MAX_UNKNOWNS or need > DENSE_MEMORY:
        most = int(min((MAX_UNKNOWNS // n_state - 1) // 2,
                       (math.isqrt(DENSE_MEMORY // 48) // n_state - 1) // 2))
        raise InputError(f"{what}: H = {harmonics} gives {unknowns} Fourier unknowns for "
                         f"{n_state} states, whose dense matrices need about "
                         f"{need / 2**30:.1f} GiB (at most {DENSE_MEMORY / 2**30:g} GiB); "
                         f"at most H = {most} for this model", field=what)
    return harmonics


def check_forced(system: System) -> None:
    """``InputError`` when the model's right-hand side does not depend on time: an
    autonomous model has no forcing period to balance (its periodic responses, if any,
    have a period of their own, which harmonic balance with a given ω cannot find)."""
    rhs = system.functions.rhs
    t = ca.MX.sym("t")
    z = ca.MX.sym("z", system.n_state)
    p = ca.MX.sym("p", len(system.model.parameter_names))
    if not ca.depends_on(rhs(t, z, p), t):
        raise InputError(f"model: '{system.model.name}' has no forcing (its equations do not "
                         "depend on time); harmonic balance needs a forced model")


@dataclass(frozen=True)
class Basis:
    """The real Fourier basis of H harmonics on N samples of one period (θ_j = 2πj/N).

    ``E`` (N × (2H + 1)): the samples of 1, cos kθ, sin kθ (k = 1 … H, interleaved);
    ``P`` ((2H + 1) × N): the discrete projection onto them (``P @ E = I``);
    ``D`` ((2H + 1) × (2H + 1)): d/dθ of the coefficients (so d/dt is ω·D)."""

    harmonics: int
    samples: int

    @cached_property
    def theta(self) -> np.ndarray:
        return 2 * np.pi * np.arange(self.samples) / self.samples

    @cached_property
    def E(self) -> np.ndarray:
        k = np.arange(1, self.harmonics + 1)
        out = np.empty((self.samples, 2 * self.harmonics + 1))
        out[:, 0] = 1.0
        out[:, 1::2] = np.cos(np.outer(self.theta, k))
        out[:, 2::2] = np.sin(np.outer(self.theta, k))
        return out

    @cached_property
    def P(self) -> np.ndarray:
        weights = np.full(2 * self.harmonics + 1, 2.0 / self.samples)
        weights[0] = 1.0 / self.samples
        return self.E.T * weights[:, None]

    @cached_property
    def D(self) -> np.ndarray:
        size = 2 * self.harmonics + 1
        out = np.zeros((size, size))
        for k in range(1, self.harmonics + 1):
            a, b = 2 * k - 1, 2 * k
            out[a, b] = k  # a'_k = k b_k
            out[b, a] = -k  # b'_k = -k a_k
        return out

    def project(self, samples: np.ndarray) -> np.ndarray:
        """Coefficients ((2H + 1) × m) of m series sampled on the grid (N × m), by FFT."""
        spec = scipy.fft.rfft(np.asarray(samples, dtype=float), axis=0) / self.samples
        out = np.empty((2 * self.harmonics + 1, *spec.shape[1:]))
        out[0] = spec[0].real
        out[1::2] = 2 * spec[1:self.harmonics + 1].real
        out[2::2] = -2 * spec[1:self.harmonics + 1].imag
        return out

    def product_matrices(self, values: np.ndarray) -> np.ndarray:
        """``P diag(a) E`` for each series a sampled in ``values`` (N × m): the matrix of
        the product of a with a truncated series, projected back, m × (2H + 1)², built
        from the FFT of a (Toeplitz plus Hankel in its discrete Fourier coefficients A_m,
        indices modulo N: the aliasing of the product matrices included)."""
        n_samp, h_max = self.samples, self.harmonics
        coeff = scipy.fft.fft(np.asarray(values, dtype=float), axis=0).T / n_samp  # m × N
        h = np.arange(h_max + 1)[:, None]
        g = np.arange(1, h_max + 1)[None, :]
        minus, plus = coeff[:, (h - g) % n_samp], coeff[:, (h + g) % n_samp]
        cos_cols = (minus + plus) / 2  # F_h of a·cos gθ, h = 0 … H
        sin_cols = (minus - plus) / 2j  # F_h of a·sin gθ
        const_col = coeff[:, h[:, 0] % n_samp]  # F_h of a
        size = 2 * h_max + 1
        out = np.empty((coeff.shape[0], size, size))
        for col, block in ((slice(1, None, 2), cos_cols), (slice(2, None, 2), sin_cols)):
            out[:, 0, col] = block[:, 0].real
            out[:, 1::2, col] = 2 * block[:, 1:].real
            out[:, 2::2, col] = -2 * block[:, 1:].imag
        out[:, 0, 0] = const_col[:, 0].real
        out[:, 1::2, 0] = 2 * const_col[:, 1:].real
        out[:, 2::2, 0] = -2 * const_col[:, 1:].imag
        return out


@dataclass
class HarmonicSystem:
    """The harmonic-balance equations of ``system`` for responses of period ``period``
    (a ``Period``: ``shaft``, ``vc``, ``vc[name]``, ``param:NAME``, ``shaft:k`` …) with
    ``harmonics`` H harmonics of ω = 2π/T on ``samples`` N time samples.

    ``evaluate(X, p, param_index)`` gives the residual (n(2H + 1), units of z'), its exact
    Jacobian in X and its derivative along parameter ``param_index``; the unknowns X and
    the residual are stored harmonic-major (``X[k·n + i]``: harmonic column k of state i).
    """

    system: System
    period: Period
    harmonics: int
    samples: int
    basis: Basis = field(init=False)

    def __post_init__(self) -> None:
        self.period.check(self.system.model)
        self.harmonics = check_harmonics(self.harmonics, self.system.n_state)
        self.samples = fast_samples(self.harmonics, self.samples)
        self.basis = Basis(self.harmonics, self.samples)

    @property
    def n(self) -> int:
        return self.system.n_state

    @property
    def size(self) -> int:
        """Number of unknowns n(2H + 1)."""
        return self.n * (2 * self.harmonics + 1)

    def period_s(self, p: np.ndarray) -> float:
        """T (s) at the parameter vector ``p``."""
        model = self.system.model
        value = float(self.period.seconds(model, self.system.structure, p))
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"period: {self.period} is not defined for these parameters "
                             f"(T = {value!r} s; is the speed zero?)")
        return value

    @cached_property
    def function(self) -> ca.Function:
        """``hb(X, p, e) -> (R, J_f, dR/dp·e)``: the residual (n × (2H + 1), column k the
        coefficients of harmonic column k), ∂f/∂z at the samples (n × nN) and the
        derivative of R along the parameter direction e (one forward AD sweep)."""
        model, system = self.system.model, self.system
        n, n_par, size = self.n, len(model.parameter_names), 2 * self.harmonics + 1
        funcs = system.functions
        x = ca.MX.sym("X", n, size)
        p = ca.MX.sym("p", n_par)
        e = ca.MX.sym("e", n_par)
        period = self.period.seconds(model, system.structure, p)
        omega = 2 * math.pi / period
        t = period * ca.DM(np.arange(self.samples)[None, :] / self.samples)
        z = ca.mtimes(x, ca.DM(self.basis.E.T))
        f = funcs.rhs.map(self.samples)(t, z, p)
        residual = omega * ca.mtimes(x, ca.DM(self.basis.D.T)) - ca.mtimes(f, ca.DM(self.basis.P.T))
        jf = funcs.jac.map(self.samples)(t, z, p)
        along = ca.jtimes(residual, p, e)
        return ca.Function("hb", [x, p, e], [residual, jf, along],
                           ["X", "p", "e"], ["R", "jac_f", "dR_de"])

    def evaluate(self, coeffs: np.ndarray, p: np.ndarray,
                 param_index: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Residual R (n(2H + 1), harmonic-major, units of z'), ∂R/∂X (n(2H + 1) square)
        and ∂R/∂p_k for ``param_index`` k (zeros when None) at coefficients ``coeffs``
        (harmonic-major) and parameters ``p``."""
        n, size = self.n, 2 * self.harmonics + 1
        x = np.asarray(coeffs, dtype=float).reshape(size, n).T
        e = np.zeros(len(p))
        if param_index is not None:
            e[param_index] = 1.0
        res, jf, along = self.function(x, p, e)
        res, jf = np.asarray(res), np.asarray(jf).reshape(n, self.samples, n)
        omega = 2 * math.pi / self.period_s(p)
        # blocks[i, k] = P diag(∂f_i/∂z_k) E, from the FFT of each entry over the samples
        entries = np.transpose(jf, (1, 0, 2)).reshape(self.samples, n * n)
        blocks = self.basis.product_matrices(entries).reshape(n, n, size, size)
        jac = -np.transpose(blocks, (2, 0, 3, 1)).reshape(size * n, size * n)
        jac += omega * np.kron(self.basis.D, np.eye(n))
        return res.T.reshape(-1), jac, np.asarray(along).T.reshape(-1)

    def residual(self, coeffs: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The residual R of ``evaluate`` alone (n(2H + 1), units of z')."""
        return self.evaluate(coeffs, p)[0]

    def sample(self, coeffs: np.ndarray, points: int | None = None) -> np.ndarray:
        """The response on ``points`` equally spaced phases of one period (default: the N
        AFT samples), points × n, the states' units."""
        size = 2 * self.harmonics + 1
        x = np.asarray(coeffs, dtype=float).reshape(size, self.n)
        basis = self.basis if points is None else Basis(self.harmonics, int(points))
        return basis.E @ x

    def coefficients(self, samples: np.ndarray) -> np.ndarray:
        """Harmonic-major coefficients of a response sampled on the N AFT phases
        (N × n)."""
        return self.basis.project(samples).reshape(-1)


def resize(coeffs: np.ndarray, n_state: int, harmonics: int) -> np.ndarray:
    """Harmonic-major coefficients with ``harmonics`` harmonics: cut, or padded with zeros."""
    x = np.asarray(coeffs, dtype=float).reshape(-1, n_state)
    size = 2 * harmonics + 1
    out = np.zeros((size, n_state))
    keep = min(size, x.shape[0])
    out[:keep] = x[:keep]
    return out.reshape(-1)
