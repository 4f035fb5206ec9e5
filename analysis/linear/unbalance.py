"""The 1X (synchronous) unbalance response of a rotor at a node.

At speed Omega (rad/s) the unbalances give f(t) = Re(F e^{i Omega t}) (``F_x = m e Omega²
e^{i phase}``, ``F_y = -i F_x``), and the steady response is Re(X e^{i Omega t}) with

    (K + K_b - Omega² M + i Omega (C + C_b + Omega G)) X = F,

so that x(t) = |X_x| cos(Omega t + arg X_x) at the node: ``amplitude_m = |X_x|`` and
``phase_deg = arg X_x`` in degrees, (-180, 180], as ROSS's ``run_unbalance_response``
reports its x response.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la

from analysis.errors import InputError
from analysis.linear.campbell import RAD_S, check_speeds
from analysis.threads import blas_threads
from modelgen.fe.assembly import RotorMatrices, dof, unbalance_force_amplitudes
from modelgen.fe.schema import Unbalance

__all__ = ["UnbalanceResponse", "unbalance_response"]


@dataclass(frozen=True)
class UnbalanceResponse:
    """x and y response at ``node`` over speed: complex amplitudes X (m)."""

    node: int
    speed_rpm: np.ndarray
    x: np.ndarray
    y: np.ndarray

    @property
    def amplitude_m(self) -> np.ndarray:
        return np.abs(self.x)

    @property
    def phase_deg(self) -> np.ndarray:
        return np.degrees(np.angle(self.x))

    def to_json(self) -> dict:
        """``{"speed_rpm", "amplitude_m", "phase_deg"}``."""
        return {"speed_rpm": [float(s) for s in self.speed_rpm],
                "amplitude_m": [float(a) for a in self.amplitude_m],
                "phase_deg": [float(p) for p in self.phase_deg]}


def unbalance_response(rotor: RotorMatrices, node: int, speed_rpm: Sequence[float],
                       unbalances: Sequence[Unbalance]) -> UnbalanceResponse:
    """The 1X response at ``node`` to ``unbalances`` at each speed (rpm)."""
    speeds = check_speeds(speed_rpm)
    if not 0 <= node < rotor.n_nodes:
        raise InputError(f"node: no node {node}; the shaft's nodes are 0 to "
                         f"{rotor.n_nodes - 1}", field="node")
    if not unbalances:
        raise InputError("--unbalance: the model has no [[shaft.unbalances]]; give one as "
                         "NODE:KG_M[:PHASE_DEG]")
    for u in unbalances:
        if not 0 <= u.node < rotor.n_nodes:
            raise InputError(f"unbalances: no node {u.node}; the shaft's nodes are 0 to "
                             f"{rotor.n_nodes - 1}", field="unbalances")
    xs, ys = np.zeros(speeds.size, complex), np.zeros(speeds.size, complex)
    with blas_threads():
        for j, s in enumerate(speeds):
            omega = s * RAD_S
            if omega == 0:
                continue  # no unbalance force at rest
            m, c, k = rotor.matrices_at(omega)
            force = unbalance_force_amplitudes(rotor.n_dof, unbalances, omega)
            response = la.solve(k - omega**2 * m + 1j * omega * c, force)
            xs[j], ys[j] = response[dof(node, "x")], response[dof(node, "y")]
    return UnbalanceResponse(node, speeds, xs, ys)
