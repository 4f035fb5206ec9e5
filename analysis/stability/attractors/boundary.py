"""How uncertain a basin picture is: basin entropy and the uncertainty exponent.

Both are computed from a labelled grid (``basins``' ``basin``: one label per initial
state; diverged, undecided and failed count as labels of their own).

**Basin entropy** (Daza, Wagemakers, Georgeot, Guéry-Odelin & Sanjuán, Sci. Rep. 6,
31416, 2016): the grid is cut into boxes of ``box`` × ``box`` cells; in box i the labels'
shares p_ij give the Gibbs entropy S_i = −Σ_j p_ij ln p_ij. The basin entropy S_b is the
mean of S_i over all boxes, the boundary basin entropy S_bb the mean over the boxes that
hold more than one label (the boundary boxes). A smooth boundary gives S_bb small (≪ ln 2);
S_bb > ln 2 proves the boundary fractal (Daza et al.'s log 2 criterion). Natural
logarithms (nats).

**Uncertainty exponent** (Grebogi, McDonald, Ott & Yorke, Phys. Lett. A 99, 415, 1983): an
initial state is ε-uncertain when a state ε away along a grid axis (either direction, either
axis) has another label. The fraction f(ε) of uncertain states (among those whose
neighbours at ε are all on the grid) scales as ε^α; α is the slope of ln f against ln ε
(least squares). α = 1 for a smooth boundary, α < 1 for a fractal one (its box-counting
dimension is D − α), α near 0 for a riddled basin. ε is in grid cells (the slope does not
depend on the unit). Both counts are reported (issue 41): over the interior states only
(``exponent``, the one printed first) and over every state, each compared with the
neighbours it has on the grid (``exponent_edges``); on a riddled picture they differ
(issue 41 measured 0.025 and 0.014).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError

BOX = 5
"""Cells per side of the boxes of the basin entropy (Daza et al. use 5)."""


@dataclass(frozen=True)
class Boundary:
    """The boundary measures of one labelled grid."""

    basin_entropy: float
    """S_b, nats."""
    boundary_entropy: float
    """S_bb, nats (0 when no box holds two labels)."""
    boundary_boxes: float
    """Share of the boxes that hold more than one label."""
    box: int
    """Cells per box side."""
    epsilons: np.ndarray
    """ε, grid cells."""
    uncertain: np.ndarray
    """f(ε): the fraction of ε-uncertain states."""
    exponent: float
    """α, the slope of ln f against ln ε (NaN when fewer than two f(ε) > 0)."""
    uncertain_edges: np.ndarray | None = None
    """f(ε) over every state, each against the neighbours it has on the grid."""
    exponent_edges: float = float("nan")
    """α of ``uncertain_edges``."""

    @property
    def fractal(self) -> bool:
        """Whether S_bb > ln 2 (Daza et al.'s sufficient condition for a fractal
        boundary)."""
        return self.boundary_entropy > np.log(2)


def _grid(labels: np.ndarray) -> np.ndarray:
    grid = np.asarray(labels)
    if grid.ndim != 2 or min(grid.shape) < 2:
        raise InputError(f"basin: a grid of at least 2 × 2 labels is needed, got shape "
                         f"{grid.shape}")
    return grid


def basin_entropy(labels: np.ndarray, box: int = BOX) -> tuple[float, float, float]:
    """(S_b, S_bb, share of boundary boxes) of a labelled grid, in boxes of ``box`` ×
    ``box`` cells (the cells beyond the last whole box along an axis are left out)."""
    grid = _grid(labels)
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or \
            not 1 <= box <= min(grid.shape):
        raise InputError(f"box: must be a whole number from 1 to {min(grid.shape)} (the "
                         f"grid's shorter side), got {box!r}")
    ny, nx = grid.shape[0] // box, grid.shape[1] // box
    cells = grid[:ny * box, :nx * box].reshape(ny, box, nx, box).swapaxes(1, 2)
    cells = cells.reshape(ny * nx, box * box)
    entropies = np.zeros(len(cells))
    for k, row in enumerate(cells):
        _, counts = np.unique(row, return_counts=True)
        p = counts / counts.sum()
        entropies[k] = float(-(p * np.log(p)).sum())
    boundary = np.array([len(np.unique(row)) > 1 for row in cells])
    sb = float(entropies.mean())
    sbb = float(entropies[boundary].mean()) if boundary.any() else 0.0
    return sb, sbb, float(boundary.mean())


def _uncertain(labels: np.ndarray, epsilon: int) -> tuple[np.ndarray, int]:
    """(mask, ε): each state of a labelled grid marked when one of its four neighbours at
    ε cells that lie on the grid has another label."""
    grid = _grid(labels)
    e = int(epsilon)
    ny, nx = grid.shape
    if e < 1 or 2 * e >= min(ny, nx):
        raise InputError(f"epsilon: must be from 1 to {(min(ny, nx) - 1) // 2} cells for "
                         f"this grid, got {epsilon!r}")
    uncertain = np.zeros(grid.shape, dtype=bool)
    uncertain[e:, :] |= grid[e:, :] != grid[:-e, :]
    uncertain[:-e, :] |= grid[:-e, :] != grid[e:, :]
    uncertain[:, e:] |= grid[:, e:] != grid[:, :-e]
    uncertain[:, :-e] |= grid[:, :-e] != grid[:, e:]
    return uncertain, e


def uncertain_fraction(labels: np.ndarray, epsilon: int) -> float:
    """The fraction of ε-uncertain states of a labelled grid (``epsilon`` in cells; among
    the states whose four neighbours at ε lie on the grid)."""
    uncertain, e = _uncertain(labels, epsilon)
    return float(uncertain[e:-e, e:-e].mean())


def uncertain_fraction_edges(labels: np.ndarray, epsilon: int) -> float:
    """The fraction of ε-uncertain states over every state of a labelled grid, each
    compared with those of its four neighbours at ε (cells) that lie on the grid."""
    uncertain, _ = _uncertain(labels, epsilon)
    return float(uncertain.mean())


def _slope(eps: np.ndarray, f: np.ndarray) -> float:
    keep = f > 0
    return (float(np.polyfit(np.log(eps[keep]), np.log(f[keep]), 1)[0])
            if np.count_nonzero(keep) >= 2 else float("nan"))


def default_epsilons(shape: tuple[int, ...]) -> np.ndarray:
    """ε from 1 cell to a tenth of the grid's shorter side (at least two values when the
    grid allows: 1 and 2 cells), about geometric, whole cells."""
    top = max(min(shape) // 10, 2)
    top = min(top, (min(shape) - 1) // 2)
    return np.unique(np.round(np.geomspace(1, max(top, 1), 6)).astype(int))


def boundary_measures(labels: np.ndarray, box: int = BOX,
                      epsilons: np.ndarray | None = None) -> Boundary:
    """The basin entropy (in boxes of ``box`` cells, or the grid's shorter side when
    smaller) and the uncertainty exponent (over ``epsilons``, cells; default
    ``default_epsilons``) of a labelled grid (see the module)."""
    grid = _grid(labels)
    box = min(box, min(grid.shape))
    sb, sbb, share = basin_entropy(grid, box)
    eps = default_epsilons(grid.shape) if epsilons is None else np.asarray(epsilons, int)
    eps = eps[2 * eps < min(grid.shape)]
    f = np.array([uncertain_fraction(grid, e) for e in eps])
    edges = np.array([uncertain_fraction_edges(grid, e) for e in eps])
    return Boundary(sb, sbb, share, box, eps.astype(float), f, _slope(eps, f), edges,
                    _slope(eps, edges))
