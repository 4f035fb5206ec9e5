"""Ball bearings on a finite-element shaft, linearised about the static equilibrium.

A spec's ball bearing on the shaft (``[[bearings]]`` with ``inner = "shaft"`` and a
``node``) is nonlinear: Hertz contact with clearance. For the linear analyses it is replaced
by its linearised coefficients (kxx … cyy) at the static load it carries, computed by the
project's ``stiffness`` machinery (``analysis.stability.statics``: static equilibrium,
K = −∂F/∂q and C = −∂F/∂q̇ by automatic differentiation, averaged over one ball pitch of the
cage) on the shipped one-bearing model whose terms are the bearing's own (``BEARING_MODELS``),
with the bearing's parameters from the spec (``<quantity>_<bearing>`` or ``<quantity>``).

The load each bearing carries comes from the shaft's static deflection under the spec's
``radial_load`` terms (+x at their nodes): the shaft (with its linear bearings) and the
linearised ball bearings are solved for the static deflection u, a bearing carries
``K_b u`` at its node, and its coefficients are recomputed at that load (turned to its
direction) until the loads agree to ``LOAD_RTOL``; on two bearings the loads are those of
statics alone and one step settles them. The varying-compliance (VC) line of each bearing,
``n_balls × (1 − d/D)/2`` times the shaft speed (outer race fixed), is a line of the
Campbell diagram.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from analysis.errors import InputError
from modelgen.fe.assembly import RotorMatrices, dof
from modelgen.fe.schema import LinearBearing

__all__ = ["BEARING_MODELS", "ShaftBallBearing", "linearised_bearings", "shaft_ball_bearings",
           "static_loads"]

BEARING_MODELS = {
    frozenset({"hertz_contact", "viscous_damping"}): "balanced-rotor",
    frozenset({"hertz_contact", "centrifugal", "viscous_damping"}): "vakharia2015",
}
"""The shipped one-bearing model whose terms are a ball bearing's, by its set of terms."""
DYNAMIC_TERMS = frozenset({"unbalance", "harmonic_force"})
"""Terms without a static part (averaged out of the statics): left out of the loads."""
LOAD_RTOL = 1e-6
"""The bearings' static loads agree to this fraction of the total load."""
MAX_ROUNDS = 30
RAD_S_PER_RPM = math.pi / 30
TABLE_SPEEDS = 5
"""Most speeds the coefficients are computed at (spread over the range; interpolated)."""


@dataclass(frozen=True)
class ShaftBallBearing:
    """A ball bearing on the shaft: its node, balls, the one-bearing model of its terms and
    the parameter values (SI) that model takes from the spec."""

    name: str
    node: int
    n_balls: int
    model: str
    parameters: dict[str, float]

    def vc_order(self) -> float:
        """VC / shaft speed: n_balls (1 − d/D)/2, d the ball and D the pitch diameter."""
        from analysis.model import load_model

        values = {**load_model(self.model).defaults, **self.parameters}
        inner, outer = values["inner_race_diameter"], values["outer_race_diameter"]
        ball = values.get("ball_diameter", (outer - inner) / 2)
        pitch = values.get("pitch_diameter", (outer + inner) / 2)
        return self.n_balls * (1 - ball / pitch) / 2


def _value(parameters: Mapping[str, Any], name: str) -> float | None:
    entry = parameters.get(name)
    if isinstance(entry, Mapping) and "value" in entry:
        return float(entry["value"])
    return None


def shaft_ball_bearings(spec: Mapping[str, Any]) -> list[ShaftBallBearing]:
    """The ball bearings on the shaft of a spec (its TOML data), each with its model."""
    from analysis.model import load_model

    parameters = spec.get("parameters") or {}
    terms = spec.get("terms") or []
    found = []
    for entry in spec.get("bearings") or []:
        if entry.get("inner") != "shaft":
            continue
        name = str(entry.get("name"))
        kinds = frozenset(str(t.get("kind")) for t in terms if t.get("bearing") == name)
        if kinds not in BEARING_MODELS:
            known = "; ".join(" + ".join(sorted(k)) for k in BEARING_MODELS)
            raise InputError(f"bearings ({name}): terms {' + '.join(sorted(kinds)) or 'none'} "
                             f"have no linearisation here; the linear analyses take a ball "
                             f"bearing with {known}")
        model = BEARING_MODELS[kinds]
        values = {}
        for quantity in load_model(model).parameter_names:
            if quantity in ("speed_rpm", "radial_load", "rotor_mass", "unbalance_force"):
                continue
            value = _value(parameters, f"{quantity}_{name}")
            value = _value(parameters, quantity) if value is None else value
            if value is not None:
                values[quantity] = value
        found.append(ShaftBallBearing(name, int(entry["node"]), int(entry["n_balls"]), model,
                                      values))
    return found


def static_loads(spec: Mapping[str, Any], n_nodes: int) -> np.ndarray:
    """The constant forces of the spec's body terms on the shaft's nodes (N, over the
    4 × n_nodes DOFs): ``radial_load`` (+x) at ``body = "node<k>"``."""
    force = np.zeros(4 * n_nodes)
    parameters = spec.get("parameters") or {}
    for term in spec.get("terms") or []:
        kind, body = str(term.get("kind")), term.get("body")
        if body is None or kind in DYNAMIC_TERMS:
            continue
        if kind != "radial_load" or not str(body).startswith("node"):
            raise InputError(f"terms ({kind} on {body}): only radial_load on a shaft node "
                             "enters the static load of the linear analyses")
        node = int(str(body)[4:])
        value = _value(parameters, f"radial_load_{body}")
        value = _value(parameters, "radial_load") if value is None else value
        force[dof(node, "x")] += value or 0.0
    return force


def _turned(matrix: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    rotation = np.array([[c, -s], [s, c]])
    return rotation @ matrix @ rotation.T


def _coefficients(bearing: ShaftBallBearing, load: float, speed_rpm: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Cage-averaged (K, C) 2×2 of the bearing carrying ``load`` N along +x."""
    from analysis.stability.statics import coefficients

    ds = coefficients(bearing.model, bearing.n_balls, radial_load=load, speed_rpm=speed_rpm,
                      **bearing.parameters)
    return np.asarray(ds.stiffness_mean.values), np.asarray(ds.damping_mean.values)


def _carried(rotor: RotorMatrices, bearings: Sequence[ShaftBallBearing],
             stiffness: list[np.ndarray], loads: np.ndarray, speed_rpm: float) -> np.ndarray:
    """The force each ball bearing carries (2-vectors, N) in the static deflection."""
    k = rotor.K + rotor.bearing_matrices(speed_rpm * RAD_S_PER_RPM)[0]
    for b, kb in zip(bearings, stiffness, strict=True):
        i = dof(b.node, "x")
        k[i:i + 2, i:i + 2] += kb
    try:
        u = np.linalg.solve(k, loads)
    except np.linalg.LinAlgError:
        raise InputError("model: the shaft has no static equilibrium on its bearings (a "
                         "bearing without stiffness: a ball bearing that carries no load)"
                         ) from None
    return np.array([kb @ u[dof(b.node, "x"):dof(b.node, "x") + 2]
                     for b, kb in zip(bearings, stiffness, strict=True)])


def linearised_bearings(rotor: RotorMatrices, bearings: Sequence[ShaftBallBearing],
                        loads: np.ndarray, speeds_rpm: Sequence[float]) -> list[LinearBearing]:
    """Each ball bearing as a linear bearing: its coefficients at its static load,
    tabulated over up to ``TABLE_SPEEDS`` speeds spread over ``speeds_rpm``."""
    speeds = np.unique(np.asarray(speeds_rpm, dtype=float))
    table = np.linspace(speeds[0], speeds[-1], min(TABLE_SPEEDS, speeds.size))
    middle = float(table[len(table) // 2])
    total = float(np.linalg.norm(loads[0::4] + 1j * loads[1::4], ord=1))
    if total == 0:
        raise InputError("model: the ball bearings carry no static load (no radial_load on "
                         "the shaft): with clearance they have no stiffness to linearise")
    carried = np.array([[total / len(bearings), 0.0]] * len(bearings))
    for _ in range(MAX_ROUNDS):
        stiffness = [_turned(_coefficients(b, float(np.hypot(*f)), middle)[0],
                             math.atan2(f[1], f[0])) for b, f in zip(bearings, carried,
                                                                     strict=True)]
        new = _carried(rotor, bearings, stiffness, loads, middle)
        settled = np.abs(new - carried).max() <= LOAD_RTOL * total
        carried = new
        if settled:
            break
    else:
        raise InputError(f"model: the ball bearings' static loads did not settle in "
                         f"{MAX_ROUNDS} rounds")
    out = []
    for b, f in zip(bearings, carried, strict=True):
        load, angle = float(np.hypot(*f)), math.atan2(f[1], f[0])
        if load <= 1e-9 * total:
            raise InputError(f"bearings ({b.name}): carries no static load; with clearance "
                             "it has no stiffness to linearise")
        pairs = [tuple(_turned(m, angle) for m in _coefficients(b, load, s)) for s in table]
        values = {f"{letter}{a}{c}": [float(p[n][i, j]) if i != j else max(float(p[n][i, j]), 0.0)
                                      for p in pairs]  # a diagonal's round-off below 0: 0
                  for n, letter in enumerate("kc") for i, a in enumerate("xy")
                  for j, c in enumerate("xy")}
        if len(table) == 1:
            values = {key: v[0] for key, v in values.items()}
        else:
            values["speed_rpm"] = [float(s) for s in table]
        out.append(LinearBearing(node=b.node, **values))
    return out
