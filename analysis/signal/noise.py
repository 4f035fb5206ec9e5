"""Measurement noise on a run: seeded white Gaussian noise at a given signal-to-noise ratio.

A real accelerometer signal carries noise; a simulated one carries none, so the most
impulsive band of a clean record can be one no sensor would resolve. ``add_noise`` adds
white noise to chosen state variables of a run, each at ``snr_db`` below that variable's
own power (0 dB: noise std equal to the signal's std), drawn from
``numpy.random.default_rng(seed)`` one variable after another: the same seed gives the same
noise. The SNR, the seed and the variables are recorded in the attrs
(``analysis.provenance.noise_attrs``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.provenance import noise_attrs, state_names

SNR_RANGE_DB = (-60.0, 200.0)
"""Allowed signal-to-noise ratios (dB)."""


def check_snr(snr_db: float) -> float:
    """``snr_db`` as a float, or InputError naming ``--noise`` and the allowed range."""
    value = float(snr_db)
    low, high = SNR_RANGE_DB
    if not (math.isfinite(value) and low <= value <= high):
        raise InputError(f"noise: must be an SNR in dB in [{low:g}, {high:g}], got {snr_db}",
                         field="noise")
    return value


def add_noise(ds: xr.Dataset, snr_db: float, seed: int,
              variables: Sequence[str] | None = None) -> xr.Dataset:
    """A copy of the run ``ds`` with white Gaussian noise added to ``variables`` (default:
    every state variable): noise std = std(variable)·10^(−snr_db/20), from
    ``numpy.random.default_rng(seed)``. attrs gain ``noise_snr_db``, ``noise_seed`` and
    ``noise_variables``; a run that already has noise is refused (say it once)."""
    snr = check_snr(snr_db)
    check_count("noise_seed", seed, 0)
    if "noise_seed" in ds.attrs:
        raise InputError(f"noise: this run already has noise (SNR "
                         f"{ds.attrs.get('noise_snr_db')} dB, seed {ds.attrs['noise_seed']})",
                         field="noise")
    names = tuple(state_names(ds)) if variables is None else tuple(variables)
    for name in names:
        if name not in ds.data_vars:
            raise InputError(f"var: no state variable {name!r} in this run; variables: "
                             f"{', '.join(map(str, ds.data_vars))}", field="var")
    rng = np.random.default_rng(int(seed))
    out = ds.copy(deep=True)
    scale = 10 ** (-snr / 20)
    for name in names:
        values = np.asarray(out[name].values, dtype=float)
        noise = rng.standard_normal(values.size).reshape(values.shape)
        out[name].values = values + values.std() * scale * noise
    out.attrs.update(noise_attrs(snr, int(seed), names))
    return out
