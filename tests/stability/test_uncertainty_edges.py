"""Issue 41: the uncertainty exponent says which states it counts, and the edge-inclusive
count is reported beside the interior one. Both fractions checked against a brute-force
count written here (state by state, neighbour by neighbour), on a random riddled picture
(both exponents near 0) and a straight boundary (both near 1)."""

import numpy as np
import pytest

from analysis.stability.attractors.boundary import (
    boundary_measures,
    uncertain_fraction,
    uncertain_fraction_edges,
)


def brute(grid: np.ndarray, e: int, edges: bool) -> float:
    ny, nx = grid.shape
    counted = uncertain = 0
    for i in range(ny):
        for j in range(nx):
            near = [(i + di, j + dj) for di, dj in ((e, 0), (-e, 0), (0, e), (0, -e))]
            inside = [(a, b) for a, b in near if 0 <= a < ny and 0 <= b < nx]
            if not edges and len(inside) < 4:
                continue
            counted += 1
            uncertain += any(grid[a, b] != grid[i, j] for a, b in inside)
    return uncertain / counted


@pytest.mark.parametrize("e", [1, 2, 5])
def test_both_counts_match_a_brute_force_count(e):
    grid = np.random.default_rng(3).integers(0, 3, (23, 31))
    grid[:, :9] = 0  # a region of one label, so that edge and interior counts differ
    assert uncertain_fraction(grid, e) == pytest.approx(brute(grid, e, False))
    assert uncertain_fraction_edges(grid, e) == pytest.approx(brute(grid, e, True))
    assert uncertain_fraction_edges(grid, e) != uncertain_fraction(grid, e)


def test_both_exponents_reported():
    straight = np.zeros((60, 60), int)
    straight[:, 30:] = 1
    smooth = boundary_measures(straight)
    # interior: f = 2ε/(60 − 2ε), slope 1.10 over ε = 1…6; every state: f = 2ε/60, slope 1
    assert smooth.exponent == pytest.approx(1.10, abs=0.02)
    assert smooth.exponent_edges == pytest.approx(1, abs=1e-9)
    riddled = boundary_measures(np.random.default_rng(0).integers(0, 2, (60, 60)))
    assert abs(riddled.exponent) < 0.1 and abs(riddled.exponent_edges) < 0.1
    assert len(riddled.uncertain_edges) == len(riddled.epsilons)
