"""Assembly of a finite-element rotor: the global M, K, G (and the elements' structural C)
over ``4 * node_count`` DOFs, and the linear bearings' K and C at a speed.

Global DOF ``4 * node + k``, k = 0..3 for ``x, y, alpha, beta`` (ROSS's lateral order). The
equations of motion at speed Omega (rad/s) are

    M q'' + (C + C_b(Omega) + Omega G) q' + (K + K_b(Omega)) q = f(t).

>>> from modelgen.fe.schema import Shaft
>>> shaft = Shaft.model_validate({
...     "materials": [{"name": "steel", "E": 211e9, "nu": 0.3, "rho": 7810.0}],
...     "elements": [{"L": 0.5, "odl": 0.05, "material": "steel"}] * 2,
...     "bearings": [{"node": 0, "kxx": 1e7}, {"node": 2, "kxx": 1e7}]})
>>> rotor = assemble(shaft)
>>> rotor.M.shape, rotor.dof_names[:5]
((12, 12), ('x0', 'y0', 'alpha0', 'beta0', 'x1'))
>>> float(rotor.bearing_matrices(100.0)[0][8, 8])
10000000.0
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from modelgen.fe.elements import disk_matrices, shaft_element_matrices
from modelgen.fe.schema import LinearBearing, Shaft, Unbalance

__all__ = ["DOF_NAMES", "RotorMatrices", "assemble", "dof", "unbalance_force_amplitudes"]

DOF_NAMES = ("x", "y", "alpha", "beta")
"""The four lateral DOFs of a node (m, m, rad, rad)."""
RPM = 30.0 / np.pi
"""rpm per rad/s."""


def dof(node: int, which: str | int) -> int:
    """Global index of a node's DOF (``"x"``, ``"y"``, ``"alpha"``, ``"beta"`` or 0..3)."""
    k = DOF_NAMES.index(which) if isinstance(which, str) else int(which)
    return 4 * node + k


@dataclass(frozen=True)
class RotorMatrices:
    """The assembled rotor: M (kg), K (N/m), G (per rad/s of speed), C (the elements'
    proportional damping, N·s/m), and the linear bearings, placed by ``bearing_matrices``."""

    M: np.ndarray
    K: np.ndarray
    G: np.ndarray
    dof_names: tuple[str, ...]
    n_nodes: int
    node_positions: tuple[float, ...]
    bearings: tuple[LinearBearing, ...] = ()
    C: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.C is None:
            object.__setattr__(self, "C", np.zeros_like(self.M))

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    def bearing_matrices(self, speed_rad_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(K_b, C_b) of the linear bearings at a speed, rad/s (coefficients tabulated over
        rpm are interpolated at ``speed_rad_s * 30 / pi``)."""
        kb, cb = np.zeros_like(self.M), np.zeros_like(self.M)
        for bearing in self.bearings:
            k, c = bearing.matrices(speed_rad_s * RPM)
            i = dof(bearing.node, "x")
            kb[i:i + 2, i:i + 2] += np.asarray(k)
            cb[i:i + 2, i:i + 2] += np.asarray(c)
        return kb, cb

    def matrices_at(self, speed_rad_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(M, C + C_b + Omega G, K + K_b) at a speed, rad/s."""
        kb, cb = self.bearing_matrices(speed_rad_s)
        return self.M, self.C + cb + speed_rad_s * self.G, self.K + kb


def assemble(shaft: Shaft) -> RotorMatrices:
    """The global matrices of a validated shaft (elements, disks; bearings kept aside)."""
    n = shaft.node_count
    size = 4 * n
    mass, stiff, gyro, damp = (np.zeros((size, size)) for _ in range(4))
    for element, left in zip(shaft.elements, shaft.left_nodes(), strict=True):
        mat = shaft.material(element.material)
        m, k, g = shaft_element_matrices(
            element.L, element.odl, element.idl, mat.E, mat.shear_modulus, mat.rho,
            shear_effects=element.shear_effects, rotary_inertia=element.rotary_inertia,
            gyroscopic=element.gyroscopic, shear_method=element.shear_method)
        block = slice(4 * left, 4 * left + 8)
        mass[block, block] += m
        stiff[block, block] += k
        gyro[block, block] += g
        damp[block, block] += element.alpha * m + element.beta * k
    for disk in shaft.disks:
        m, g = disk_matrices(disk.m, disk.Id, disk.Ip)
        block = slice(4 * disk.node, 4 * disk.node + 4)
        mass[block, block] += m
        gyro[block, block] += g
    names = tuple(f"{d}{i}" for i in range(n) for d in DOF_NAMES)
    return RotorMatrices(M=mass, K=stiff, G=gyro, C=damp, dof_names=names, n_nodes=n,
                         node_positions=tuple(shaft.node_positions()),
                         bearings=tuple(shaft.bearings))


def unbalance_force_amplitudes(n_dof: int, unbalances: Iterable[Unbalance],
                               speed_rad_s: float) -> np.ndarray:
    """Complex amplitudes F of the unbalance forces, f(t) = Re(F e^{i Omega t}): at each
    unbalance's node F_x = m e Omega² e^{i phase}, F_y = -i F_x (a force turning with the
    shaft), N, as ROSS's ``_unbalance_force``."""
    force = np.zeros(n_dof, dtype=complex)
    for u in unbalances:
        fx = u.magnitude * speed_rad_s**2 * np.exp(1j * u.phase)
        force[dof(u.node, "x")] += fx
        force[dof(u.node, "y")] += -1j * fx
    return force
