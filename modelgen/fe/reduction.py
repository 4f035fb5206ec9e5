"""Reduction of a finite-element rotor to the few coordinates a nonlinear integration needs.

Each bending plane (x–z: the DOFs ``x, beta`` of every node; y–z: ``y, alpha``) is reduced
by itself, from its own mass and stiffness (the linear bearings' direct terms included):

- ``craig_bampton``: the ball-bearing nodes' translations are the interface. The basis is
  the constraint modes (the static shape of a unit interface displacement, the other
  interface DOFs held: ``Psi = -K_ii^-1 K_ib``) and the ``modes`` lowest fixed-interface
  modes (the shaft with its bearing nodes held). Every interface displacement is exactly
  representable, and a static load at the interface is carried exactly.
- ``modal``: the ``modes`` lowest modes of the shaft on its linear bearings (for a shaft
  without ball bearings).
- ``none``: every DOF of the plane (the full model in other coordinates).

The kept space is then written in coordinates in which the mass matrix is diagonal, so
that the generated model's equations are ``m_j q_j'' = F_j`` like every rigid model's:
the space's mass-orthonormal modes, turned (Householder reflections: a QR factorisation of
the interface rows) so that the first coordinate of each plane is the displacement of one
chosen node (``x``, ``y``: physical states, in m; by default a ball bearing's node) and the
k-th other ball-bearing node moves with the first k + 1 coordinates only, the others
scaled so that their largest nodal translation is 1 (``x_q<j>``, ``y_q<j>``: generalised
coordinates, in m). Only one node can be physical this way (two would couple the mass
matrix); every node's translation is an exact linear map of the state (a bearing's is its
station map, with as few terms as the QR leaves). Gyroscopic,
damping and cross-coupled bearing terms (which join the planes) are projected onto this
basis whole; only the basis is chosen per plane.

The arithmetic of the basis is done in ``mpmath`` (30 digits) and the projections with
``math.fsum``: the numbers baked into generated code are the same bits on every machine
(``bearingdyn generate --check`` compares them byte for byte). Inputs are rounded to 12
significant digits first, so last-bit differences of the element matrices (libm's ``pow``
of another platform) do not reach them: a value changes only when it lies within its
last-bit noise of a rounding boundary (about 1e-4 of the entries that have such noise at
all). Fewer digits would be safer still but spoil the cancellations of a very stiff shaft
(its rigid motion then meets a spurious stiffness).

The reduction's error is the largest relative difference of the damped natural
frequencies (modes below twice the highest speed of interest) between the reduced and the
full model, over speeds from 0 to that speed and over ball-bearing stiffnesses
``ERROR_STIFFNESSES`` (the ball bearings stood in for by isotropic springs at their
nodes): ``reduction_error``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from modelgen.lazy import sympy as _sympy  # noqa: F401  (mpmath ships with SymPy)

__all__ = ["ERROR_STIFFNESSES", "Reduced", "ReductionError", "damped_frequencies",
           "held_stiffness_problem", "reduce_rotor", "reduction_error", "stated"]

Method = Literal["craig_bampton", "modal", "none"]
DIGITS = 30
"""Working precision of the basis (decimal digits)."""
SNAP = 1e-20
"""Entries of the basis below this (of a largest nodal translation of 1) are set to 0."""
INPUT_DIGITS = 12
"""Significant digits the assembled matrices are rounded to before reduction."""
ERROR_STIFFNESSES = (1e6, 1e7, 1e8, 1e9, 1e10)
"""Stiffnesses (N/m) of the isotropic springs that stand in for the ball bearings when the
reduction's error is measured (a 6205 ball bearing's radial stiffness is 1e7 to 1e8 N/m)."""
ERROR_SPEEDS = 6
"""Speeds (0 … the highest speed of interest) at which the error is measured."""
PLANES = (("x", 0, 3), ("y", 1, 2))
"""(name, translation, rotation) DOF offsets of the two bending planes: x–z carries
(x, beta), y–z carries (y, alpha)."""


class ReductionError(ValueError):
    """The shaft cannot be reduced as asked (one line naming the field and the range)."""


@dataclass(frozen=True)
class Reduced:
    """A reduced rotor: full DOFs ``u = transform @ q`` (``4 n_nodes`` × ``n``), the diagonal
    mass (kg; a coordinate's generalised mass) and the projected stiffness (N/m), damping
    (N·s/m) and gyroscopic matrix (per rad/s) over the coordinates ``names`` (m)."""

    transform: np.ndarray
    mass: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    gyroscopic: np.ndarray
    names: tuple[str, ...]
    method: str
    modes: int
    node: int
    interface: tuple[int, ...]
    """The ball-bearing nodes (Craig–Bampton's interface)."""
    full_dofs: int

    def node_rows(self, node: int) -> tuple[np.ndarray, np.ndarray]:
        """(∂x/∂q, ∂y/∂q) of node ``node``'s translation."""
        return self.transform[4 * node], self.transform[4 * node + 1]

    def kept(self) -> str:
        """What was kept, in words."""
        per_plane = len(self.names) // 2
        where = ", ".join(str(n) for n in self.interface)
        if self.method == "craig_bampton":
            what = (f"Craig–Bampton: the translations of the ball-bearing node"
                    f"{'s' if len(self.interface) > 1 else ''} {where} (interface) and "
                    f"{self.modes} fixed-interface mode{'s' if self.modes != 1 else ''} per "
                    "bending plane")
        elif self.method == "modal":
            what = f"modal truncation: the {self.modes} lowest modes per bending plane"
        else:
            what = "no reduction: every DOF"
        return (f"{what}; {per_plane} coordinates per plane, {len(self.names)} in all "
                f"(of {self.full_dofs} DOFs), {2 * len(self.names)} states; x and y are node "
                f"{self.node}'s displacements, x_q<j> and y_q<j> generalised coordinates (m: "
                "the largest nodal translation of their shape)")


def quantized(matrix: np.ndarray) -> np.ndarray:
    """``matrix`` rounded to ``INPUT_DIGITS`` significant digits (entries below 1e-13 of
    its largest one set to 0)."""
    scale = float(np.max(np.abs(matrix))) if matrix.size else 0.0
    out = np.zeros_like(matrix, dtype=float)
    for index, value in np.ndenumerate(matrix):
        if abs(value) > 1e-13 * scale:
            out[index] = float(f"{float(value):.{INPUT_DIGITS}g}")
    return out


def _mp(matrix):
    import mpmath

    return mpmath.matrix([[mpmath.mpf(float(v)) for v in row] for row in matrix])


def _generalized_modes(k, m):
    """(eigenvalues ascending, mass-orthonormal eigenvectors as columns) of k φ = λ m φ, in
    mpmath (k symmetric, m symmetric positive definite); each vector's largest component
    positive."""
    import mpmath

    n = m.rows
    if n == 0:
        return [], mpmath.matrix(0, 0)
    low = mpmath.cholesky(m)
    inv = mpmath.inverse(low)
    a = inv * k * inv.T
    a = (a + a.T) / 2
    values, vectors = mpmath.eigsy(a)
    order = sorted(range(n), key=lambda i: values[i])
    phi = inv.T * vectors
    out = mpmath.matrix(n, n)
    for col, i in enumerate(order):
        column = [phi[r, i] for r in range(n)]
        big = max(range(n), key=lambda r: (abs(column[r]), -r))
        sign = 1 if column[big] >= 0 else -1
        for r in range(n):
            out[r, col] = sign * column[r]
    return [values[i] for i in order], out


def _plane_basis(mass: np.ndarray, stiffness: np.ndarray, plane: tuple[int, int],
                 n_nodes: int, interface: tuple[int, ...], method: str, modes: int, node: int):
    """The reduced basis of one bending plane (plane DOFs × coordinates, mpmath) and the
    generalised mass of each coordinate."""
    import mpmath

    _, t_off, r_off = plane
    dofs = [4 * n + o for n in range(n_nodes) for o in (t_off, r_off)]
    local = {d: i for i, d in enumerate(dofs)}
    m = _mp(mass[np.ix_(dofs, dofs)])
    k = _mp(stiffness[np.ix_(dofs, dofs)])
    n_p = len(dofs)
    if method == "none":
        basis = mpmath.eye(n_p)
    elif method == "modal":
        _, phi = _generalized_modes(k, m)
        basis = phi[:, :modes] if modes else mpmath.matrix(n_p, 0)
    else:
        bnd = [local[4 * n + t_off] for n in interface]
        inner = [i for i in range(n_p) if i not in bnd]
        k_ii = _sub(k, inner, inner)
        k_ib = _sub(k, inner, bnd)
        psi = mpmath.matrix(len(inner), len(bnd))
        for col in range(len(bnd)):
            solved = mpmath.lu_solve(k_ii, k_ib[:, col])
            for r in range(len(inner)):
                psi[r, col] = -solved[r]
        _, phi = _generalized_modes(k_ii, _sub(m, inner, inner))
        basis = mpmath.matrix(n_p, len(bnd) + modes)
        for col, b in enumerate(bnd):
            basis[b, col] = 1
            for r, i in enumerate(inner):
                basis[i, col] = psi[r, col]
        for col in range(modes):
            for r, i in enumerate(inner):
                basis[i, len(bnd) + col] = phi[r, col]
    # mass-orthonormal modes of the kept space
    m_r = basis.T * m * basis
    k_r = basis.T * k * basis
    _, v = _generalized_modes((k_r + k_r.T) / 2, (m_r + m_r.T) / 2)
    phi = basis * v
    # Householder reflections (a QR factorisation of the interface rows): the first
    # coordinate is the chosen node's displacement, and the k-th interface node's
    # displacement depends on the first k + 1 coordinates only (its balls' loads reach
    # k + 1 coordinates, not all)
    n_r = phi.cols
    row = local[4 * node + t_off]
    others = [local[4 * n + t_off] for n in interface if 4 * n + t_off != 4 * node + t_off]
    for step, target in enumerate([row, *others][:n_r]):
        phi = _reflect(phi, target, step)
        if step == 0 and phi[row, 0] == 0:
            raise ReductionError(f"reduction.node: node {node} does not move in the kept "
                                 "space; choose another node")
    translations = [local[4 * n + t_off] for n in range(n_nodes)]
    scales = []
    for j in range(n_r):
        if j == 0:
            s = phi[row, 0]
        else:
            big = max(translations, key=lambda r: (abs(phi[r, j]), -r))
            s = phi[big, j]
        if s == 0:
            raise ReductionError("reduction: a kept coordinate does not move any node; keep "
                                 "fewer modes")
        scales.append(s)
        for r in range(n_p):
            phi[r, j] /= s
    masses = [1 / (s * s) for s in scales]
    for j in range(n_r):  # round-off of the 30-digit arithmetic is not a coupling
        for r in range(n_p):
            if abs(phi[r, j]) < SNAP:
                phi[r, j] = 0
    return dofs, phi, masses


def _reflect(phi, row: int, step: int):
    """``phi`` times the Householder reflection of coordinates ``step`` … that makes
    ``phi[row, step + 1:]`` zero (set exactly 0) and ``phi[row, step]`` non-negative."""
    import mpmath

    n_r = phi.cols
    a = [phi[row, j] for j in range(step, n_r)]
    norm = mpmath.sqrt(mpmath.fsum(x * x for x in a))
    if norm == 0:
        return phi
    u = [-x / norm for x in a]
    u[0] += 1
    uu = mpmath.fsum(x * x for x in u)
    if uu > mpmath.mpf(10) ** (-DIGITS + 5):
        h = mpmath.eye(n_r)
        for i in range(len(u)):
            for j in range(len(u)):
                h[step + i, step + j] -= 2 * u[i] * u[j] / uu
        phi = phi * h
    for j in range(step + 1, n_r):  # exactly 0 (not 1e-32) where the reflection made it so
        phi[row, j] = 0
    return phi


def _sub(a, rows, cols):
    import mpmath

    out = mpmath.matrix(len(rows), len(cols))
    for i, r in enumerate(rows):
        for j, c in enumerate(cols):
            out[i, j] = a[r, c]
    return out


def _project(transform: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``transform.T @ matrix @ transform`` with correctly rounded sums (``math.fsum``): the
    same bits on every machine."""
    n_full, n = transform.shape
    nz = [[(j, float(matrix[i, j])) for j in range(n_full) if matrix[i, j] != 0]
          for i in range(n_full)]
    cols = [[float(transform[r, c]) for r in range(n_full)] for c in range(n)]
    right = [[math.fsum(v * cols[c][j] for j, v in nz[i]) for c in range(n)]
             for i in range(n_full)]
    out = np.zeros((n, n))
    for a in range(n):
        ca = cols[a]
        for b in range(n):
            out[a, b] = math.fsum(ca[i] * right[i][b] for i in range(n_full) if ca[i])
    return out


def reduce_rotor(mass: np.ndarray, stiffness: np.ndarray, damping: np.ndarray,
                 gyroscopic: np.ndarray, interface: tuple[int, ...], method: Method,
                 modes: int, node: int) -> Reduced:
    """Reduce the rotor with matrices ``mass`` (kg), ``stiffness`` (N/m, the linear bearings
    included), ``damping`` (N·s/m) and ``gyroscopic`` (per rad/s), over ``4 n_nodes``
    DOFs in ROSS's order, keeping ``interface`` (ball-bearing nodes) physical; ``node``: the
    node whose x, y become the first coordinates. ``ReductionError`` when the shaft with its
    interface held can still move freely, or more modes are asked for than there are."""
    import mpmath

    n_full = mass.shape[0]
    n_nodes = n_full // 4
    interface = tuple(sorted(set(interface)))
    m_q, k_q, c_q, g_q = (quantized(a) for a in (mass, stiffness, damping, gyroscopic))
    per_plane = 2 * n_nodes - (len(interface) if method == "craig_bampton" else 0)
    if method != "none" and modes > per_plane:
        raise ReductionError(f"reduction.modes: must be in [0, {per_plane}] (the DOFs of a "
                             f"bending plane{' besides its interface' if interface else ''}), "
                             f"got {modes}")
    if method == "modal" and modes < 1:
        raise ReductionError("reduction.modes: modal truncation keeps at least 1 mode, got 0")
    with mpmath.workdps(DIGITS):
        if method == "craig_bampton":
            held = held_stiffness_problem(k_q, interface)
            if held is not None:
                raise ReductionError(held)
        bases = [_plane_basis(m_q, k_q, plane, n_nodes, interface, method, modes, node)
                 for plane in PLANES]
        n_r = bases[0][1].cols
        if bases[1][1].cols != n_r:
            raise ReductionError("reduction: the two bending planes keep different numbers "
                                 "of coordinates")
        transform = np.zeros((n_full, 2 * n_r))
        masses = np.zeros(2 * n_r)
        for p, (dofs, phi, plane_masses) in enumerate(bases):
            for j in range(n_r):
                masses[2 * j + p] = float(plane_masses[j])
                for r, d in enumerate(dofs):
                    transform[d, 2 * j + p] = float(phi[r, j])
    from modelgen.spec import shaft_coordinates

    names = shaft_coordinates(n_r)
    return Reduced(transform=transform, mass=masses, stiffness=_project(transform, k_q),
                   damping=_project(transform, c_q), gyroscopic=_project(transform, g_q),
                   names=names, method=method, modes=modes, node=node, interface=interface,
                   full_dofs=n_full)


def held_stiffness_problem(stiffness: np.ndarray, interface: tuple[int, ...]) -> str | None:
    """Why the shaft with its interface held can still move freely (None when it cannot)."""
    n_full = stiffness.shape[0]
    held = {4 * n + o for n in interface for o in (0, 1)}
    free = [i for i in range(n_full) if i not in held]
    k = stiffness[np.ix_(free, free)]
    eig = np.linalg.eigvalsh((k + k.T) / 2)
    if eig.size and eig[0] <= 1e-9 * max(abs(eig[-1]), 1.0):
        nodes = ", ".join(str(n) for n in interface) or "none"
        return ("shaft: the shaft moves freely with its ball-bearing nodes held (nodes "
                f"{nodes}): give it at least two ball bearings at different nodes, or linear "
                "bearings ([[shaft.bearings]])")
    return None


OSCILLATING = 0.5
"""Largest damping ratio -Re λ/|λ| of a mode whose frequency is compared (heavily damped
modes, such as the stiffest ones under stiffness-proportional damping, are left out)."""


def damped_frequencies(mass: np.ndarray, damping: np.ndarray, stiffness: np.ndarray
                       ) -> np.ndarray:
    """Damped natural frequencies (Hz, ascending) of M q'' + C q' + K q = 0: the positive
    imaginary parts of the eigenvalues over 2π, of the modes with damping ratio at most
    ``OSCILLATING``."""
    n = mass.shape[0]
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiffness, -minv @ damping]])
    lam = np.linalg.eigvals(a)
    keep = (lam.imag > 0) & (-lam.real <= OSCILLATING * np.abs(lam))
    return np.sort(lam.imag[keep] / (2 * math.pi))


def _spring_matrix(n_full: int, nodes: tuple[int, ...], k: float) -> np.ndarray:
    out = np.zeros((n_full, n_full))
    for n in nodes:
        out[4 * n, 4 * n] += k
        out[4 * n + 1, 4 * n + 1] += k
    return out


def frequency_differences(full: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                          reduced: Reduced, speed_rpm: float, bearing_stiffness: float,
                          limit_hz: float) -> tuple[float, int]:
    """(largest relative difference, modes compared) of the damped natural frequencies of
    the reduced and the full rotor at a speed (rpm) with the ball bearings as springs of
    ``bearing_stiffness`` (N/m), over the full model's modes below ``limit_hz`` (inf when
    the reduced model has fewer modes there)."""
    m, k, c, g = full
    omega = speed_rpm * math.pi / 30
    spring = _spring_matrix(m.shape[0], reduced.interface, bearing_stiffness)
    t = reduced.transform
    with _one_blas_thread():
        f_full = damped_frequencies(m, c + omega * g, k + spring)
        f_red = damped_frequencies(np.diag(reduced.mass),
                                   reduced.damping + omega * reduced.gyroscopic,
                                   reduced.stiffness + t.T @ spring @ t)
    wanted = f_full[f_full <= limit_hz]
    if wanted.size == 0:
        return 0.0, 0
    if f_red.size < wanted.size:
        return math.inf, int(wanted.size)
    return float(np.max(np.abs(f_red[:wanted.size] - wanted) / wanted)), int(wanted.size)


def reduction_error(full: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                    reduced: Reduced, max_speed_rpm: float) -> tuple[float, int, float]:
    """(the reduction's error, the number of modes it covers at the stiffest bearings, the
    frequency limit in Hz): the largest relative difference of the damped natural
    frequencies below twice the highest speed (``max_speed_rpm``/30 Hz) between the reduced
    and the full rotor, over ``ERROR_SPEEDS`` speeds from 0 to ``max_speed_rpm`` and the
    bearing stiffnesses ``ERROR_STIFFNESSES``."""
    limit = 2 * max_speed_rpm / 60
    worst, covered = 0.0, 0
    for speed in np.linspace(0.0, max_speed_rpm, ERROR_SPEEDS):
        for kb in ERROR_STIFFNESSES:
            err, count = frequency_differences(full, reduced, float(speed), kb, limit)
            worst, covered = max(worst, err), max(covered, count)
    return worst, covered, limit


def _one_blas_thread():
    """One BLAS thread for the small eigenproblems (several threads spin against other
    processes on a loaded machine: ten times slower on 2 shared cores)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl comes with scipy's stack
        from contextlib import nullcontext

        return nullcontext()
    return threadpool_limits(1, user_api="blas")


def stated(error: float) -> str:
    """The error as stated: rounded up to two significant digits ('< 1e-12' below that)."""
    if not math.isfinite(error):
        return "inf"
    if error < 1e-12:
        return "< 1e-12"
    exponent = math.floor(math.log10(error)) - 1
    return f"{math.ceil(error / 10**exponent * (1 - 1e-9)) * 10**exponent:.1e}"
