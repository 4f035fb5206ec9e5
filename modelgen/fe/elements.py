"""Element matrices of a finite-element rotor, derived symbolically in SymPy.

The Timoshenko beam element is derived here, not copied: the static solution of the
Timoshenko equations (a cubic deflection ``w`` and the section rotation
``psi = w' + (phi L^2 / 2) a3``, exact for a uniform element) gives the shape functions of
the four nodal values ``(w0, psi0, w1, psi1)``; then

* translational mass ``rho A ∫ N^T N dz``, rotary inertia ``rho I ∫ Nψ^T Nψ dz``;
* stiffness ``E I ∫ Nψ'^T Nψ' dz + kappa G A ∫ (N' - Nψ)^T (N' - Nψ) dz`` with
  ``kappa G A = 12 E I / (phi L^2)``, ``phi = 12 E I / (kappa G A L^2)``;
* gyroscopic ``rho J ∫ (Nα^T Nβ - Nβ^T Nα) dz`` with ``J = 2 I`` (polar).

The two bending planes are mapped onto ROSS's node order ``[x, y, alpha, beta]``: the x–z
plane carries ``(x, beta)`` with ``beta = dx/dz``; the y–z plane ``(y, -alpha)``. The
equations of motion are ``M q'' + (C + Omega G) q' + K q = f`` as in ROSS (``Omega``, rad/s).
Expressions are built once per process and turned into NumPy functions with
``sympy.lambdify``.

>>> m, k, g = shaft_element_matrices(L=0.25, odl=0.05, idl=0.0, E=211e9, G_s=81.2e9,
...                                  rho=7810.0)
>>> m.shape, bool(abs(m - m.T).max() == 0), bool(abs(g + g.T).max() == 0)
((8, 8), True, True)
"""

from __future__ import annotations

import functools
import math
from typing import Literal

import numpy as np

from modelgen.lazy import sympy as sp

__all__ = ["disk_matrices", "plane_matrices", "shaft_element_matrices", "shear_coefficient"]

X_PLANE = ((0, 1.0), (3, 1.0), (4, 1.0), (7, 1.0))
"""(index in the 8 element DOFs, sign) of (w0, psi0, w1, psi1) in the x–z plane:
x0, beta0, x1, beta1."""
Y_PLANE = ((1, 1.0), (2, -1.0), (5, 1.0), (6, -1.0))
"""The same in the y–z plane: y0, -alpha0, y1, -alpha1."""


@functools.cache
def symbolic_plane_matrices():
    """(symbols (L, phi, rhoA, rhoI, EI), M_t, M_r, K, Gc) of one bending plane over
    ``(w0, psi0, w1, psi1)``: translational and rotary mass, stiffness, and the rotation
    product ``Gc = ∫ Nψ^T Nψ dz`` the gyroscopic matrix is made of (SymPy matrices)."""
    L, phi, rho_a, rho_i, ei = sp.symbols("L phi rhoA rhoI EI", positive=True)
    z = sp.Symbol("z", real=True)
    a = sp.symbols("a0:4")
    q = sp.symbols("w0 psi0 w1 psi1")
    basis_w = sp.Matrix([[1, z, z**2, z**3]])  # w = basis_w a
    basis_psi = sp.diff(basis_w, z) + sp.Matrix([[0, 0, 0, phi * L**2 / 2]])  # psi
    ends = [(basis_w, 0), (basis_psi, 0), (basis_w, L), (basis_psi, L)]
    nodal = sp.Matrix([[sum(b.subs(z, at)[j] * a[j] for j in range(4)) - qi]
                       for (b, at), qi in zip(ends, q, strict=True)])
    system, rhs = sp.linear_eq_to_matrix(list(nodal), a)
    to_a = system.LUsolve(rhs).applyfunc(sp.cancel).jacobian(sp.Matrix(q))  # a = to_a q

    def integral(left, right):
        """to_a^T (∫ left^T right dz over [0, L]) to_a, factored."""
        inner = (left.T * right).applyfunc(lambda e: sp.integrate(sp.expand(e), (z, 0, L)))
        return (to_a.T * inner * to_a).applyfunc(sp.cancel)

    gamma = sp.diff(basis_w, z) - basis_psi  # shear strain w' - psi: -(phi L^2/2) a3
    kappa_ga = 12 * ei / (phi * L**2)
    m_t = rho_a * integral(basis_w, basis_w)
    gc = integral(basis_psi, basis_psi)
    m_r = rho_i * gc
    d_psi = sp.diff(basis_psi, z)
    k = (ei * integral(d_psi, d_psi) + kappa_ga * integral(gamma, gamma)).applyfunc(sp.cancel)
    return (L, phi, rho_a, rho_i, ei), m_t, m_r, k, gc


@functools.cache
def _plane_functions():
    symbols, m_t, m_r, k, gc = symbolic_plane_matrices()
    return tuple(sp.lambdify(symbols, expr, modules="numpy") for expr in (m_t, m_r, k, gc))


def plane_matrices(L: float, phi: float, rho_a: float, rho_i: float, ei: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(M_t, M_r, K, Gc) 4x4 of one bending plane as numbers (SI units: L m, rho_a kg/m,
    rho_i kg·m, ei N·m²)."""
    return tuple(np.array(f(L, phi, rho_a, rho_i, ei), dtype=float)
                 for f in _plane_functions())


def shear_coefficient(odl: float, idl: float, poisson: float,
                      method: Literal["cowper", "hutchinson"] = "cowper") -> float:
    """Shear coefficient kappa of a hollow circular section (Cowper 1966 or Hutchinson
    2001, the formulas ROSS uses), for inner/outer diameter ratio ``idl / odl``."""
    r2 = (idl / odl) ** 2
    r12 = (1 + r2) ** 2
    nu = poisson
    if method == "cowper":
        return 6 * r12 * (1 + nu) / (r12 * (7 + 6 * nu) + r2 * (20 + 12 * nu))
    return 6 * r12 * (1 + nu) / (r12 * (7 + 12 * nu + 4 * nu**2)
                                 + 4 * r2 * (5 + 6 * nu + 2 * nu**2))


def _spread(plane: np.ndarray, which) -> np.ndarray:
    out = np.zeros((8, 8))
    for i, (a, sa) in enumerate(which):
        for j, (b, sb) in enumerate(which):
            out[a, b] += sa * sb * plane[i, j]
    return out


def shaft_element_matrices(L: float, odl: float, idl: float, E: float, G_s: float, rho: float,
                           *, shear_effects: bool = True, rotary_inertia: bool = True,
                           gyroscopic: bool = True,
                           shear_method: Literal["cowper", "hutchinson"] = "cowper"
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, K, G) 8x8 of a uniform Timoshenko element over ``[x0, y0, alpha0, beta0, x1, y1,
    alpha1, beta1]``: kg, N/m, and kg·m²/rad (G is multiplied by the speed, rad/s). SI units:
    lengths m, moduli Pa, density kg/m³."""
    area = math.pi * (odl**2 - idl**2) / 4
    inertia = math.pi * (odl**4 - idl**4) / 64
    poisson = E / (2 * G_s) - 1
    phi = 0.0
    if shear_effects:
        kappa = shear_coefficient(odl, idl, poisson, shear_method)
        phi = 12 * E * inertia / (G_s * kappa * area * L**2)
    m_t, m_r, k, gc = plane_matrices(L, phi, rho * area, rho * inertia, E * inertia)
    m_plane = m_t + (m_r if rotary_inertia else 0.0)
    mass = _spread(m_plane, X_PLANE) + _spread(m_plane, Y_PLANE)
    stiffness = _spread(k, X_PLANE) + _spread(k, Y_PLANE)
    gyro = np.zeros((8, 8))
    if gyroscopic:
        # beta = Nψ q_x, alpha = -Nψ q_y: G = rho J ∫ (Nα^T Nβ - Nβ^T Nα) dz
        polar = rho * 2 * inertia
        for i, (a, sa) in enumerate(Y_PLANE):
            for j, (b, sb) in enumerate(X_PLANE):
                value = -sa * sb * polar * gc[i, j]
                gyro[a, b] += value
                gyro[b, a] -= value
    return mass, stiffness, gyro


def disk_matrices(m: float, Id: float, Ip: float) -> tuple[np.ndarray, np.ndarray]:
    """(M, G) 4x4 of a rigid disk over ``[x, y, alpha, beta]``: kg and kg·m²; G times the
    speed (rad/s) is its gyroscopic matrix (``G[alpha, beta] = Ip``, as ROSS)."""
    mass = np.diag([m, m, Id, Id]).astype(float)
    gyro = np.zeros((4, 4))
    gyro[2, 3], gyro[3, 2] = Ip, -Ip
    return mass, gyro
