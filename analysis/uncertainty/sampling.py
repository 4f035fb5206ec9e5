"""Quasi-Monte Carlo draws of the uncertain parameters, laid out for Sobol' indices.

N base points of a scrambled, seeded Sobol' sequence in 2P dimensions (``scipy.stats.qmc``)
give two independent unit matrices A and B (N × P each). The design holds, for every base
point i, the row A_i, the P rows AB_i^(j) (A_i with its j-th coordinate taken from B_i) and
the row B_i: N (P + 2) rows in that order, SALib's layout (``SALib.sample.sobol`` with
``calc_second_order=False``), which ``sobol.indices`` reads. Every row is mapped through the
distributions' inverse CDFs (``Dist.ppf``). Each row alone is a draw from the joint
distribution (the parameters are independent); the A and B rows are 2N draws of which no
two share a coordinate, and they alone give the regime probabilities
(``Design.independent``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from analysis.errors import InputError, check_count
from analysis.uncertainty.distributions import Dist

MAX_SAMPLES = 1 << 20
"""Base points N at most."""


@dataclass(frozen=True)
class Design:
    """A Saltelli design: ``unit`` and ``values`` (N (P + 2) × P), rows ordered as the
    module docstring says."""

    names: tuple[str, ...]
    unit: np.ndarray
    values: np.ndarray
    samples: int

    @property
    def runs(self) -> int:
        """Rows, each one member run per swept value."""
        return len(self.values)

    @property
    def independent(self) -> np.ndarray:
        """Indices of the A and B rows (2N draws, no coordinate shared)."""
        p = len(self.names)
        base = np.arange(self.samples) * (p + 2)
        return np.sort(np.concatenate([base, base + p + 1]))


def check_samples(samples: int) -> int:
    """``samples`` as a whole number in [1, ``MAX_SAMPLES``] (``InputError`` else)."""
    return check_count("samples", samples, 1, MAX_SAMPLES)


def unit_design(p: int, samples: int, seed: int) -> np.ndarray:
    """The unit design (N (P + 2) × P) from N scrambled Sobol' points in 2P dimensions."""
    sampler = qmc.Sobol(d=2 * p, scramble=True, seed=seed)
    with warnings.catch_warnings():  # N not a power of 2: the balance properties weaken
        warnings.simplefilter("ignore", UserWarning)
        base = sampler.random(samples)
    a, b = base[:, :p], base[:, p:]
    rows = np.empty((samples, p + 2, p))
    rows[:, 0] = a
    for j in range(p):
        rows[:, 1 + j] = a
        rows[:, 1 + j, j] = b[:, j]
    rows[:, p + 1] = b
    return rows.reshape(samples * (p + 2), p)


def draw(dists: Sequence[Dist], samples: int, seed: int = 0) -> Design:
    """The Saltelli design of ``samples`` base points for ``dists``, seeded."""
    samples = check_samples(samples)
    seed = check_count("seed", seed, 0, 2**32 - 1)
    unit = unit_design(len(dists), samples, seed)
    values = np.column_stack([d.ppf(unit[:, j]) for j, d in enumerate(dists)])
    if not np.all(np.isfinite(values)):
        raise InputError("dist: a draw is not finite", field="dist")
    return Design(tuple(d.name for d in dists), unit, values, samples)


def power_of_two(samples: int) -> bool:
    """Whether N is a power of 2 (Sobol' points are balanced then)."""
    return samples > 0 and math.log2(samples).is_integer()
