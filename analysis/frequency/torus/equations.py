"""The harmonic-balance equations of a quasi-periodic response with two base frequencies,
evaluated by a two-dimensional AFT on a torus grid in CasADi.

A response on a 2-torus of the base frequencies ω1, ω2 (rad/s, incommensurate) is
z(t) = u(ω1 t, ω2 t) with u 2π-periodic in each of its two hyper-times θ1, θ2, written as
the truncated real Fourier series on the harmonic set {k·ω = k1 ω1 + k2 ω2 : |k1| ≤ H1,
|k2| ≤ H2},

    u(θ) = c_0 + Σ_{k ∈ K⁺} (a_k cos k·θ + b_k sin k·θ),

K⁺ = {(0, k2): 1 ≤ k2 ≤ H2} ∪ {(k1, k2): 1 ≤ k1 ≤ H1, |k2| ≤ H2} (one of each pair ±k),
so n(2H1 + 1)(2H2 + 1) real unknowns, stored harmonic-major as in
``analysis.frequency.periodic.harmonic``: X = [c_0; a_k1; b_k1; …] (each block the n states). The
torus satisfies the invariance equation (ω1 ∂/∂θ1 + ω2 ∂/∂θ2) u = f(θ, u); its Galerkin
projection on the same harmonics is the residual

    R(X, p) = (ω1 ∇1 + ω2 ∇2) X − P f(θ_j, E X, p),   θ_j on an N1 × N2 grid,

with E the synthesis on the grid, P the discrete projection (P E = I for N_i ≥ 2H_i + 1)
and ∇_i the derivative of the series in θ_i (a'_k = k_i b_k, b'_k = −k_i a_k).

**The forcing on the torus.** The generated ``rhs(t, z, p)`` depends on time in two ways
(``generated/_runtime.ModelFunctions``): explicitly, through ``external_force`` and
``ball_load_<b>`` (the unbalance P_u (cos ωt, sin ωt), a harmonic force of a forcing
period), and through each bearing's cage angle ψ_b = ω_cage,b t, from which the runtime
places ball i at θ_i = 2π(i − 1)/N_b + ψ_b (``derivative(t, z, p, angles)`` takes the
explicit time and the cage angles separately). With equally spaced identical balls the sum
over balls is periodic in ψ_b with period 2π/N_b, i.e. in VC·t. So f(θ1, θ2, z) is the
runtime's own right-hand side with *separate phases*: the explicit time replaced by θ_a/ω_a
of the frequency that is not a VC (``shaft`` or ``param:NAME``), and the cage angle of a
bearing whose VC is one of the two frequencies replaced by θ_c/N_b. Nothing of the model is
rewritten: the same ``external_force``, ``ball_load_<b>``, station maps and masses, summed
by the same runtime code. That this is the model's forcing, and that it is 2π-periodic in
each phase, is checked numerically before any work (``check_phases``): f(ω1 t mod 2π,
ω2 t mod 2π, z) must equal ``rhs(t, z, p)`` at the states of the guess's simulation (large
t, so the reduction mod 2π is exercised). A model whose time dependence is not carried by
the two named frequencies (a third frequency, a ball defect that breaks the balls'
symmetry, a bearing whose VC is not named) fails that check with one line.

The Jacobian ∂R/∂X = (ω1 ∇1 + ω2 ∇2) − P diag(∂f/∂z(θ_j)) E is exact: ∂f/∂z by CasADi AD
on the grid, its projection assembled from the 2-D FFT of each entry (Toeplitz plus Hankel
in the two indices, aliasing included), as ``harmonic.Basis.product_matrices`` does in one
dimension. ∂R/∂p along one parameter (the frequencies' own dependence included) comes from
one forward AD sweep. Nothing is smoothed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np
import scipy.fft

from analysis.budgets import DENSE_MEMORY
from analysis.errors import InputError, check_count
from analysis.frequency.periodic.harmonic import MAX_UNKNOWNS
from analysis.integrate.flow import Period
from analysis.model import Model, System

RESONANCE_TOL = 1e-6
"""Smallest |k1 ω1 + k2 ω2| / max(ω1, ω2) over 0 < |k_i| ≤ 2H_i (the harmonics a product
of two series reaches) for frequencies to count as incommensurate (``check_frequencies``)."""

PHASE_TOL = 1e-9
"""Largest |f(θ, z) − rhs(t, z)| relative to max |rhs| of a state for the torus forcing to
count as the model's (``check_phases``)."""

TORUS_MATRICES = 4
"""Dense (n M)² matrices one torus solve holds at once (the Jacobian, its scaled copy,
the LU factors, the branch's bordered matrix); ``check_torus_harmonics``."""


def parse_frequencies(text: str | tuple, model: Model) -> tuple[Period, Period]:
    """Two base frequencies from ``"F1,F2"`` (or a pair): each ``shaft``, ``vc``,
    ``vc[name]`` or ``param:NAME`` (the grammar of ``--period``, without counts or
    ratios), checked against ``model``; ``InputError`` naming ``frequencies`` otherwise."""
    parts = [s.strip() for s in text.split(",")] if isinstance(text, str) else list(text)
    if len(parts) != 2 or not all(parts):
        raise InputError(f"frequencies: give two base frequencies F1,F2 (each shaft, vc, "
                         f"vc[name] or param:NAME), got {text!r}", field="frequencies")
    out = []
    for part in parts:
        try:
            per = part if isinstance(part, Period) else Period.parse(part)
        except InputError as err:
            raise InputError(f"frequencies: {err}".replace("period: ", ""),
                             field="frequencies") from None
        if per.kind == "ratio" or per.count != 1:
            raise InputError(f"frequencies: {part} is not a base frequency; use shaft, vc, "
                             "vc[name] or param:NAME", field="frequencies")
        try:
            per.check(model)
        except InputError as err:
            text = str(err).replace("period: ", "frequencies: ", 1)
            raise InputError(text, field="frequencies" if text.startswith("frequencies:")
                             else None) from None
        out.append(per)
    same_name = out[0].name == out[1].name or out[0].kind == "vc"
    if out[0].kind == out[1].kind and same_name and \
            _bearing_index(model, out[0]) == _bearing_index(model, out[1]):
        raise InputError(f"frequencies: {parts[0]} and {parts[1]} are the same frequency; "
                         "a torus needs two incommensurate ones", field="frequencies")
    if all(per.kind != "vc" for per in out):
        raise InputError(f"frequencies: {parts[0]},{parts[1]}: at most one may be shaft or "
                         "param:NAME (the model's explicit time goes to it); name a bearing's "
                         "vc as the other", field="frequencies")
    return out[0], out[1]


def _bearing_index(model: Model, per: Period) -> int | None:
    if per.kind != "vc":
        return None
    return model.bearing_names.index(per.name) if per.name else 0


def torus_size(n_state: int, harmonics: tuple[int, int]) -> int:
    """Real unknowns n(2H1 + 1)(2H2 + 1)."""
    return n_state * (2 * harmonics[0] + 1) * (2 * harmonics[1] + 1)


def torus_bytes(n_state: int, harmonics: tuple[int, int]) -> int:
    """Bytes of the dense matrices of one torus solve (``TORUS_MATRICES`` of (n M)²)."""
    size = torus_size(n_state, harmonics)
    return TORUS_MATRICES * 8 * size * size


def check_torus_harmonics(harmonics: object, n_state: int,
                          what: str = "harmonics") -> tuple[int, int]:
    """``harmonics`` as (H1, H2), whole numbers >= 1 (a pair, or ``"H1,H2"``), whose dense
    matrices fit ``DENSE_MEMORY`` and ``MAX_UNKNOWNS``; ``InputError`` (one line) before
    any work otherwise."""
    parts = harmonics.split(",") if isinstance(harmonics, str) else harmonics
    try:
        pair = tuple(parts)
    except TypeError:
        pair = ()
    if len(pair) != 2:
        raise InputError(f"{what}: give two numbers of harmonics H1,H2 (each >= 1), got "
                         f"{harmonics!r}", field=what)
    try:
        h1, h2 = (check_count(what, h, 1, text=True) for h in pair)
    except InputError:
        raise InputError(f"{what}: each of H1,H2 must be a whole number >= 1, got "
                         f"{harmonics!r}", field=what) from None
    unknowns = torus_size(n_state, (h1, h2))
    need = torus_bytes(n_state, (h1, h2))
    if unknowns > MAX_UNKNOWNS or need > DENSE_MEMORY:
        most = math.isqrt(DENSE_MEMORY // (8 * TORUS_MATRICES)) // n_state
        raise InputError(f"{what}: H1,H2 = {h1},{h2} give {unknowns} Fourier unknowns for "
                         f"{n_state} states, whose dense matrices need about "
                         f"{need / 2**30:.1f} GiB (at most {DENSE_MEMORY / 2**30:g} GiB): "
                         f"(2H1 + 1)(2H2 + 1) must be at most {most} for this model",
                         field=what)
    return h1, h2


def torus_samples(harmonics: tuple[int, int],
                  samples: tuple[int, int] | None = None) -> tuple[int, int]:
    """Grid N1 × N2 of the 2-D AFT: ``samples`` when given (each N_i >= 2H_i + 1), else
    ``scipy.fft.next_fast_len(max(4H_i + 1, 32))``."""
    if samples is None:
        return tuple(int(scipy.fft.next_fast_len(max(4 * h + 1, 32))) for h in harmonics)
    pair = tuple(samples)
    if len(pair) != 2 or not all(isinstance(s, (int, np.integer)) and s >= 2 * h + 1
                                 for s, h in zip(pair, harmonics, strict=False)):
        raise InputError(f"samples: give N1,N2 with N_i >= 2H_i + 1 = "
                         f"{2 * harmonics[0] + 1},{2 * harmonics[1] + 1}, got {samples!r}",
                         field="samples")
    return int(pair[0]), int(pair[1])


@dataclass(frozen=True)
class TorusBasis:
    """The real Fourier basis of the harmonic set of (H1, H2) on an N1 × N2 grid of
    hyper-times (θ_i = 2π j_i / N_i; grid point j = j1·N2 + j2).

    ``index`` (M⁺ × 2): the (k1, k2) of K⁺; columns of ``E``, rows of ``P``: c_0, then
    a_k, b_k for each k of ``index``; ``D1``, ``D2``: ∂/∂θ1, ∂/∂θ2 of the coefficients."""

    harmonics: tuple[int, int]
    samples: tuple[int, int]

    @cached_property
    def index(self) -> np.ndarray:
        h1, h2 = self.harmonics
        rows = [(0, k2) for k2 in range(1, h2 + 1)]
        rows += list(itertools.product(range(1, h1 + 1), range(-h2, h2 + 1)))
        return np.array(rows, dtype=int).reshape(-1, 2)

    @property
    def size(self) -> int:
        """M = (2H1 + 1)(2H2 + 1) columns."""
        return 1 + 2 * len(self.index)

    @cached_property
    def theta(self) -> tuple[np.ndarray, np.ndarray]:
        """(θ1, θ2) of every grid point (N1·N2 each, rad)."""
        n1, n2 = self.samples
        t1, t2 = np.meshgrid(2 * np.pi * np.arange(n1) / n1, 2 * np.pi * np.arange(n2) / n2,
                             indexing="ij")
        return t1.ravel(), t2.ravel()

    def synthesis(self, theta1: np.ndarray, theta2: np.ndarray) -> np.ndarray:
        """The basis at the points (θ1, θ2): points × M."""
        phase = np.outer(theta1, self.index[:, 0]) + np.outer(theta2, self.index[:, 1])
        out = np.empty((len(theta1), self.size))
        out[:, 0] = 1.0
        out[:, 1::2] = np.cos(phase)
        out[:, 2::2] = np.sin(phase)
        return out

    @cached_property
    def E(self) -> np.ndarray:
        return self.synthesis(*self.theta)

    @cached_property
    def P(self) -> np.ndarray:
        weights = np.full(self.size, 2.0 / (self.samples[0] * self.samples[1]))
        weights[0] /= 2
        return self.E.T * weights[:, None]

    def derivative(self, axis: int) -> np.ndarray:
        """∂/∂θ_axis of the coefficients (M × M)."""
        out = np.zeros((self.size, self.size))
        for j, k in enumerate(self.index[:, axis]):
            a, b = 1 + 2 * j, 2 + 2 * j
            out[a, b] = k
            out[b, a] = -k
        return out

    @cached_property
    def D1(self) -> np.ndarray:
        return self.derivative(0)

    @cached_property
    def D2(self) -> np.ndarray:
        return self.derivative(1)

    def frequencies(self, omega1: float, omega2: float) -> np.ndarray:
        """k1 ω1 + k2 ω2 of each harmonic of ``index`` (rad/s)."""
        return self.index[:, 0] * omega1 + self.index[:, 1] * omega2

    def complex_coefficients(self, samples: np.ndarray) -> np.ndarray:
        """The 2-D DFT coefficients A_m (N1 × N2 × m) of m series on the grid (N × m)."""
        n1, n2 = self.samples
        values = np.asarray(samples, dtype=float).reshape(n1, n2, -1)
        return scipy.fft.fft2(values, axes=(0, 1)) / (n1 * n2)

    def project(self, samples: np.ndarray) -> np.ndarray:
        """Coefficients (M × m) of m series sampled on the grid (N × m), by FFT."""
        spec = self.complex_coefficients(samples)
        n1, n2 = self.samples
        picked = spec[self.index[:, 0] % n1, self.index[:, 1] % n2]  # M⁺ × m
        out = np.empty((self.size, spec.shape[2]))
        out[0] = spec[0, 0].real
        out[1::2] = 2 * picked.real
        out[2::2] = -2 * picked.imag
        return out

    def grid_values(self, coeffs: np.ndarray, n_state: int) -> np.ndarray:
        """The series (harmonic-major ``coeffs``) on the grid by inverse 2-D FFT, without
        ``E``: N × n (equal to ``E @ coeffs`` to rounding)."""
        n1, n2 = self.samples
        x = np.asarray(coeffs, dtype=float).reshape(self.size, n_state)
        spec = np.zeros((n1, n2, n_state), dtype=complex)
        spec[0, 0] = x[0]
        k1, k2 = self.index[:, 0], self.index[:, 1]
        half = (x[1::2] - 1j * x[2::2]) / 2
        np.add.at(spec, (k1 % n1, k2 % n2), half)
        np.add.at(spec, (-k1 % n1, -k2 % n2), np.conj(half))
        values = np.fft.ifft2(spec, axes=(0, 1)).real * (n1 * n2)
        return values.reshape(n1 * n2, n_state)

    def product_matrices(self, values: np.ndarray) -> np.ndarray:
        """``P diag(a) E`` for each series a sampled in ``values`` (N × m): m × M × M, from
        the 2-D FFT of a (F_k of a·cos l·θ is (A_{k−l} + A_{k+l})/2, of a·sin l·θ
        (A_{k−l} − A_{k+l})/2i, indices modulo the grid)."""
        n1, n2 = self.samples
        spec = self.complex_coefficients(values)  # N1 × N2 × m
        rows = np.vstack([[0, 0], self.index])  # the output's complex harmonics
        cols = self.index
        size = self.size
        out = np.empty((spec.shape[2], size, size))
        minus = ((rows[:, None, 0] - cols[None, :, 0]) % n1,
                 (rows[:, None, 1] - cols[None, :, 1]) % n2)
        plus = ((rows[:, None, 0] + cols[None, :, 0]) % n1,
                (rows[:, None, 1] + cols[None, :, 1]) % n2)
        const = (rows[:, 0] % n1, rows[:, 1] % n2)
        for m in range(spec.shape[2]):
            a = spec[:, :, m]
            am, ap = a[minus], a[plus]
            for col, block in ((slice(1, None, 2), (am + ap) / 2),
                               (slice(2, None, 2), (am - ap) / 2j)):
                out[m, 0, col] = block[0].real
                out[m, 1::2, col] = 2 * block[1:].real
                out[m, 2::2, col] = -2 * block[1:].imag
            c = a[const]
            out[m, 0, 0] = c[0].real
            out[m, 1::2, 0] = 2 * c[1:].real
            out[m, 2::2, 0] = -2 * c[1:].imag
        return out

    def evaluate(self, coeffs: np.ndarray, theta1: np.ndarray, theta2: np.ndarray,
                 n_state: int) -> np.ndarray:
        """The series (harmonic-major ``coeffs``) at the points (θ1, θ2): points × n. In
        blocks of points, by complex exponentials of each hyper-time (O(points·H1·H2))."""
        h1, h2 = self.harmonics
        x = np.asarray(coeffs, dtype=float).reshape(self.size, n_state)
        grid = np.zeros((h1 + 1, 2 * h2 + 1, n_state), dtype=complex)
        grid[0, h2] = x[0]
        grid[self.index[:, 0], self.index[:, 1] + h2] = x[1::2] - 1j * x[2::2]
        theta1, theta2 = np.asarray(theta1, dtype=float), np.asarray(theta2, dtype=float)
        out = np.empty((theta1.size, n_state))
        k1, k2 = np.arange(h1 + 1), np.arange(-h2, h2 + 1)
        for start in range(0, theta1.size, 20_000):
            part = slice(start, start + 20_000)
            e1 = np.exp(1j * np.outer(theta1[part], k1))
            e2 = np.exp(1j * np.outer(theta2[part], k2))
            for i in range(n_state):
                out[part, i] = np.einsum("tk,tk->t", e1 @ grid[:, :, i], e2).real
        return out


def torus_function(system: System, frequencies: tuple[Period, Period]) -> ca.Function:
    """``f(theta (2), z, p) -> dz/dt``: the model's right-hand side with the explicit time
    and the cage angles placed on the two hyper-times (module docstring): the explicit time
    t = θ_a/ω_a of the frequency that is not a VC, the cage angle of a bearing whose VC is
    frequency c ψ_b = θ_c/N_b, any other bearing's ψ_b = ω_cage,b·t."""
    model, funcs = system.model, system.functions
    theta = ca.SX.sym("theta", 2)
    z = ca.SX.sym("z", system.n_state)
    p = ca.SX.sym("p", len(model.parameter_names))
    omegas = [2 * math.pi / per.seconds(model, system.structure, p) for per in frequencies]
    plain = [i for i, per in enumerate(frequencies) if per.kind != "vc"]
    t = theta[plain[0]] / omegas[plain[0]] if plain else ca.SX(0)
    angles = []
    for b, name in enumerate(model.bearing_names):
        chosen = [i for i, per in enumerate(frequencies) if _bearing_index(model, per) == b]
        psi = theta[chosen[0]] / system.structure[b] if chosen else \
            model.cage_speed(name, p) * t
        angles.append((ca.cos(psi), ca.sin(psi)))
    dz = ca.cse(funcs.derivative(t, z, p, angles))
    return ca.Function("torus_rhs", [theta, z, p], [dz], ["theta", "z", "p"], ["dz"])


def torus_jacobian(f: ca.Function, system: System) -> ca.Function:
    """``jac(theta, z, p) -> ∂f/∂z`` (n × n) of a ``torus_function``, by AD."""
    theta = ca.SX.sym("theta", 2)
    z = ca.SX.sym("z", system.n_state)
    p = ca.SX.sym("p", len(system.model.parameter_names))
    return ca.Function("torus_jac", [theta, z, p], [ca.jacobian(f(theta, z, p), z)],
                       ["theta", "z", "p"], ["dfdz"])


def omegas_of(system: System, frequencies: tuple[Period, Period],
              p: np.ndarray | None = None) -> tuple[float, float]:
    """(ω1, ω2) in rad/s at the parameters ``p`` (default the system's)."""
    p = system.p if p is None else p
    out = []
    for per in frequencies:
        period = float(per.seconds(system.model, system.structure, p))
        if not (math.isfinite(period) and period > 0):
            raise InputError(f"frequencies: {per} is not defined for these parameters "
                             f"(T = {period!r} s; is the speed zero?)", field="frequencies")
        out.append(2 * math.pi / period)
    return out[0], out[1]


def check_frequencies(system: System, frequencies: tuple[Period, Period],
                      harmonics: tuple[int, int], p: np.ndarray | None = None) -> None:
    """``InputError`` when the two frequencies are commensurate within the harmonics: some
    0 < |k1| ≤ 2H1, |k2| ≤ 2H2 with |k1 ω1 + k2 ω2| < ``RESONANCE_TOL``·max(ω1, ω2) (a
    harmonic of frequency zero: the torus equations have no unique solution, the response
    is periodic), or ω2 a multiple of ω1 within that tolerance."""
    w1, w2 = omegas_of(system, frequencies, p)
    k1 = np.arange(-2 * harmonics[0], 2 * harmonics[0] + 1)[:, None]
    k2 = np.arange(-2 * harmonics[1], 2 * harmonics[1] + 1)[None, :]
    combo = np.abs(k1 * w1 + k2 * w2) / max(w1, w2)
    combo[(k1 == 0)[:, 0], :] = np.inf
    combo[:, (k2 == 0)[0, :]] = np.inf
    j1, j2 = np.unravel_index(np.argmin(combo), combo.shape)
    if combo[j1, j2] < RESONANCE_TOL:
        a, b = int(k1[j1, 0]), int(k2[0, j2])
        what = "equal" if abs(a) == abs(b) == 1 else "commensurate"
        raise InputError(f"frequencies: {frequencies[0]} ({w1 / (2 * math.pi):.6g} Hz) and "
                         f"{frequencies[1]} ({w2 / (2 * math.pi):.6g} Hz) are {what} "
                         f"({a}·F1 {'+' if b > 0 else '-'} {abs(b)}·F2 = 0 to "
                         f"{RESONANCE_TOL:g}): the response is periodic; use hb --period",
                         field="frequencies")


def check_phases(system: System, frequencies: tuple[Period, Period], f: ca.Function,
                 t: np.ndarray, z: np.ndarray) -> None:
    """``InputError`` unless f(ω1 t mod 2π, ω2 t mod 2π, z) equals ``rhs(t, z, p)`` to
    ``PHASE_TOL`` at the times ``t`` (s) and states ``z`` (points × n): the torus forcing
    is the model's, and periodic in each hyper-time."""
    p = system.p
    w1, w2 = omegas_of(system, frequencies, p)
    theta = np.vstack([np.mod(w1 * t, 2 * math.pi), np.mod(w2 * t, 2 * math.pi)])
    mine = np.asarray(f.map(len(t))(theta, z.T, p))
    theirs = np.asarray(system.functions.rhs.map(len(t))(t[None, :], z.T, p))
    scale = np.maximum(np.max(np.abs(theirs), axis=1, keepdims=True), 1e-300)
    worst = float(np.max(np.abs(mine - theirs) / scale))
    if not worst <= PHASE_TOL:
        raise InputError(f"frequencies: {frequencies[0]},{frequencies[1]} do not carry all of "
                         f"model '{system.model.name}''s time dependence (its right-hand side "
                         f"differs from the torus forcing by {worst:.1e} of its size); the "
                         "forcing needs other frequencies too",
                         field="frequencies")
    for axis in range(2):
        if not _depends(f, axis, system):
            raise InputError(f"frequencies: the model's forcing does not depend on "
                             f"{frequencies[axis]}; the response is periodic: use hb",
                             field="frequencies")


def _depends(f: ca.Function, axis: int, system: System) -> bool:
    theta = ca.SX.sym("theta", 2)
    z = ca.SX.sym("z", system.n_state)
    p = ca.SX.sym("p", len(system.model.parameter_names))
    return bool(ca.depends_on(f(theta, z, p), theta[axis]))


@dataclass
class TorusSystem:
    """The torus harmonic-balance equations of ``system`` with the base frequencies
    ``frequencies`` (two ``Period``), ``harmonics`` (H1, H2) on ``samples`` (N1, N2).

    ``evaluate(X, p, param_index)`` gives the residual (n M, units of z'), its exact
    Jacobian in X and its derivative along parameter ``param_index``; unknowns and residual
    harmonic-major (``X[c·n + i]``: basis column c of state i). It meets what
    ``solve.newton_solve`` asks of a harmonic system: ``n``, ``size``, ``evaluate`` and
    ``period_s`` (here 2π/ω1: the residual's scale is ω1·s_i)."""

    system: System
    frequencies: tuple[Period, Period]
    harmonics: tuple[int, int]
    samples: tuple[int, int] | None = None
    shear: int = 0
    """m of the harmonic set {(k1 − m k2) ω1 + k2 ω2 : |k1| ≤ H1, |k2| ≤ H2}: the basis
    frequencies are (ω1, ω2 − m ω1) (module docstring, *The harmonic set*)."""
    dense: bool = True
    """False: the series only (a torus from ``invariant_circle``: no dense Jacobian is built,
    so the harmonics are not bounded by the memory of one)."""
    basis: TorusBasis = field(init=False)

    def __post_init__(self) -> None:
        for per in self.frequencies:
            per.check(self.system.model)
        if self.dense:
            self.harmonics = check_torus_harmonics(self.harmonics, self.system.n_state)
        else:
            self.harmonics = tuple(int(h) for h in self.harmonics)
        self.samples = torus_samples(self.harmonics, self.samples)
        self.basis = TorusBasis(self.harmonics, self.samples)

    @property
    def n(self) -> int:
        return self.system.n_state

    @property
    def size(self) -> int:
        """Number of unknowns n(2H1 + 1)(2H2 + 1)."""
        return self.n * self.basis.size

    @property
    def points(self) -> int:
        return self.samples[0] * self.samples[1]

    def omegas(self, p: np.ndarray | None = None) -> tuple[float, float]:
        """(ω1, ω2), rad/s."""
        return omegas_of(self.system, self.frequencies, p)

    def basis_omegas(self, p: np.ndarray | None = None) -> tuple[float, float]:
        """The frequencies of the basis's hyper-times (θ1, φ): (ω1, ω2 − m ω1), rad/s."""
        w1, w2 = self.omegas(p)
        return w1, w2 - self.shear * w1

    def physical_theta(self, theta1: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """The forcing phases (θ1, θ2 = φ + m θ1 mod 2π) of basis hyper-times: 2 × points."""
        return np.vstack([theta1, np.mod(phi + self.shear * theta1, 2 * math.pi)])

    def line_orders(self) -> np.ndarray:
        """(k1, k2) of each harmonic of the basis's ``index`` in the frequencies F1, F2:
        the line k1·ω1 + k2·ω2 (M⁺ × 2)."""
        out = self.basis.index.copy()
        out[:, 0] -= self.shear * out[:, 1]
        return out

    def period_s(self, p: np.ndarray) -> float:
        """2π/ω1 (s): the reference period of the residual's scale."""
        return 2 * math.pi / self.omegas(p)[0]

    @cached_property
    def rhs(self) -> ca.Function:
        return torus_function(self.system, self.frequencies)

    @cached_property
    def function(self) -> ca.Function:
        """``torus(X, p, e) -> (R, J_f, dR/dp·e)`` as ``HarmonicSystem.function``."""
        model, system = self.system.model, self.system
        n, n_par, size = self.n, len(model.parameter_names), self.basis.size
        x = ca.MX.sym("X", n, size)
        p = ca.MX.sym("p", n_par)
        e = ca.MX.sym("e", n_par)
        w1, w2 = (2 * math.pi / per.seconds(model, system.structure, p)
                  for per in self.frequencies)
        w2 = w2 - self.shear * w1
        theta = ca.DM(self.physical_theta(*self.basis.theta))
        z = ca.mtimes(x, ca.DM(self.basis.E.T))
        rhs = self.rhs.map(self.points)
        f = rhs(theta, z, p)
        jac = torus_jacobian(self.rhs, system)
        derivative = w1 * ca.DM(self.basis.D1.T) + w2 * ca.DM(self.basis.D2.T)
        residual = ca.mtimes(x, derivative) - ca.mtimes(f, ca.DM(self.basis.P.T))
        jf = jac.map(self.points)(theta, z, p)
        along = ca.jtimes(residual, p, e)
        return ca.Function("torus_hb", [x, p, e], [residual, jf, along],
                           ["X", "p", "e"], ["R", "jac_f", "dR_de"])

    def evaluate(self, coeffs: np.ndarray, p: np.ndarray,
                 param_index: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Residual R (n M, harmonic-major, units of z'), ∂R/∂X (n M square) and ∂R/∂p_k
        for ``param_index`` k (zeros when None)."""
        n, size = self.n, self.basis.size
        x = np.asarray(coeffs, dtype=float).reshape(size, n).T
        e = np.zeros(len(p))
        if param_index is not None:
            e[param_index] = 1.0
        res, jf, along = self.function(x, p, e)
        res = np.asarray(res)
        jf = np.asarray(jf).reshape(n, self.points, n)
        w1, w2 = self.basis_omegas(p)
        entries = np.transpose(jf, (1, 0, 2)).reshape(self.points, n * n)
        blocks = self.basis.product_matrices(entries).reshape(n, n, size, size)
        jac = -np.transpose(blocks, (2, 0, 3, 1)).reshape(size * n, size * n)
        jac += np.kron(w1 * self.basis.D1 + w2 * self.basis.D2, np.eye(n))
        return res.T.reshape(-1), jac, np.asarray(along).T.reshape(-1)

    def residual(self, coeffs: np.ndarray, p: np.ndarray) -> np.ndarray:
        """R alone (n M), without the Jacobian's assembly."""
        x = np.asarray(coeffs, dtype=float).reshape(self.basis.size, self.n).T
        res, _, _ = self.function(x, p, np.zeros(len(p)))
        return np.asarray(res).T.reshape(-1)

    def on_grid(self, coeffs: np.ndarray) -> np.ndarray:
        """The torus on the N1 × N2 grid: N1 × N2 × n, the states' units."""
        if not self.dense:  # large grids: no dense E
            return self.basis.grid_values(coeffs, self.n).reshape(*self.samples, self.n)
        x = np.asarray(coeffs, dtype=float).reshape(self.basis.size, self.n)
        return (self.basis.E @ x).reshape(*self.samples, self.n)

    def at_times(self, coeffs: np.ndarray, t: np.ndarray,
                 p: np.ndarray | None = None) -> np.ndarray:
        """z(t) = u(ω1 t, ω2 t) at the times ``t`` (s): len(t) × n."""
        w1, w2 = self.basis_omegas(p)
        t = np.asarray(t, dtype=float)
        return self.basis.evaluate(coeffs, np.mod(w1 * t, 2 * math.pi),
                                   np.mod(w2 * t, 2 * math.pi), self.n)

    def fit(self, t: np.ndarray, z: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """Harmonic-major coefficients of the least-squares fit of the series to the
        states ``z`` (points × n) at the times ``t`` (s): a guess from a simulation."""
        w1, w2 = self.basis_omegas(p)
        t = np.asarray(t, dtype=float)
        basis = self.basis.synthesis(np.mod(w1 * t, 2 * math.pi), np.mod(w2 * t, 2 * math.pi))
        coeffs, *_ = np.linalg.lstsq(basis, np.asarray(z, dtype=float), rcond=None)
        return coeffs.reshape(-1)


def resize_torus(coeffs: np.ndarray, n_state: int, old: tuple[int, int],
                 new: tuple[int, int]) -> np.ndarray:
    """Harmonic-major coefficients of harmonics ``old`` moved to the harmonic set ``new``:
    the common harmonics kept, the others zero."""
    a, b = TorusBasis(tuple(old), (1, 1)), TorusBasis(tuple(new), (1, 1))
    x = np.asarray(coeffs, dtype=float).reshape(a.size, n_state)
    out = np.zeros((b.size, n_state))
    out[0] = x[0]
    where = {tuple(k): j for j, k in enumerate(b.index)}
    for j, k in enumerate(a.index):
        target = where.get(tuple(k))
        if target is not None:
            out[1 + 2 * target:3 + 2 * target] = x[1 + 2 * j:3 + 2 * j]
    return out.reshape(-1)
