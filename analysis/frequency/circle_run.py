"""A run sampled from an invariant-circle torus by integrating, not interpolating, between
the shaft sections (issue 32).

The circle v(φ) is the torus at the shaft sections t = k·T1. ``torus_run`` evaluates the
2-D Fourier series of the N1 × N grid, whose error between the sections is that of N1
samples per revolution of a contact response (about 2e-3 of the amplitude at N1 = 300,
against 5e-4 at the sections). Here each revolution k starts at the circle's point
v(ω2 k T1 mod 2π) (trigonometric interpolation of the N samples) and is integrated over T1
with the same fixed-step RK4 (h = T1/steps, the ``steps`` of the solve: the discrete map
whose invariant circle was solved), every step kept. Between the sections the run so holds
the RK4's error plus the circle's own, grown over at most one revolution.

``between_error`` measures the difference between the two reconstructions (fraction of
each state's amplitude, the largest over the states): what the interpolation loses between
the sections.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.circle.solve import ShaftMap, interpolate_circle
from analysis.frequency.torus.dataset import check_torus_run, torus_of, torus_run
from analysis.frequency.torus.equations import omegas_of
from analysis.provenance import completed_attrs, to_dataset


def _is_circle(data: xr.Dataset) -> bool:
    return data.attrs.get("solver") == "shooting" and "circle" in data


def circle_states(data: xr.Dataset, duration: float, refine: int = 1
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(t (s), z (len(t) × n)) from t = 0 over ``duration`` s at the circle's RK4 step: each
    revolution integrated from its section point on the circle (module docstring);
    ``refine``: integrated at the step / ``refine``, kept at the circle's step."""
    if not _is_circle(data):
        raise InputError("torus: the dataset is not an invariant-circle torus "
                         "(bearingdyn torus --method shooting)")
    ts, _ = torus_of(data, -1)
    system, freqs = ts.system, ts.frequencies
    w1, w2 = omegas_of(system, freqs)
    period = 2 * math.pi / w1
    steps = int(data.attrs["steps"])
    h = period / steps
    revolutions = max(1, math.ceil(duration / period - 1e-9))
    phi = np.mod(w2 * period * np.arange(revolutions), 2 * math.pi)
    circle = data.circle.values if data.circle.ndim == 2 else data.circle.values[-1]
    starts = interpolate_circle(circle.T, phi)  # a branch: its last circle, as torus_of
    shaft = ShaftMap(system, freqs, steps * refine, steps, revolutions)
    _, _, states = shaft(starts, phi, system.p)
    # each section holds its circle point (the end of the revolution before differs by the
    # circle's invariance defect between its samples)
    z = np.concatenate([starts[:, None, :], states[:, :-1, :]], axis=1)
    z = np.vstack([z.reshape(-1, system.n_state), states[-1, -1:]])
    t = h * np.arange(len(z))
    keep = t <= duration + 0.5 * h
    return t[keep], z[keep]


def circle_run(data: xr.Dataset, duration: float, dt: float | None = None) -> xr.Dataset:
    """The run of ``torus_run`` for an invariant-circle torus, integrated between the
    sections (sampled at the circle's RK4 step, so ``dt`` only bounds the check); any
    other torus Dataset goes to ``torus_run``."""
    if not _is_circle(data):
        return torus_run(data, duration, dt)
    ts, _ = torus_of(data, -1)
    check_torus_run(ts.system, duration, dt)
    t, z = circle_states(data, duration)
    attrs = completed_attrs(ts.system, method="torus", dt=float(t[1] - t[0]), save_every=1,
                            duration=duration, transient=0.0, t_start=0.0)
    attrs.update(frequencies=",".join(str(per) for per in ts.frequencies),
                 harmonics=f"{ts.harmonics[0]},{ts.harmonics[1]}",
                 reconstruction="RK4 from the circle at each shaft section")
    return to_dataset(t, z.T, attrs, ts.system.model)


def _apart(a: np.ndarray, z: np.ndarray) -> float:
    """max over the states of max |a − z| / ((max − min)/2 of z)."""
    amp = np.maximum(np.ptp(z, axis=0) / 2, 1e-300)
    return float(np.max(np.max(np.abs(a - z), axis=0) / amp))


def run_errors(data: xr.Dataset, duration: float | None = None) -> tuple[float, float]:
    """(``between_error``, ``step_error``) over ``duration`` s (default 10 revolutions),
    from one integrated run (module docstring)."""
    ts, coeffs = torus_of(data, -1)
    period = 2 * math.pi / omegas_of(ts.system, ts.frequencies)[0]
    span = 10 * period if duration is None else duration
    t, z = circle_states(data, span)
    return (_apart(ts.at_times(coeffs, t), z),
            _apart(circle_states(data, span, refine=2)[1], z))


def between_error(data: xr.Dataset, duration: float | None = None) -> float:
    """Largest |series − integrated| over ``duration`` s (default 10 revolutions), relative
    to each state's amplitude, the largest over the states: the interpolation's error
    between the sections."""
    ts, coeffs = torus_of(data, -1)
    period = 2 * math.pi / omegas_of(ts.system, ts.frequencies)[0]
    t, z = circle_states(data, 10 * period if duration is None else duration)
    return _apart(ts.at_times(coeffs, t), z)


def with_between_error(data: xr.Dataset) -> xr.Dataset:
    """An invariant-circle torus (one point) with the attrs ``between_error`` (the stored
    series against the integrated run) and ``run_step_error`` (the integrated run against
    one at half the RK4 step: the RK4's share of the run's error between the sections, the
    rest being the circle's own at the sections carried over one revolution), each over 10
    revolutions; any other Dataset unchanged."""
    if not _is_circle(data) or data.sizes["point"] != 1:
        return data
    data = data.copy()
    data.attrs["between_error"], data.attrs["run_step_error"] = run_errors(data)
    return data
