"""A quasi-periodic response (2-torus) as the invariant circle of the shaft-period
stroboscopic map: quasi-periodic shooting (Schilder, Osinga & Vogt, SIAM J. Appl. Dyn.
Syst. 4 (2005) 459–488; the shooting variant of COCO ``tor`` and CoSTAR).

A forced response z(t) = u(ω1 t, ω2 t) on the torus of the base frequencies ω1 (the
explicit time: ``shaft`` or ``param:NAME``) and ω2 (a bearing's VC) meets the section
θ1 = 0 (t = k·T1, T1 = 2π/ω1) in the circle v(φ) = u(0, φ). Let P_φ be the flow over one
period T1 started at shaft phase 0 and cage phase φ: the right-hand side
``torus.torus_function`` at the phases θ1 = ω1 s, θ2 = φ + ω2 s (the model's own ``rhs``
with the time origin moved, checked against it by ``torus.check_phases``). Then

    P_{φ}(v(φ)) = v(φ + ρ),   ρ = 2π ω2/ω1 mod 2π,

the rotation number being known (a forced torus: no phase condition). The unknowns are
the circle at N equally spaced phases φ_j = 2πj/N (n states each, point-major:
``U[j·n + i]``); v(φ_j + ρ) is the trigonometric interpolation of the samples, a fixed
real N × N matrix R_ρ (``shift_matrix``) applied per state. The residual
F(U) = P(U_j) − (R_ρ ⊗ I) U has the exact Jacobian blockdiag(∂P/∂z_j) − R_ρ ⊗ I:
∂P/∂z by forward AD through the fixed-step RK4 (the same discrete map as ``simulate``'s
RK4 at the same step, the N shootings mapped in one CasADi call). Newton solves it from the
Fourier least-squares fit of a settled simulation's shaft section.

**Why it beats 2-D harmonic balance on Hertz contact.** The torus HB represents u(θ1, θ2)
by a 2-D Fourier series whose coefficients decay slowly (the contact force max(0, δ)^1.5
is not smooth, and the spectrum runs along the small divisor 4X − VC), so its error falls
like H^-1.4. Here the flow within a shaft period is integrated (to the RK4's error: the
same discrete map as ``simulate``'s), and only the circle v(φ) is a Fourier series, of one
variable. At N_b = 10, 5000 rpm, N = 65 points give the circle within about 1e-3 of the
amplitude of a long simulation (about 1e-4 away from the cage phases 0.5–2.5 rad), where
HB at 4900 unknowns reaches 7e-2. The remaining error does not fall with N: over those
cage phases the shaft map's local multiplier is a flip below −1 (down to −1.29), which
amplifies the circle's invariance defect between its samples by the product of about 20
expanding revolutions (docs/frequency.md, "Tori by the invariant circle of the shaft
map").

The truncation measures: ``tail``, the largest amplitude of the circle's modes k > 0.4·N
relative to its largest mode (states scaled), and ``change``, the largest difference
between this circle and the one with 2N points on a fine grid of phases, relative to the
amplitude ((max − min)/2) of each state.

The torus Dataset (``circle_dataset``): each circle point integrated over T1, sampled at N1
shaft phases θ1 = 2πa/N1 (every steps/N1 RK4 steps), lies at the cage phases
φ_j + ρ_full·a/N1 (ρ_full = 2π ω2/ω1, unsheared); shifted back by trigonometric
interpolation in θ2, that is u on the regular N1 × N grid, whose 2-D DFT gives the
coefficients of the same ``torus.TorusSystem`` series (H_i = (N_i − 1)//2, no dense
matrices) that ``torus_dataset`` writes, so ``torus_run``, ``spectrum``, ``poincare`` and
``plot`` read it unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import casadi as ca
import numpy as np
import xarray as xr

from analysis.budgets import DENSE_MEMORY
from analysis.errors import InputError, check_count
from analysis.frequency.periodic.harmonic import blas_threads
from analysis.frequency.torus.equations import (
    TorusSystem,
    check_phases,
    omegas_of,
    torus_function,
)
from analysis.frequency.torus.solve import prepare_torus, torus_drift, torus_lambda1
from analysis.integrate.flow import Period
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import BallCounts, Model, System, as_system
from analysis.stability.periodic import state_scale

MIN_POINTS = 8
"""Fewest circle points N."""

CIRCLE_MATRICES = 3
"""Dense (n N)² matrices one circle solve holds (the Jacobian, its scaled copy, the LU)."""

SECTION_SAMPLES = 300
"""Default shaft phases N1 of the torus Dataset's grid (rounded to a divisor of the RK4
steps per shaft period, an odd one where one is near: the series of an odd grid holds its
samples exactly, an even one drops the Nyquist mode). At N_b = 10, 5000 rpm the series
between the sections is within 1.5e-3 of the amplitude at N1 = 300 (the circle's own
error), 4.6e-3 at 150, 5.6e-2 at 75: the contact's content within a revolution."""

DEFAULT_POINTS = 65
"""Default circle points N (odd, for the same reason)."""

AMPLITUDE_PHASES = 4
"""The amplitude of a circle's torus is (max − min)/2 over whole revolutions integrated,
every RK4 step kept, from ``AMPLITUDE_PHASES``·N cage phases of the circle
(``integrated_amplitude``); its error estimate is the change from half as many phases.
The N1 × N grid's (max − min)/2 misses the peaks between its shaft phases: 1.9e-3 of the
amplitude low at N_b = 10, 5000 rpm, where the integrated one is within 4e-4 of a 10 s
simulation (tests/frequency/test_torus_amplitude.py)."""

TAIL_FRACTION = 0.4
"""Modes k > TAIL_FRACTION·N of the circle make its ``tail``."""


def check_points(points: object, n_state: int, what: str = "points") -> int:
    """N as a whole number >= ``MIN_POINTS`` whose dense Newton matrices
    (``CIRCLE_MATRICES`` of (n N)² doubles) fit ``DENSE_MEMORY``; ``InputError`` (one line)
    before any work otherwise."""
    points = check_count(what, points, MIN_POINTS, text=True)
    most = math.isqrt(DENSE_MEMORY // (8 * CIRCLE_MATRICES)) // n_state
    if points > most:
        raise InputError(f"{what}: {points} circle points of {n_state} states need about "
                         f"{CIRCLE_MATRICES * 8 * (n_state * points) ** 2 / 2**30:.1f} GiB of "
                         f"dense matrices (at most {DENSE_MEMORY / 2**30:g} GiB): at most "
                         f"{most} for this model", field=what)
    return int(points)


def shift_matrix(points: int, shift: float) -> np.ndarray:
    """R (N × N, real): (R v)_j = the trigonometric interpolant of the samples v_l at
    φ_l = 2πl/N, evaluated at φ_j + ``shift`` (rad); the Nyquist mode of an even N as
    cos(N φ/2) (the real part of its shift)."""
    k = np.fft.fftfreq(points, 1.0 / points)
    spectrum = np.fft.fft(np.eye(points), axis=0)
    return np.real(np.fft.ifft(np.exp(1j * k * shift)[:, None] * spectrum, axis=0))


def shift_derivative(points: int, shift: float) -> np.ndarray:
    """dR/d(shift) of ``shift_matrix`` (N × N, 1/rad)."""
    k = np.fft.fftfreq(points, 1.0 / points)
    spectrum = np.fft.fft(np.eye(points), axis=0)
    return np.real(np.fft.ifft((1j * k * np.exp(1j * k * shift))[:, None] * spectrum, axis=0))


def circle_modes(values: np.ndarray) -> np.ndarray:
    """|c_k| of the real series of samples on the circle (N × m): (N//2 + 1) × m, the
    amplitude of cos/sin k φ (k = 0: the mean)."""
    spec = np.fft.rfft(np.asarray(values, dtype=float), axis=0) / values.shape[0]
    amp = 2 * np.abs(spec)
    amp[0] /= 2
    if values.shape[0] % 2 == 0:
        amp[-1] /= 2
    return amp


def interpolate_circle(values: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """The trigonometric interpolant of the samples ``values`` (N × m, at φ_j = 2πj/N) at
    the phases ``phi`` (rad): len(phi) × m (the Nyquist mode of an even N as cos)."""
    values = np.asarray(values, dtype=float)
    n = values.shape[0]
    spec = np.fft.fft(values, axis=0) / n
    k = np.fft.fftfreq(n, 1.0 / n)
    phase = np.exp(1j * np.outer(np.asarray(phi, dtype=float), k))
    return np.real(phase @ spec)


def shaft_steps(period: float, dt_max: float, samples: int) -> tuple[int, int]:
    """(RK4 steps per shaft period, N1): the fewest steps >= T1/dt_max (``period``,
    ``dt_max`` in s; the step T1/steps equals dt_max when T1 is a whole number of it) that
    a number of shaft phases within a quarter of ``samples`` divides, an odd one first."""
    steps = max(1, math.ceil(period / dt_max - 1e-9))
    reach = max(2, samples // 4)
    for extra in range(0, steps):
        total = steps + extra
        near = [d for d in range(max(3, samples - reach), samples + reach + 1)
                if total % d == 0]
        if near:
            return total, min(near, key=lambda d: (d % 2 == 0, abs(d - samples)))
    return steps * samples, samples


@dataclass
class ShaftMap:
    """The flow over one shaft period T1 = 2π/ω1 of ``system`` from shaft phase 0 and cage
    phase φ, ``steps`` fixed RK4 steps of h = T1/steps of the torus forcing of
    ``frequencies`` (``torus.torus_function``), sampled every steps/``samples`` steps.

    ``function(Z0, phi, p, e) -> (Z_T, J, S, D)`` for N circle points at once
    (``Function.map``): Z0 (n × N) the starts, phi (1 × N) their cage phases (rad), Z_T
    (n × N) the end states, J (n × n N) the blocks ∂z_T/∂z_0 side by side (exact: the
    tangent of the discrete RK4 map), S (n × samples·N) the states at the shaft phases
    2πa/samples, a = 1..samples (the last is Z_T), D (n × N) dz_T/dp·e along the parameter
    direction e (the step's and the phases' own dependence on p included).

    **Why its own RK4 step and not ``integrate.tangent``** (the one builder of RK4 steps
    with derivatives, docs/architecture.md): that builder chains the model's
    ``rk4_step(t, z, p, h)``, whose forcing has one time t. The shaft map starts each circle
    point at its own cage phase φ, so its step evaluates the torus forcing
    ``torus_function`` at the two phases (ω1 s, φ + ω2 s), with φ an input; and its
    derivative along p carries ds/dp = (s/h)·dh/dp for the step's time. Building those on
    ``tangent`` would need a second time input there; kept here, its forcing checked
    against the model's right-hand side by ``check_phases`` before every solve."""

    system: System
    frequencies: tuple[Period, Period]
    steps: int
    samples: int
    points: int

    def _rk4(self, n_par: int):
        """(z, s, phi, p, z_next, h): one RK4 step of the torus forcing as SX."""
        model, system = self.system.model, self.system
        z = ca.SX.sym("z", system.n_state)
        s = ca.SX.sym("s")
        phi = ca.SX.sym("phi")
        p = ca.SX.sym("p", n_par)
        w1, w2 = (2 * math.pi / per.seconds(model, system.structure, p)
                  for per in self.frequencies)
        h = 2 * math.pi / w1 / self.steps
        f = torus_function(system, self.frequencies)

        def dz(tau, state):
            return f(ca.vertcat(w1 * tau, phi + w2 * tau), state, p)

        k1 = dz(s, z)
        k2 = dz(s + h / 2, z + h / 2 * k1)
        k3 = dz(s + h / 2, z + h / 2 * k2)
        k4 = dz(s + h, z + h * k3)
        return z, s, phi, p, z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), h

    @cached_property
    def revolution_function(self) -> ca.Function:
        """``revolution(Z0, phi, p) -> S`` (n × steps·N): the states after every RK4 step
        of one shaft period from each start, no tangent (the integrated amplitude,
        ``integrated_amplitude``)."""
        n, n_par = self.system.n_state, len(self.system.model.parameter_names)
        z, s, phi, p, z_next, h = self._rk4(n_par)
        step = ca.Function("circle_rk4_states", [ca.vertcat(z, s), phi, p],
                           [ca.vertcat(z_next, s + h)])
        sweep = step.mapaccum("circle_states", self.steps)
        z0 = ca.MX.sym("z0", n)
        ph = ca.MX.sym("phi")
        pp = ca.MX.sym("p", n_par)
        one = ca.Function("circle_revolution", [z0, ph, pp],
                          [sweep(ca.vertcat(z0, 0), ph, pp)[:n, :]])
        return one.map(self.points, "thread", 2)

    def revolutions(self, u: np.ndarray, phi: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The states after every RK4 step of one shaft period from the starts ``u``
        (N × n) at the cage phases ``phi`` (rad): N × steps × n."""
        n = self.system.n_state
        out = self.revolution_function(np.asarray(u, dtype=float).T,
                                       np.asarray(phi, dtype=float)[None, :], p)
        return np.asarray(out).reshape(n, self.points, self.steps).transpose(1, 2, 0)

    @cached_property
    def function(self) -> ca.Function:
        n, n_par = self.system.n_state, len(self.system.model.parameter_names)
        z, s, phi, p, z_next, h = self._rk4(n_par)
        m = ca.SX.sym("m", n, n)
        d = ca.SX.sym("d", n)
        e = ca.SX.sym("e", n_par)
        a = ca.jacobian(z_next, z)
        m_next = ca.mtimes(a, m)  # the tangent of the discrete map
        # along p: the time s of a step is k·h(p), so ds/dp·e = (s/h)·dh/dp·e
        dh = ca.jtimes(h, p, e)
        d_next = ca.mtimes(a, d) + ca.jtimes(z_next, p, e) + ca.jacobian(z_next, s) * s / h * dh
        carry = ca.vertcat(z, ca.vec(m), d, s)
        step = ca.Function("circle_rk4", [carry, phi, p, e],
                           [ca.vertcat(z_next, ca.vec(m_next), d_next, s + h)])
        per = self.steps // self.samples
        block = step.mapaccum("circle_block", per)
        ends = ca.Function("circle_block_end", [carry, phi, p, e],
                           [block(carry, phi, p, e)[:, -1]])
        sweep = ends.mapaccum("circle_sweep", self.samples)
        z0 = ca.MX.sym("z0", n)
        ph = ca.MX.sym("phi")
        pp = ca.MX.sym("p", n_par)
        ee = ca.MX.sym("e", n_par)
        out = sweep(ca.vertcat(z0, ca.vec(ca.DM.eye(n)), ca.DM.zeros(n), 0), ph, pp, ee)
        states = out[:n, :]
        one = ca.Function("circle_shoot", [z0, ph, pp, ee],
                          [states[:, -1], ca.reshape(out[n:n + n * n, -1], n, n), states,
                           out[n + n * n:n + n * n + n, -1]])
        mapped = one.map(self.points, "thread", 2)
        Z0 = ca.MX.sym("Z0", n, self.points)
        PH = ca.MX.sym("PH", 1, self.points)
        P = ca.MX.sym("P", n_par)
        E = ca.MX.sym("E", n_par)
        out = mapped(Z0, PH, P, E)
        return ca.Function("shaft_map", [Z0, PH, P, E], list(out), ["Z0", "phi", "p", "e"],
                           ["ZT", "J", "S", "D"])

    @cached_property
    def rotation_function(self) -> ca.Function:
        """``rho(p, e) -> (2π ω2/ω1, its derivative along e)`` (rad, not reduced)."""
        model, system = self.system.model, self.system
        p = ca.SX.sym("p", len(model.parameter_names))
        e = ca.SX.sym("e", len(model.parameter_names))
        t1, t2 = (per.seconds(model, system.structure, p) for per in self.frequencies)
        rho = 2 * math.pi * t1 / t2
        return ca.Function("circle_rotation", [p, e], [rho, ca.jtimes(rho, p, e)])

    def along(self, u: np.ndarray, phi: np.ndarray, p: np.ndarray, e: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(end states N × n, Jacobian blocks N × n × n, dz_T/dp·e N × n)."""
        n = self.system.n_state
        zt, jac, _, d = self.function(np.asarray(u, dtype=float).T,
                                      np.asarray(phi, dtype=float)[None, :], p, e)
        jac = np.asarray(jac).reshape(n, self.points, n).transpose(1, 0, 2)
        return np.asarray(zt).T, jac, np.asarray(d).T

    def __call__(self, u: np.ndarray, phi: np.ndarray, p: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(end states N × n, Jacobian blocks N × n × n, samples N × samples × n)."""
        n = self.system.n_state
        zt, jac, states, _ = self.function(np.asarray(u, dtype=float).T,
                                           np.asarray(phi, dtype=float)[None, :], p,
                                           np.zeros(len(p)))
        jac = np.asarray(jac).reshape(n, self.points, n).transpose(1, 0, 2)
        states = np.asarray(states).reshape(n, self.points, self.samples).transpose(1, 2, 0)
        return np.asarray(zt).T, jac, states


@dataclass
class CircleResponse:
    """A torus as the invariant circle of the shaft map: ``circle`` (N × n, the states'
    units) at the cage phases φ_j = 2πj/N (rad) of the shaft section t = k·T1."""

    system: System = field(repr=False)
    frequencies: tuple[Period, Period]
    circle: np.ndarray
    converged: bool
    iterations: int
    residual: float
    """Largest |P(u_j) − u(φ_j + ρ)|_i / s_i at the solution."""
    message: str
    scale: np.ndarray
    steps: int
    """RK4 steps per shaft period (h = T1/steps)."""
    samples: int
    """Shaft phases N1 of the torus grid."""
    grid: np.ndarray = field(default=None, repr=False)
    """u on the regular N1 × N grid (N1 × N × n)."""
    tail: float = math.nan
    change: float = math.nan
    """Largest |u_N − u_2N| / amplitude over the states (NaN: not computed)."""
    change_points: int = 0
    lambda1: float = math.nan
    lambda1_ci95: float = math.nan
    drift: float = math.nan
    seconds: float = math.nan
    integrated: np.ndarray | None = field(default=None, repr=False)
    """(max − min)/2 of each state over integrated revolutions (``integrated_amplitude``);
    None: not computed (the grid's is used)."""
    amplitude_error: float = math.nan
    """Largest change of ``integrated`` from half as many cage phases, relative."""

    @property
    def points(self) -> int:
        return self.circle.shape[0]

    @property
    def omegas(self) -> tuple[float, float]:
        return omegas_of(self.system, self.frequencies)

    @property
    def rotation(self) -> float:
        """ρ = 2π ω2/ω1 mod 2π (rad)."""
        w1, w2 = self.omegas
        return float(np.mod(2 * math.pi * w2 / w1, 2 * math.pi))

    def section(self, phi: np.ndarray) -> np.ndarray:
        """u(φ) at the cage phases ``phi`` (rad): len(phi) × n."""
        return interpolate_circle(self.circle, phi)

    def at_sections(self, t: np.ndarray) -> np.ndarray:
        """z(t) at shaft-section times ``t`` = k·T1 (s): u(ω2 t mod 2π)."""
        return self.section(np.mod(self.omegas[1] * np.asarray(t, dtype=float), 2 * math.pi))

    @cached_property
    def torus(self) -> TorusSystem:
        """The ``TorusSystem`` series of the N1 × N grid (H_i = (N_i − 1)//2)."""
        n1, n2 = self.grid.shape[:2]
        return TorusSystem(self.system, self.frequencies, ((n1 - 1) // 2, (n2 - 1) // 2),
                           (n1, n2), dense=False)

    @cached_property
    def coefficients(self) -> np.ndarray:
        """Harmonic-major coefficients of ``torus`` (its 2-D DFT of ``grid``)."""
        n = self.system.n_state
        return self.torus.basis.project(self.grid.reshape(-1, n)).reshape(-1)

    def amplitude(self) -> dict[str, float]:
        """(max − min)/2 of each state (its unit): over the integrated revolutions
        (``integrated``) when computed, else over the N1 × N grid."""
        if self.integrated is not None:
            values = np.asarray(self.integrated, dtype=float)
        else:
            values = np.ptp(self.grid.reshape(-1, self.system.n_state), axis=0) / 2
        return dict(zip(self.system.state_names, values.tolist(), strict=True))


def integrated_amplitude(response: CircleResponse, phases: int = AMPLITUDE_PHASES
                         ) -> tuple[np.ndarray, float]:
    """((max − min)/2 per state, its error estimate) of a converged circle's torus: over
    one shaft period integrated from ``phases``·N cage phases of the circle (trigonometric
    interpolation), every RK4 step of the solve's own map kept; the estimate is the largest
    change over the states from half as many phases, relative to the amplitude."""
    system, n = response.system, response.system.n_state
    found = []
    for m in (phases * response.points // 2, phases * response.points):
        phi = 2 * math.pi * np.arange(m) / m
        u = response.section(phi)
        shaft = ShaftMap(system, response.frequencies, response.steps, response.steps, m)
        with blas_threads():
            states = shaft.revolutions(u, phi, system.p)
        found.append(np.ptp(np.vstack([u, states.reshape(-1, n)]), axis=0) / 2)
    coarse, fine = found
    return fine, float(np.max(np.abs(fine - coarse) / np.maximum(fine, 1e-300)))


def settled_section(system: System, frequencies: tuple[Period, Period], dt: float,
                    settle: float | None, revolutions: int) -> tuple[np.ndarray, np.ndarray,
                                                                     np.ndarray, np.ndarray]:
    """(t, z) of a run of RK4 step ``dt`` after ``settle`` s (default the spec's transient,
    rounded to shaft periods) at the shaft sections t = k·T1 over ``revolutions``
    periods, and (t, z) of every run state (for ``check_phases``)."""
    w1, _ = omegas_of(system, frequencies)
    period = 2 * math.pi / w1
    per = round(period / dt)
    settle = float(system.model.simulation_defaults["transient"] if settle is None else settle)
    first = math.ceil(settle / period)
    run = simulate(system, duration=(first + revolutions) * period, transient=first * period,
                   dt=dt, save_every=per)
    t = run.t.values
    z = np.column_stack([run[name].values for name in system.state_names])
    return t, z, t[::max(1, len(t) // 50)], z[::max(1, len(t) // 50)]


def fit_circle(phi: np.ndarray, z: np.ndarray, points: int) -> np.ndarray:
    """The circle (points × n) at φ_j = 2πj/points of the least-squares trigonometric fit
    (harmonics up to (points − 1)//2) to states ``z`` at cage phases ``phi`` (rad)."""
    harmonics = (points - 1) // 2
    k = np.arange(1, harmonics + 1)

    def basis(x):
        return np.hstack([np.ones((len(x), 1)), np.cos(np.outer(x, k)), np.sin(np.outer(x, k))])

    coeffs, *_ = np.linalg.lstsq(basis(phi), z, rcond=None)
    return basis(2 * math.pi * np.arange(points) / points) @ coeffs


def newton_circle(shaft: ShaftMap, u0: np.ndarray, p: np.ndarray, scale: np.ndarray,
                  tol: float, max_iter: int) -> tuple[np.ndarray, int, float, bool, str]:
    """Newton on F(U) = P(U) − (R_ρ ⊗ I) U, scaled by ``scale`` per state, from ``u0``
    (N × n), with backtracking on the scaled residual's max norm."""
    n, points = shaft.system.n_state, shaft.points
    w1, w2 = omegas_of(shaft.system, shaft.frequencies, p)
    rho = float(np.mod(2 * math.pi * w2 / w1, 2 * math.pi))
    shift = shift_matrix(points, rho)
    phi = 2 * math.pi * np.arange(points) / points
    big = np.kron(shift, np.eye(n))
    d = np.tile(scale, points)

    def residual(u):
        zt, jac, _ = shaft(u, phi, p)
        return (zt - shift @ u), jac

    u = np.array(u0, dtype=float)
    f, jac = residual(u)
    norm = float(np.max(np.abs(f) / scale))
    for it in range(1, max_iter + 1):
        if not math.isfinite(norm):
            return u, it - 1, norm, False, "the residual is not finite"
        if norm <= tol:
            return u, it - 1, norm, True, "converged"
        full = -big
        for j in range(points):
            full[j * n:(j + 1) * n, j * n:(j + 1) * n] += jac[j]
        scaled = full * d[None, :] / d[:, None]
        try:
            step = np.linalg.solve(scaled, -f.reshape(-1) / d) * d
        except np.linalg.LinAlgError:
            return u, it, norm, False, "singular Jacobian"
        alpha = 1.0
        while True:
            trial = u + alpha * step.reshape(points, n)
            f_new, jac_new = residual(trial)
            new = float(np.max(np.abs(f_new) / scale))
            if new < norm or alpha < 1e-3:
                break
            alpha /= 2
        if not new < norm:
            return u, it, norm, False, f"no descent (residual {norm:.2e})"
        u, f, jac, norm = trial, f_new, jac_new, new
    if norm <= tol:
        return u, max_iter, norm, True, "converged"
    return u, max_iter, norm, False, f"no convergence in {max_iter} iterations " \
                                     f"(residual {norm:.2e})"


def regular_grid(states: np.ndarray, circle: np.ndarray, rho_full: float) -> np.ndarray:
    """u on the regular N1 × N grid from the samples of each circle point along its
    trajectory (``states`` N × N1 × n at θ1 = 2πa/N1, a = 1..N1; ``circle`` the a = 0
    ones), each row of shaft phase a shifted back by ρ_full·a/N1 in θ2."""
    points, n1, n = states.shape
    rows = np.concatenate([circle[:, None, :], states[:, :-1, :]], axis=1)  # a = 0..N1−1
    grid = np.empty((n1, points, n))
    for a in range(n1):
        grid[a] = shift_matrix(points, -rho_full * a / n1) @ rows[:, a, :]
    return grid


def solve_circle(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    frequencies: str | tuple = "shaft,vc",
    points: int = DEFAULT_POINTS,
    *,
    samples: int = SECTION_SAMPLES,
    dt: float | None = None,
    settle: float | None = None,
    guess: np.ndarray | None = None,
    tol: float = 1e-10,
    max_iter: int = 20,
    convergence: bool = True,
    stability: bool = True,
    lyapunov_duration: float = 2.0,
    **parameters: float,
) -> CircleResponse:
    """The quasi-periodic response on the torus of ``frequencies`` (``"F1,F2"``: F1 the
    explicit time's ``shaft`` or ``param:NAME``, F2 a bearing's ``vc``) as the invariant
    circle of the F1-period map at ``points`` cage phases (module docstring).

    RK4 steps of h = T1/steps <= ``dt`` s (default the spec's; T1 a whole number of steps
    when it is one of dt); ``samples`` shaft phases N1 of the torus grid (rounded to a
    divisor of the steps). The guess: ``guess`` (a circle of any number of points, N' × n),
    else the fit to the shaft sections of a run settled for ``settle`` s (default the
    spec's transient). ``tol`` bounds the scaled residual max |F_i|/s_i. ``convergence``:
    also solve with 2N points and report the change. ``stability``: λ1 and the drift over
    ``lyapunov_duration`` s from u(0, 0) (``torus_solve.torus_lambda1``). A solve that does
    not converge is returned with ``converged`` False and its message, never raised.
    """
    import time

    start = time.perf_counter()
    system = as_system(system, n_balls, **parameters)
    system, freqs, _ = prepare_torus(system, frequencies, (1, 1))
    if freqs[0].kind == "vc" or freqs[1].kind != "vc":
        raise InputError(f"frequencies: the shaft map needs F1 the explicit time's (shaft or "
                         f"param:NAME) and F2 a VC, got {freqs[0]},{freqs[1]}",
                         field="frequencies")
    points = check_points(points, system.n_state)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 3:
        raise InputError(f"samples: must be a whole number >= 3, got {samples!r}",
                         field="samples")
    w1, w2 = omegas_of(system, freqs)
    dt_max = RunPlan.step(system, dt).dt
    steps, n1 = shaft_steps(2 * math.pi / w1, dt_max, int(samples))
    h = 2 * math.pi / w1 / steps
    t, z, t_check, z_check = settled_section(system, freqs, h, settle, max(4 * points, 200))
    check_phases(system, freqs, torus_function(system, freqs), t_check, z_check)
    if guess is None:
        u0 = fit_circle(np.mod(w2 * t, 2 * math.pi), z, points)
    else:
        g = np.asarray(guess, dtype=float)
        u0 = interpolate_circle(g, 2 * math.pi * np.arange(points) / points)
    scale = state_scale(np.abs(z).max(axis=0), 2 * math.pi / w1,
                        system.model.module.STATE_UNITS)
    shaft = ShaftMap(system, freqs, steps, n1, points)
    with blas_threads():
        u, iters, res, ok, msg = newton_circle(shaft, u0, system.p, scale, tol, max_iter)
    response = CircleResponse(system=system, frequencies=freqs, circle=u, converged=ok,
                              iterations=iters, residual=res, message=msg, scale=scale,
                              steps=steps, samples=n1)
    if not ok:
        response.seconds = time.perf_counter() - start
        return response
    phi = 2 * math.pi * np.arange(points) / points
    _, _, states = shaft(u, phi, system.p)
    response.grid = regular_grid(states, u, 2 * math.pi * w2 / w1)
    response.integrated, response.amplitude_error = integrated_amplitude(response)
    modes = circle_modes(u / scale[None, :])
    top = float(modes[1:].max())
    tail = modes[np.arange(len(modes)) > TAIL_FRACTION * points]
    response.tail = float(tail.max() / top) if top > 0 and tail.size else 0.0
    if convergence:
        fine = ShaftMap(system, freqs, steps, n1, 2 * points)
        u2, _, _, ok2, _ = newton_circle(
            fine, interpolate_circle(u, np.pi * np.arange(2 * points) / points), system.p,
            scale, tol, max_iter)
        if ok2:
            grid = 2 * math.pi * np.arange(8 * points) / (8 * points)
            amp = np.ptp(response.grid.reshape(-1, system.n_state), axis=0) / 2
            diff = np.abs(interpolate_circle(u, grid) - interpolate_circle(u2, grid))
            response.change = float(np.max(diff.max(axis=0) / np.maximum(amp, 1e-300)))
            response.change_points = 2 * points
    if stability:
        ts, coeffs = response.torus, response.coefficients
        response.lambda1, response.lambda1_ci95 = torus_lambda1(ts, coeffs, lyapunov_duration,
                                                                dt)
        response.drift = torus_drift(ts, coeffs, lyapunov_duration, dt)
    response.seconds = time.perf_counter() - start
    return response


def circle_dataset(response: CircleResponse) -> xr.Dataset:
    """The torus of a circle as the Dataset of ``torus_dataset.tori_dataset`` (one point;
    ``border`` the circle's ``tail``, ``residual_fine`` NaN), plus ``circle`` (state ×
    phi) and attrs ``method`` (the invariant circle), ``points``, ``steps``,
    ``circle_change`` (the change at 2N points), ``converged``, ``iterations``,
    ``message``."""
    from analysis.frequency.torus.dataset import tori_dataset

    ts = response.torus
    n = response.points
    variables = {"circle": (("state", "phi"), response.circle.T,
                            {"long_name": "the invariant circle u(0, phi) of the shaft map at "
                                          "the cage phases phi, in the state's unit"})}
    data = tori_dataset(
        ts, response.coefficients[None, :], [response.system.p],
        np.array([response.residual]), np.array([math.nan]), np.array([response.tail]),
        np.array([response.lambda1]), np.array([response.lambda1_ci95]),
        np.array([response.drift]), [""], response.scale, variables,
        converged=int(response.converged), iterations=response.iterations,
        message=response.message, points=n, steps=response.steps,
        circle_change=response.change, circle_change_points=response.change_points,
        amplitude_error=response.amplitude_error,
        series=("the 2-D series interpolates the N1 x N grid between its shaft phases "
                "(between_error: its distance from the integrated run); amplitude from "
                "integrated revolutions"))
    if response.integrated is not None:
        data["amplitude"] = data.amplitude.copy(data=np.asarray(response.integrated)[None, :])
        data.amplitude.attrs["long_name"] = (
            f"(max - min)/2 of each state over one shaft period integrated (RK4, every "
            f"step) from {AMPLITUDE_PHASES} N cage phases of the circle, in the state's "
            f"unit; amplitude_error: its change from half as many phases")
    data = data.assign_coords(phi=("phi", 2 * np.pi * np.arange(n) / n, {"units": "rad"}))
    data.attrs["method"] = ("invariant circle of the shaft-period map (quasi-periodic "
                            "shooting, RK4 with AD Jacobian), lambda1 by Lyapunov")
    data.attrs["solver"] = "shooting"
    data.residual.attrs["long_name"] = ("max |P(u_j) - u(phi_j + rho)|_i / s_i of the "
                                        "circle")
    data.border.attrs["long_name"] = ("largest circle mode k > 0.4 N / largest circle mode "
                                      "(states scaled)")
    return data


