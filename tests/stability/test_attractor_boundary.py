"""Basin-boundary measures on grids whose answers are known analytically: a straight
boundary (uncertainty exponent 1, small boundary entropy), checkerboards (every box holds
its labels in known shares), a random picture (exponent 0), and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.stability.attractors.boundary import (
    basin_entropy,
    boundary_measures,
    uncertain_fraction,
)


def straight(n: int = 240, slope: float = 0.3) -> np.ndarray:
    y, x = np.mgrid[0:n, 0:n]
    return np.where(x < 0.4 * n + slope * y, 1, 2)


def test_a_straight_boundary_has_exponent_one_and_a_smooth_entropy():
    b = boundary_measures(straight())
    assert b.exponent == pytest.approx(1.0, abs=0.1)
    assert 0 < b.boundary_entropy < np.log(2) and not b.fractal
    # f(ε) of a straight line: the cells within ε of it, 2ε per row (interior rows)
    assert uncertain_fraction(straight(), 4) == pytest.approx(8 / (240 - 8), rel=0.1)


def test_a_vertical_boundary_on_box_edges_has_no_boundary_box():
    grid = np.where(np.arange(20)[None, :] < 10, 1, 2).repeat(20, axis=0)
    sb, sbb, share = basin_entropy(grid, 5)
    assert (sb, sbb, share) == (0.0, 0.0, 0.0)
    sb, sbb, share = basin_entropy(grid, 4)  # boxes 8–11 straddle the boundary
    p = np.array([2 / 4, 2 / 4])
    assert sbb == pytest.approx(-(p * np.log(p)).sum())
    assert share == pytest.approx(1 / 5)
    assert sb == pytest.approx(share * sbb)


@pytest.mark.parametrize(("colours", "box"), [(2, 2), (3, 3), (4, 2)])
def test_checkerboards_have_the_entropy_of_their_shares(colours, box):
    y, x = np.mgrid[0:24, 0:24]
    grid = (x + y) % colours if colours != 4 else (x % 2) + 2 * (y % 2)
    sb, sbb, share = basin_entropy(grid, box)
    # every box of a 2-checkerboard in 2×2 boxes, of a 3-diagonal pattern in 3×3 boxes and
    # of the 4-colour pattern in 2×2 boxes holds each colour in equal shares: ln(colours)
    assert sb == pytest.approx(np.log(colours)) and sbb == pytest.approx(sb)
    assert share == 1.0


def test_a_random_picture_is_uncertain_at_every_scale():
    grid = np.random.default_rng(1).integers(1, 3, (120, 120))
    b = boundary_measures(grid)
    assert abs(b.exponent) < 0.05
    assert b.boundary_entropy == pytest.approx(np.log(2), abs=0.05)
    assert b.uncertain.min() > 0.9


def test_a_one_label_grid_has_no_boundary():
    b = boundary_measures(np.ones((30, 30), dtype=int))
    assert b.basin_entropy == 0.0 and b.boundary_entropy == 0.0
    assert np.isnan(b.exponent) and not b.uncertain.any()


@pytest.mark.parametrize(("call", "message"), [
    (lambda: basin_entropy(np.ones((4, 4)), 5), "box: must be a whole number from 1 to 4"),
    (lambda: basin_entropy(np.ones(4), 1), "basin: a grid of at least 2 × 2"),
    (lambda: uncertain_fraction(np.ones((10, 10)), 5), "epsilon: must be from 1 to 4"),
])
def test_bad_sizes_name_the_field_and_range(call, message):
    with pytest.raises(InputError, match=message):
        call()
