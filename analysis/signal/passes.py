"""When a ball meets a localized defect: the passing times of the model's kinematics.

Ball i (1 … N_b) of a bearing sits at θ_i(t) = 2π(i−1)/N_b + ω_cage t. It is over

- an outer-race pit at φ_d when θ_i ≡ φ_d (mod 2π): t = (φ_d − 2π(i−1)/N_b + 2πm)/ω_cage;
- an inner-race pit at φ_d + ω t when θ_i − φ_d − ω t ≡ 0:
  t = (2π(i−1)/N_b − φ_d + 2πm)/(ω − ω_cage);
- and a pit on a ball at spin angle φ_d + ω_spin t meets the outer race when the spin angle
  is ≡ 0 and the inner race when ≡ π: t = (kπ − φ_d)/ω_spin.

The frequencies are the run's (``shaft_hz``, ``cage_hz``, ``bsf_hz`` in its attrs), so the
times are those of the simulated kinematics; consecutive passes are 1/BPFO, 1/BPFI or
1/(2 BSF) apart.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from analysis.errors import InputError

RACES = ("outer", "inner", "ball")


def passing_times(attrs: Mapping, race: str, t0: float, t1: float,
                  defect_angle: float | None = None) -> np.ndarray:
    """Sorted times (s) in [t0, t1] at which a ball meets the defect on ``race`` (``outer``,
    ``inner`` or ``ball``: then the strikes on both races) of a one-bearing run (attrs
    ``shaft_hz``, ``cage_hz``, ``n_balls``, ``bsf_hz``; ``defect_angle`` in rad, default the
    run's)."""
    if race not in RACES:
        raise InputError(f"race: must be one of {', '.join(RACES)}, got {race!r}")
    phi = float(attrs.get("defect_angle", 0.0) if defect_angle is None else defect_angle)
    n = int(attrs["n_balls"])
    omega, cage = 2 * math.pi * float(attrs["shaft_hz"]), 2 * math.pi * float(attrs["cage_hz"])
    if race == "ball":
        spin = 2 * math.pi * float(attrs["bsf_hz"])
        k = np.arange(math.floor((t0 * spin + phi) / math.pi),
                      math.ceil((t1 * spin + phi) / math.pi) + 1)
        times = (k * math.pi - phi) / spin
    else:
        rate = cage if race == "outer" else omega - cage
        sign = 1.0 if race == "outer" else -1.0
        offsets = np.array([sign * (phi - 2 * math.pi * i / n) for i in range(n)])
        m = np.arange(math.floor(t0 * rate / (2 * math.pi)) - 1,
                      math.ceil(t1 * rate / (2 * math.pi)) + 2)
        times = ((offsets[:, None] + 2 * math.pi * m[None, :]) / rate).ravel()
    times = np.sort(times)
    return times[(times >= t0) & (times <= t1)]
