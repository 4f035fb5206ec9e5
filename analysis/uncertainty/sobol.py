"""Sobol' sensitivity indices, first order and total, with bootstrap intervals.

The estimators are SALib's (``SALib.analyze.sobol`` with ``calc_second_order=False``):
Saltelli et al. 2010 ("Variance based sensitivity analysis of model output", Comput. Phys.
Commun. 181, 259) for the first-order index S1 and Jansen 1999 for the total index ST, on
the design of ``sampling.draw`` (N (P + 2) rows). Their 95 % intervals are the index ± SALib's
``*_conf`` half-width: z times the standard deviation of the index over ``resamples``
bootstrap resamples of the N base points. An output without variance (every draw in the same regime)
has no indices: NaN, said as such.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from analysis.errors import InputError

RESAMPLES = 200
"""Bootstrap resamples of the intervals."""


def indices(names: Sequence[str], y: np.ndarray, *, resamples: int = RESAMPLES,
            seed: int = 0, level: float = 0.95) -> dict[str, dict[str, list[float] | float]]:
    """Per parameter: ``S1``, ``ST`` and their intervals ``S1_ci95``, ``ST_ci95`` ([low,
    high]) of the output ``y`` over a ``sampling`` design of ``names`` (N (P + 2) values in
    the design's order). NaN everywhere when ``y`` has no variance or is not finite."""
    from SALib.analyze import sobol

    p = len(names)
    y = np.asarray(y, dtype=float)
    if p < 1 or y.ndim != 1 or len(y) % (p + 2) or len(y) < p + 2:
        raise InputError(f"sobol: {len(y)} outputs do not fit a design of {p} parameter(s)")
    nan = {"S1": np.nan, "ST": np.nan, "S1_ci95": [np.nan, np.nan],
           "ST_ci95": [np.nan, np.nan]}
    if not np.all(np.isfinite(y)) or np.var(y) == 0.0 or len(y) // (p + 2) < 2:
        return {name: dict(nan) for name in names}
    problem = {"num_vars": p, "names": list(names), "bounds": [[0.0, 1.0]] * p}
    with np.errstate(all="ignore"):
        found = sobol.analyze(problem, y, calc_second_order=False, num_resamples=resamples,
                              conf_level=level, seed=seed)
    out = {}
    for j, name in enumerate(names):
        s1, st = float(found["S1"][j]), float(found["ST"][j])
        c1, ct = float(found["S1_conf"][j]), float(found["ST_conf"][j])
        out[name] = {"S1": s1, "ST": st, "S1_ci95": [s1 - c1, s1 + c1],
                     "ST_ci95": [st - ct, st + ct]}
    return out
