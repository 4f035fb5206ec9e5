"""A spec's finite-element rotor, ready for the linear analyses: its ``[shaft]`` read and
assembled, with the provenance its results and figures carry.

The shaft's linear bearings (``[[shaft.bearings]]``) support it; its ball bearings
(``[[bearings]]`` with ``inner = "shaft"``) enter as their linearised coefficients at the
static equilibrium (``analysis.linear.ball_bearings``), and bring their VC lines.
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from analysis.errors import InputError
from modelgen.fe.assembly import RotorMatrices, assemble
from modelgen.fe.schema import Shaft, Unbalance, load_shaft

__all__ = ["LinearRotor", "load_rotor", "parse_unbalance"]


@dataclass(frozen=True)
class LinearRotor:
    """A rotor's name, spec file, shaft and assembled matrices; ``lines``: the excitation
    lines of its Campbell diagram (name: order of the shaft speed)."""

    name: str
    path: Path
    shaft: Shaft
    matrices: RotorMatrices
    lines: dict[str, float] = field(default_factory=lambda: {"1X": 1.0})

    def source(self) -> dict[str, str]:
        """The provenance a result or figure of this rotor carries."""
        from analysis.provenance import package_version
        from modelgen.spec import spec_hash

        return {"model": self.name, "spec_file": str(self.path),
                "spec_sha256": spec_hash(self.path), "bearingdyn_version": package_version()}


def load_rotor(model: str | Path, speeds_rpm: Sequence[float] = (0.0,)) -> LinearRotor:
    """The rotor of a spec (a path, or a shipped or user spec's name) with a ``[shaft]``;
    its ball bearings linearised at the static equilibrium over ``speeds_rpm``."""
    from analysis.linear.ball_bearings import (
        linearised_bearings,
        shaft_ball_bearings,
        static_loads,
    )

    shaft, path = load_shaft(model)
    data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    name = str((data.get("model") or {}).get("name") or path.stem)
    balls = shaft_ball_bearings(data)
    lines = {"1X": 1.0}
    if balls:
        matrices = assemble(shaft)
        linear = linearised_bearings(matrices, balls, static_loads(data, shaft.node_count),
                                     speeds_rpm)
        shaft = shaft.model_copy(update={"bearings": [*shaft.bearings, *linear]})
        orders = {b.name: b.vc_order() for b in balls}
        if len(set(orders.values())) == 1:
            lines["VC"] = next(iter(orders.values()))
        else:
            lines.update({f"VC[{n}]": order for n, order in orders.items()})
    if not shaft.bearings:
        raise InputError("model: the shaft has no bearings; a free rotor has no critical "
                         "speeds or steady unbalance response")
    return LinearRotor(name, path, shaft, assemble(shaft), lines)


def parse_unbalance(text: str, node_count: int) -> Unbalance:
    """``NODE:KG_M[:PHASE_DEG]`` (``--unbalance``) as an ``Unbalance``; ``InputError``
    naming ``unbalances`` (the python name of ``unbalance``'s option) otherwise."""
    import math

    parts = str(text).split(":")
    try:
        if len(parts) not in (2, 3):
            raise ValueError
        node, magnitude = int(parts[0]), float(parts[1])
        phase = math.radians(float(parts[2])) if len(parts) == 3 else 0.0
    except ValueError:
        raise InputError(f"unbalances: expected NODE:KG_M[:PHASE_DEG] (e.g. 6:1e-4:90), got "
                         f"{text!r}", field="unbalances") from None
    if not 0 <= node < node_count:
        raise InputError(f"unbalances: no node {node}; the shaft's nodes are 0 to "
                         f"{node_count - 1}", field="unbalances")
    if not (math.isfinite(magnitude) and 0 < magnitude <= 1e3) or not math.isfinite(phase):
        raise InputError(f"unbalances: the unbalance must be in (0, 1000] kg m and the phase "
                         f"finite, got {text!r}", field="unbalances")
    return Unbalance(node=node, magnitude=magnitude, phase=math.remainder(phase, 2 * math.pi))
