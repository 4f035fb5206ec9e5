"""Regime probabilities with Wilson 95 % intervals.

A member's class (``analysis.stability.classify``: periodic-n, quasi-periodic, chaotic; or
``diverged``) is counted under its regime: ``chaotic``, ``quasi-periodic``, ``periodic-<n>``
by its period n >= 1, ``diverged``. The probability of a regime is the share of draws in it;
its interval is Wilson's score interval (Wilson 1927), which keeps its coverage near the
stated level for shares near 0 or 1, where the normal approximation's collapses to a point.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence

import numpy as np
from scipy.stats import norm

from analysis.errors import InputError

REGIMES = ("chaotic", "quasi-periodic", "diverged")
"""The regimes besides ``periodic-<n>``."""
_PERIODIC = re.compile(r"periodic-(\d+)$")


def regime(nature: str) -> str:
    """The regime of a class: ``chaotic``, ``quasi-periodic``, ``diverged`` or
    ``periodic-<n>`` (n >= 1); anything else (a point that failed) is ``diverged``."""
    found = _PERIODIC.match(nature)
    if found and int(found.group(1)) >= 1:
        return f"periodic-{int(found.group(1))}"
    return nature if nature in REGIMES else "diverged"


def regime_order(names: Iterable[str]) -> list[str]:
    """Regimes in the order of the figure's bands: periodic-1, 2, …, quasi-periodic,
    chaotic, diverged."""
    names = set(names)
    periodic = sorted((n for n in names if _PERIODIC.match(n)),
                      key=lambda n: int(_PERIODIC.match(n).group(1)))
    return periodic + [r for r in ("quasi-periodic", "chaotic", "diverged") if r in names]


def wilson(successes: int | np.ndarray, n: int | np.ndarray,
           level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Wilson's score interval (low, high) of a share ``successes`` / ``n``."""
    if not 0 < level < 1:
        raise InputError(f"level: must be in (0, 1), got {level!r}")
    k, n = np.asarray(successes, dtype=float), np.asarray(n, dtype=float)
    if np.any(n < 1) or np.any(k < 0) or np.any(k > n):
        raise InputError("wilson: need 0 <= successes <= n and n >= 1")
    z = float(norm.ppf(0.5 + level / 2))
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return np.clip(centre - half, 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


def probabilities(natures: Sequence[str], regimes: Sequence[str] | None = None,
                  level: float = 0.95) -> dict[str, dict]:
    """Per regime: ``probability`` (share of the draws) and ``ci95`` ([low, high], Wilson)
    over ``natures`` (one class per draw); ``regimes``: those to report (default: those
    seen, in ``regime_order``), a regime not seen has probability 0."""
    if not len(natures):
        raise InputError("probabilities: no draws")
    counts = Counter(regime(n) for n in natures)
    names = list(regimes) if regimes is not None else regime_order(counts)
    out = {"probability": {}, "ci95": {}, "count": {}}
    for name in names:
        k = counts.get(name, 0)
        lo, hi = wilson(k, len(natures), level)
        out["probability"][name] = k / len(natures)
        out["ci95"][name] = [float(lo), float(hi)]
        out["count"][name] = int(k)
    return out

