"""Damped natural frequencies, log decrements and whirl of a rotor over speed (a Campbell
diagram), and its critical speeds.

At a speed Omega (rad/s) the rotor ``M q'' + (C + C_b + Omega G) q' + (K + K_b) q = 0`` has
the eigenvalues of ``[[0, I], [-M⁻¹K, -M⁻¹(C + Omega G)]]``. Each pair with positive imaginary
part lambda = -zeta w_n ± i w_d (and not overdamped in all but name, ``OVERDAMPED``) is a
mode: damped frequency w_d / 2 pi (Hz), log decrement
``-2 pi Re(lambda) / Im(lambda)`` (= 2 pi zeta / sqrt(1 - zeta²), as ROSS), and whirl:
at each node the orbit of the mode's (x, y) turns with the shaft (forward) or against it
(backward); a mode whose nodes disagree is ``mixed`` (ROSS's rule: the sign of
Im(conj(x) y), nodes that do not move left out). Overdamped (real) eigenvalues are not
modes. Modes are listed in ascending damped frequency at each speed.

A critical speed is where a mode's frequency equals an excitation line's, ``order × speed``
(1X: order 1); it is found between grid speeds by Brent's method on the eigenproblem itself.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
from scipy.optimize import brentq

from analysis.errors import InputError
from analysis.threads import blas_threads
from modelgen.fe.assembly import RotorMatrices

__all__ = ["WHIRLS", "Campbell", "CriticalSpeed", "campbell", "check_critical", "check_speeds",
           "critical_speeds", "damped_modes", "whirl_of"]

WHIRLS = ("forward", "backward", "mixed")
"""The whirl names of a mode."""
RAD_S = np.pi / 30.0
"""rad/s per rpm."""
OVERDAMPED = 0.01
"""A pair with Im(lambda) below this fraction of |lambda| (damping ratio above 0.99995) is
overdamped in all but name (structural damping beta K on the highest element modes, coupled
by the gyroscopic terms): not a mode."""
STILL = 1e-6
"""A node whose orbit is smaller than this fraction of the largest does not vote on the
whirl."""


def damped_modes(rotor: RotorMatrices, speed_rad_s: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(eigenvalues, displacement eigenvectors as columns) of the modes at a speed, rad/s:
    Im(lambda) > 0, ascending in Im(lambda)."""
    m, c, k = rotor.matrices_at(speed_rad_s)
    n = rotor.n_dof
    a = np.zeros((2 * n, 2 * n))
    a[:n, n:] = np.eye(n)
    lu = la.lu_factor(m)
    a[n:, :n] = -la.lu_solve(lu, k)
    a[n:, n:] = -la.lu_solve(lu, c)
    lam, vec = la.eig(a)
    scale = max(np.abs(lam).max(), 1.0)
    keep = np.flatnonzero((lam.imag > 1e-9 * scale) & (lam.imag >= OVERDAMPED * np.abs(lam)))
    keep = keep[np.argsort(lam.imag[keep], kind="stable")]
    return lam[keep], vec[:n, keep]


def whirl_of(vector: np.ndarray) -> str:
    """``forward``, ``backward`` or ``mixed`` of a displacement eigenvector (4 DOFs a node)."""
    x, y = vector[0::4], vector[1::4]
    size = np.abs(x) ** 2 + np.abs(y) ** 2
    moving = size > STILL**2 * size.max()
    turn = np.imag(np.conj(x[moving]) * y[moving])
    if np.all(turn < 0):
        return "forward"
    if np.all(turn > 0):
        return "backward"
    return "mixed"


@dataclass(frozen=True)
class CriticalSpeed:
    """Where mode ``mode`` (0 = lowest) meets the line ``line`` (frequency = order × speed)."""

    speed_rpm: float
    frequency_hz: float
    mode: int
    whirl: str
    line: str


@dataclass(frozen=True)
class Campbell:
    """Modes over speed: arrays (mode, speed), ascending in frequency at each speed; NaN and
    ``""`` where fewer modes exist."""

    speed_rpm: np.ndarray
    frequency_hz: np.ndarray
    log_dec: np.ndarray
    whirl: np.ndarray
    lines: dict[str, float] = field(default_factory=lambda: {"1X": 1.0})
    critical: tuple[CriticalSpeed, ...] = ()

    def to_json(self, critical: bool = False) -> dict:
        """``{"speed_rpm", "frequency_hz", "log_dec", "whirl"}`` (per mode lists), with
        ``critical_speeds`` when asked."""

        def clean(values: np.ndarray) -> list:
            return [[None if not np.isfinite(v) else float(v) for v in row] for row in values]

        out = {"speed_rpm": [float(s) for s in self.speed_rpm],
               "frequency_hz": clean(self.frequency_hz), "log_dec": clean(self.log_dec),
               "whirl": [[w or None for w in row] for row in self.whirl.tolist()]}
        if critical:
            out["critical_speeds"] = [
                {"speed_rpm": c.speed_rpm, "frequency_hz": c.frequency_hz, "mode": c.mode,
                 "whirl": c.whirl, "line": c.line} for c in self.critical]
        return out


def check_speeds(speed_rpm: Sequence[float]) -> np.ndarray:
    speeds = np.asarray(speed_rpm, dtype=float)
    if speeds.ndim != 1 or speeds.size < 1:
        raise InputError("speeds: give at least one speed", field="speeds")
    if not np.all(np.isfinite(speeds)) or np.any(speeds < 0):
        raise InputError(f"speeds: speeds must be finite and >= 0 rpm, got "
                         f"{speeds.min():g} to {speeds.max():g}", field="speeds")
    if np.any(np.diff(speeds) <= 0):
        raise InputError("speeds: speeds must increase", field="speeds")
    return speeds


def campbell(rotor: RotorMatrices, speed_rpm: Sequence[float], n_modes: int = 6,
             lines: Mapping[str, float] | None = None) -> Campbell:
    """The ``n_modes`` lowest modes at each speed (rpm) and where they cross the excitation
    ``lines`` (name: order, default ``{"1X": 1.0}``)."""
    speeds = check_speeds(speed_rpm)
    if not 1 <= n_modes <= rotor.n_dof:
        raise InputError(f"modes: must be in [1, {rotor.n_dof}] (the rotor's DOFs), got "
                         f"{n_modes}", field="modes")
    lines = dict(lines or {"1X": 1.0})
    shape = (n_modes, speeds.size)
    freq, logdec = np.full(shape, np.nan), np.full(shape, np.nan)
    whirl = np.full(shape, "", dtype=object)
    with blas_threads():  # small dense problems: one BLAS thread is many times faster
        for j, s in enumerate(speeds):
            lam, vec = damped_modes(rotor, s * RAD_S)
            count = min(n_modes, lam.size)
            freq[:count, j] = lam.imag[:count] / (2 * np.pi)
            logdec[:count, j] = -2 * np.pi * lam.real[:count] / lam.imag[:count]
            whirl[:count, j] = [whirl_of(vec[:, i]) for i in range(count)]
        critical = critical_speeds(rotor, speeds, freq, lines)
    return Campbell(speeds, freq, logdec, whirl.astype(str), lines, tuple(critical))


def check_critical(result: Campbell) -> None:
    """InputError unless the speed range passes at least one critical speed (asked for with
    ``--critical-speeds``), naming the lowest mode's frequency to aim at."""
    if result.critical:
        return
    lines = ", ".join(result.lines)
    lowest = result.frequency_hz[0]
    near = ""
    if np.isfinite(lowest).any():
        order = min(result.lines.values())
        near = (f"; the lowest mode is at {np.nanmin(lowest):.4g} to {np.nanmax(lowest):.4g} "
                f"Hz, near {np.nanmin(lowest) * 60 / order:.0f} rpm on the lowest line")
    raise InputError(f"speeds: {result.speed_rpm[0]:g} to {result.speed_rpm[-1]:g} rpm "
                     f"passes no mode's crossing with {lines}{near}; widen the speed range",
                     field="speeds")


def _mode_frequency(rotor: RotorMatrices, speed_rpm: float, mode: int) -> float:
    lam, _ = damped_modes(rotor, speed_rpm * RAD_S)
    return lam.imag[mode] / (2 * np.pi) if mode < lam.size else np.nan


def critical_speeds(rotor: RotorMatrices, speeds: np.ndarray, freq: np.ndarray,
                    lines: Mapping[str, float]) -> list[CriticalSpeed]:
    """Every crossing of a mode's frequency with a line between two grid speeds, refined."""
    found = []
    for name, order in lines.items():
        gap = freq - order * speeds[None, :] / 60.0
        for mode in range(freq.shape[0]):
            for j in range(speeds.size - 1):
                a, b = gap[mode, j], gap[mode, j + 1]
                if not (np.isfinite(a) and np.isfinite(b)) or a * b > 0 or a == b == 0:
                    continue

                def residual(s, mode=mode, order=order):
                    return _mode_frequency(rotor, s, mode) - order * s / 60.0

                s0, s1 = speeds[j], speeds[j + 1]
                speed = s0 if a == 0 else s1 if b == 0 else brentq(residual, s0, s1,
                                                                   xtol=1e-9 * s1)
                _, vec = damped_modes(rotor, speed * RAD_S)
                found.append(CriticalSpeed(float(speed), float(order * speed / 60.0), mode,
                                           whirl_of(vec[:, mode]), name))
    found.sort(key=lambda c: (c.speed_rpm, c.mode))
    return found
