"""Shaft-synchronous (1X) phasors: the amplitude and phase of a response at the shaft
frequency, referred to the shaft angle, as a keyphasor measures them.

The shaft angle is φ(t) = ω·t (rad) for a run at constant speed (``shaft_angle``; ω from
the ``shaft_hz`` attr), the angle of the unbalance force P_u·(cos φ, sin φ) of the shipped
models; for a run whose speed follows a profile (``analysis.integrate.speed_profile``, in
its attrs) it is the profile's φ(t) = ∫ω dt; a dataset that carries its angle as a
variable ``shaft_angle`` (rad, over ``t``) is referred to that angle.

The phasor of order k of a signal s(t) is

    S_k = 2 Σ_j w_j (s_j − s̄) e^{−i k φ_j} / Σ_j w_j        (Hann window w)

so that s(t) ≈ s̄ + |S_k| cos(k φ(t) − lag) with lag = −arg S_k: the 1X amplitude |S_1|
(the signal's unit) and the phase lag (rad, in [0, 2π)) by which the response's positive
peak follows the shaft's zero angle (the keyphasor mark). The window keeps lines at other
frequencies (VC, 2X, …) out of the estimate: a line Δf away leaks in by the Hann window's
sidelobe at Δf·T (T the record's length), below 1e-4 of its amplitude at 20 bins.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.integrate.speed_profile import profile_of
from analysis.provenance import displacement_names

PHASOR_PREFIXES = ("amplitude1x_", "phase1x_")
"""Names of the 1X record of a variable v in a sweep's points: ``amplitude1x_v`` (the
unit of v) and ``phase1x_v`` (rad, the lag after the shaft mark)."""


def shaft_angle(ds: xr.Dataset) -> np.ndarray:
    """The shaft angle φ(t) (rad) at each sample of a run: its ``shaft_angle`` variable
    when it has one (a run whose speed follows a profile: the angle as the integral of
    the speed), else 2π·``shaft_hz``·t (constant speed). ``InputError`` for a run without
    a turning shaft."""
    if "shaft_angle" in ds.variables:
        return np.asarray(ds["shaft_angle"].values, dtype=float)
    profile = profile_of(ds.attrs)
    if profile is not None:  # a run-up or coast-down: φ = ∫ω dt, exactly
        return profile.shaft_angle(np.asarray(ds["t"].values, dtype=float),
                                   float(ds.attrs["duration"]))
    shaft_hz = float(ds.attrs.get("shaft_hz", 0.0))
    if not (math.isfinite(shaft_hz) and shaft_hz > 0):
        raise InputError(f"shaft_hz: a 1X phasor needs a turning shaft (shaft_hz > 0), got "
                         f"{ds.attrs.get('shaft_hz', 'none')!r}")
    return 2.0 * math.pi * shaft_hz * np.asarray(ds["t"].values, dtype=float)


def synchronous_phasor(ds: xr.Dataset, var: str, order: int = 1) -> complex:
    """The order-``order`` phasor S_k of ``ds[var]`` against the shaft angle (module
    docstring): complex, in the unit of the variable (|S| the amplitude, −arg S the lag
    in rad)."""
    if var not in ds.data_vars:
        raise InputError(f"var: no variable {var!r} in the run; variables: "
                         f"{', '.join(map(str, ds.data_vars))}")
    check_count("order", order)
    values = np.asarray(ds[var].values, dtype=float)
    if values.size < 3:
        raise InputError(f"{var}: need at least 3 samples for a phasor, got {values.size}")
    angle = shaft_angle(ds)
    w = scipy.signal.get_window("hann", values.size)
    return complex(2.0 * np.sum(w * (values - values.mean()) * np.exp(-1j * order * angle))
                   / w.sum())


def phase_lag(phasor: complex) -> float:
    """The lag (rad, in [0, 2π)) of a phasor: −arg S."""
    return float(np.mod(-np.angle(phasor), 2 * math.pi))


def phasor_record(ds: xr.Dataset, variables: tuple[str, ...] | None = None
                  ) -> dict[str, float]:
    """The 1X record of a run's first-body displacements (or ``variables``):
    ``amplitude1x_<v>`` (unit of v) and ``phase1x_<v>`` (rad); NaN for a run without a
    turning shaft (no 1X to refer to)."""
    variables = displacement_names(ds) if variables is None else variables
    out: dict[str, float] = {}
    turning = "shaft_angle" in ds.variables or profile_of(ds.attrs) is not None or \
        float(ds.attrs.get("shaft_hz", 0.0)) > 0
    for v in variables:
        s = synchronous_phasor(ds, v) if turning else complex(np.nan, np.nan)
        out[f"amplitude1x_{v}"] = abs(s)
        out[f"phase1x_{v}"] = phase_lag(s) if turning else math.nan
    return out


def phasor_fields(variables: tuple[str, ...]) -> list[str]:
    """The names ``phasor_record`` gives for ``variables``."""
    return [f"{prefix}{v}" for v in variables for prefix in PHASOR_PREFIXES]


__all__ = ["phase_lag", "phasor_fields", "phasor_record", "shaft_angle",
           "synchronous_phasor"]
