"""The ``[shaft]`` table of a spec: a finite-element rotor (elements, materials, disks,
unbalances and linear bearings), validated with pydantic.

Nodes are numbered from 0 at the left end, as ROSS numbers them; element ``i`` joins nodes
``n`` and ``n + 1`` (``n`` defaults to the previous element's ``n + 1``, the first's to 0).
Every node has the four lateral degrees of freedom ``x, y, alpha, beta`` (m, m, rad, rad:
``alpha`` the rotation about x, ``beta`` about y), in ROSS's order and signs.

>>> shaft = Shaft.model_validate({
...     "materials": [{"name": "steel", "E": 211e9, "G_s": 81.2e9, "rho": 7810.0}],
...     "elements": [{"L": 0.25, "odl": 0.05, "material": "steel"}] * 6,
...     "disks": [{"node": 2, "m": 32.6, "Id": 0.178, "Ip": 0.330}],
...     "bearings": [{"node": 0, "kxx": 1e6}, {"node": 6, "kxx": 1e6}]})
>>> shaft.node_count
7
>>> shaft.materials[0].poisson
0.2992610837438423
"""

from __future__ import annotations

import itertools
import math
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    model_serializer,
    model_validator,
)

from modelgen.errors import SpecError

__all__ = ["Disk", "LinearBearing", "Material", "Shaft", "ShaftElement", "Unbalance",
           "load_shaft", "parse_shaft"]

NAME = r"^[A-Za-z0-9][A-Za-z0-9_ .-]{0,62}$"
"""Names of materials."""


class FeModel(BaseModel):
    """Strict, frozen, finite numbers only; a dump leaves out what is not set (valid TOML)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)

    @model_serializer(mode="wrap")
    def _omit_unset(self, handler):
        return {k: v for k, v in handler(self).items() if v is not None}


class Material(FeModel):
    """``[[shaft.materials]]``: an isotropic elastic material of shaft elements."""

    name: str = Field(pattern=NAME)
    """The name elements give as ``material``."""
    E: float = Field(gt=0, le=1e13)
    """Young's modulus, Pa."""
    G_s: float | None = Field(None, gt=0, le=1e13)
    """Shear modulus, Pa (give ``G_s`` or ``nu``)."""
    nu: float | None = Field(None, gt=-1, lt=0.5)
    """Poisson's ratio (give ``G_s`` or ``nu``)."""
    rho: float = Field(gt=0, le=1e5)
    """Density, kg/m³."""

    @model_validator(mode="after")
    def _one_of_g_nu(self) -> Material:
        if (self.G_s is None) == (self.nu is None):
            raise ValueError("give one of G_s (Pa) and nu (Poisson's ratio)")
        if self.G_s is not None and not -1 < self.E / (2 * self.G_s) - 1 < 0.5:
            raise ValueError(f"E / (2 G_s) - 1 (Poisson's ratio) must be in (-1, 0.5), got "
                             f"{self.E / (2 * self.G_s) - 1:g}")
        return self

    @property
    def shear_modulus(self) -> float:
        """G, Pa."""
        return self.G_s if self.G_s is not None else self.E / (2 * (1 + self.nu))

    @property
    def poisson(self) -> float:
        """Poisson's ratio."""
        return self.nu if self.nu is not None else self.E / (2 * self.G_s) - 1


class ShaftElement(FeModel):
    """``[[shaft.elements]]``: a uniform hollow beam element between nodes ``n`` and ``n + 1``
    (Timoshenko: shear deformation and rotary inertia; gyroscopic terms scale with speed)."""

    L: float = Field(gt=0, le=100)
    """Length, m."""
    odl: float = Field(gt=0, le=10)
    """Outer diameter, m."""
    idl: float = Field(0.0, ge=0, le=10)
    """Inner diameter, m (0: solid)."""
    material: str = Field(pattern=NAME)
    """Name of one of ``[[shaft.materials]]``."""
    n: int | None = Field(None, ge=0, le=10_000)
    """Left node (default: the previous element's ``n + 1``, the first element's 0)."""
    shear_effects: bool = True
    """Shear deformation (Timoshenko); false: Euler–Bernoulli bending."""
    rotary_inertia: bool = True
    """Rotary inertia of the cross sections."""
    gyroscopic: bool = True
    """Gyroscopic moments of the spinning cross sections."""
    shear_method: Literal["cowper", "hutchinson"] = "cowper"
    """Shear coefficient of the hollow circular section: Cowper (1966), as ROSS's default, or
    Hutchinson (2001)."""
    alpha: float = Field(0.0, ge=0, le=1e6)
    """Mass-proportional structural damping, 1/s (C = alpha M + beta K, as ROSS)."""
    beta: float = Field(0.0, ge=0, le=1.0)
    """Stiffness-proportional structural damping, s."""

    @model_validator(mode="after")
    def _hollow(self) -> ShaftElement:
        if self.idl >= self.odl:
            raise ValueError(f"idl: must be smaller than odl ({self.odl:g} m), got {self.idl:g}")
        return self


class Disk(FeModel):
    """``[[shaft.disks]]``: a rigid disk at a node."""

    node: int = Field(ge=0)
    """The node it sits at."""
    m: float = Field(gt=0, le=1e6)
    """Mass, kg."""
    Id: float = Field(ge=0, le=1e6)
    """Diametral moment of inertia, kg·m²."""
    Ip: float = Field(ge=0, le=1e6)
    """Polar moment of inertia, kg·m²."""


class Unbalance(FeModel):
    """``[[shaft.unbalances]]``: a mass unbalance at a node, turning with the shaft: the force
    m e Ω² (cos(Ωt + phase), sin(Ωt + phase)), as ROSS's ``run_unbalance_response``."""

    node: int = Field(ge=0)
    """The node it sits at."""
    magnitude: float = Field(gt=0, le=1e3)
    """Mass times eccentricity, kg·m."""
    phase: float = Field(0.0, ge=-2 * math.pi, le=2 * math.pi)
    """Angle, rad."""


COEFFICIENTS = ("kxx", "kyy", "kxy", "kyx", "cxx", "cyy", "cxy", "cyx")
"""The linear bearing's coefficients: stiffness N/m, damping N·s/m."""


class LinearBearing(FeModel):
    """``[[shaft.bearings]]``: a linear bearing (or seal) from a node to ground. Each
    coefficient is a number or, with ``speed_rpm``, a list of values over speed (interpolated
    linearly, held at the ends). The force on the shaft is
    -[[kxx, kxy], [kyx, kyy]] (x, y) - [[cxx, cxy], [cyx, cyy]] (vx, vy)."""

    node: int = Field(ge=0)
    """The node it sits at."""
    speed_rpm: list[float] | None = Field(None, min_length=2)
    """Speeds of the tabulated coefficients, rpm, increasing."""
    kxx: float | list[float]
    """Direct stiffness in x, N/m."""
    kyy: float | list[float] | None = None
    """Direct stiffness in y, N/m (default: kxx)."""
    kxy: float | list[float] = 0.0
    """Cross-coupled stiffness (x force from y), N/m."""
    kyx: float | list[float] = 0.0
    """Cross-coupled stiffness (y force from x), N/m."""
    cxx: float | list[float] = 0.0
    """Direct damping in x, N·s/m."""
    cyy: float | list[float] | None = None
    """Direct damping in y, N·s/m (default: cxx)."""
    cxy: float | list[float] = 0.0
    """Cross-coupled damping, N·s/m."""
    cyx: float | list[float] = 0.0
    """Cross-coupled damping, N·s/m."""

    @model_validator(mode="after")
    def _tables(self) -> LinearBearing:
        speeds = self.speed_rpm
        if speeds is not None and any(b <= a for a, b in itertools.pairwise(speeds)):
            raise ValueError("speed_rpm: must increase")
        for name in COEFFICIENTS:
            value = getattr(self, name)
            if isinstance(value, list):
                if speeds is None:
                    raise ValueError(f"{name}: a list needs speed_rpm (the speeds of its values)")
                if len(value) != len(speeds):
                    raise ValueError(f"{name}: must have {len(speeds)} values (one per "
                                     f"speed_rpm), got {len(value)}")
        for name in ("kxx", "kyy", "cxx", "cyy"):
            value = getattr(self, name)
            if value is not None and min(value if isinstance(value, list) else [value]) < 0:
                raise ValueError(f"{name}: must be >= 0")
        return self

    def coefficient(self, name: str, speed_rpm: float) -> float:
        """Coefficient ``name`` (one of ``COEFFICIENTS``) at a speed, rpm."""
        value = getattr(self, name)
        if value is None:
            value = getattr(self, {"kyy": "kxx", "cyy": "cxx"}[name])
        if not isinstance(value, list):
            return float(value)
        import numpy as np

        return float(np.interp(speed_rpm, self.speed_rpm, value))

    def matrices(self, speed_rpm: float) -> tuple[list[list[float]], list[list[float]]]:
        """(K, C) 2x2 over (x, y), N/m and N·s/m, at a speed, rpm."""
        c = {n: self.coefficient(n, speed_rpm) for n in COEFFICIENTS}
        return ([[c["kxx"], c["kxy"]], [c["kyx"], c["kyy"]]],
                [[c["cxx"], c["cxy"]], [c["cyx"], c["cyy"]]])


class Shaft(FeModel):
    """``[shaft]``: a finite-element rotor: beam elements left to right, the disks,
    unbalances and linear bearings at its nodes (0 at the left end)."""

    materials: list[Material] = Field(min_length=1)
    """The materials the elements name."""
    elements: list[ShaftElement] = Field(min_length=1, max_length=2000)
    """The beam elements, left to right."""
    disks: list[Disk] = []
    """Rigid disks at nodes."""
    unbalances: list[Unbalance] = []
    """Mass unbalances at nodes (the ``unbalance`` command's default forcing)."""
    bearings: list[LinearBearing] = []
    """Linear bearings from nodes to ground."""

    @model_validator(mode="after")
    def _nodes(self) -> Shaft:
        problems = []
        names = [m.name for m in self.materials]
        if len(set(names)) != len(names):
            problems.append("shaft.materials: names must differ")
        left = self.left_nodes()
        for i, (element, n) in enumerate(zip(self.elements, left, strict=True)):
            if element.material not in names:
                problems.append(f"shaft.elements[{i}].material: unknown material "
                                f"'{element.material}'; known: {', '.join(names)}")
            if element.n is not None and i and n < left[i - 1]:
                problems.append(f"shaft.elements[{i}].n: elements go left to right "
                                f"(the previous one starts at node {left[i - 1]}), got {n}")
        missing = sorted(set(range(max(left) + 1)) - set(left))
        if missing:
            problems.append(f"shaft.elements: no element starts at node {missing[0]}: the "
                            "shaft must be one piece")
        count = max(left) + 2
        for group in ("disks", "unbalances", "bearings"):
            for i, item in enumerate(getattr(self, group)):
                if item.node >= count:
                    problems.append(f"shaft.{group}[{i}].node: no node {item.node}; the "
                                    f"shaft's nodes are 0 to {count - 1}")
        if problems:
            raise ValueError("\n".join(problems))
        return self

    def left_nodes(self) -> list[int]:
        """The left node of each element."""
        nodes, nxt = [], 0
        for element in self.elements:
            n = element.n if element.n is not None else nxt
            nodes.append(n)
            nxt = n + 1
        return nodes

    @property
    def node_count(self) -> int:
        """Number of nodes (the last element's right node + 1)."""
        return max(self.left_nodes()) + 2

    def material(self, name: str) -> Material:
        return next(m for m in self.materials if m.name == name)

    def node_positions(self) -> list[float]:
        """Axial position of each node, m, from node 0."""
        pos = [0.0] * self.node_count
        for element, n in zip(self.elements, self.left_nodes(), strict=True):
            pos[n + 1] = pos[n] + element.L
        return pos


def _problem(err: dict[str, Any], where: tuple) -> list[str]:
    loc = ""
    for part in (*where, *err["loc"]):
        loc += f"[{part}]" if isinstance(part, int) else (f".{part}" if loc else str(part))
    msg = err["msg"].removeprefix("Value error, ")
    if err["type"] == "value_error":
        return [line if line.startswith("shaft") else f"{loc}: {line}"
                for line in msg.splitlines()]
    if err["type"] == "extra_forbidden":
        return [f"{loc}: unknown field"]
    if err["type"] == "missing":
        return [f"{loc}: missing required field"]
    shown = repr(err.get("input"))[:60]
    return [f"{loc}: {msg}, got {shown}"]


def parse_shaft(data: Any, source: str = "<spec>") -> Shaft:
    """Validate the ``[shaft]`` table (as read from TOML), or raise ``SpecError`` with one
    message per bad field (``shaft.elements[2].L: …``)."""
    try:
        return Shaft.model_validate(data)
    except ValidationError as exc:
        problems: list[str] = []
        for err in exc.errors():
            problems += [p for p in _problem(err, ("shaft",)) if p not in problems]
        raise SpecError(source, problems) from None


def load_shaft(name_or_path: str | Path) -> tuple[Shaft, Path]:
    """The ``[shaft]`` of a spec file (a path or a shipped or user spec's name), validated
    by itself (the rest of the spec is not read)."""
    from modelgen.spec import MAX_SPEC_BYTES, spec_path

    path = spec_path(name_or_path)
    if not path.is_file():
        raise SpecError(str(path), ["file not found"])
    if path.stat().st_size > MAX_SPEC_BYTES:
        raise SpecError(str(path), [f"a spec may have at most {MAX_SPEC_BYTES} bytes"])
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(str(path), [f"not valid TOML: {exc}"]) from None
    if "shaft" not in data:
        raise SpecError(str(path), ["shaft: the model has no [shaft] (a finite-element rotor); "
                                    "the linear analyses need one"])
    return parse_shaft(data["shaft"], str(path)), path
