"""The equation-spec schema: load a TOML spec, validate it, and explain what is wrong.

A spec is data: it is read with ``tomllib`` and validated with pydantic; nothing in it is
ever executed. Every problem is reported with the field's dotted path and the allowed range.
"""

from __future__ import annotations

import builtins
import difflib
import functools
import keyword
import math
import operator
import re
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from modelgen.errors import SpecError
from modelgen.expressions import CONSTANTS, FUNCTIONS, ExpressionError
from modelgen.fe.schema import Disk, LinearBearing, Material, Shaft, ShaftElement
from modelgen.fe.schema import Unbalance as ShaftUnbalance
from modelgen.lazy import sympy as sp
from modelgen.locations import (
    MODELS_ENV,
    broken_link,
    module_name,
    shipped_spec_dir,
    spec_digest,
    user_specs,
)
from modelgen.quantities import QUANTITIES, TAKEN_NAMES, Quantity
from modelgen.symbols import STATE_NAMES, Context, make_context
from modelgen.terms import TERM_CLASSES, TERMS, Centrifugal, ExpressionTerm, HertzContact
from modelgen.terms.base import OWNER_NAME, Term
from modelgen.terms.expression import BALL_SYMBOLS, ROTOR_SYMBOLS, TIME_SYMBOLS

N_BALLS_RANGE = (3, 64)
"""Allowed number of balls (inclusive)."""
USER_NAME = re.compile(r"^[a-z][a-z0-9_]{0,31}$")
"""Names of user-declared parameters: lower case, digits, '_', at most 32 characters."""
USER_UNIT = re.compile(r"^[A-Za-z0-9^*/.()_ -]{1,32}$")
"""Units of user-declared parameters, e.g. 'N/m^3', 'm/s^2', 'N*s/m', '1'."""
RESERVED_NAMES = frozenset({*ROTOR_SYMBOLS, *BALL_SYMBOLS, *FUNCTIONS, *CONSTANTS,
                            *keyword.kwlist, *dir(builtins), *TAKEN_NAMES})
"""Names a user-declared parameter cannot take: symbols and functions of the expressions,
Python's keywords and builtins, and the names of the generated code and result files."""
RACE_GAP_TOLERANCE = 1e-9
"""Relative slack of 'ball diameter <= race gap' (paper Table 1 has D_o − D_i = 2 D_b)."""

__all__ = ["N_BALLS_RANGE", "Spec", "SpecError", "load_spec", "parse_spec", "spec_hash"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)
    """Strict: a number in quotes is text, not a number (TOML integers still count as
    numbers)."""

    @model_serializer(mode="wrap")
    def _omit_unset(self, handler):
        """Leave out what is not given, so a dump is valid TOML (no None)."""
        return {k: v for k, v in handler(self).items() if v is not None}


class ModelInfo(_Strict):
    name: str = Field(pattern=r"^[a-z0-9][a-z0-9-]{0,62}$")
    """The model's name (lower case, digits, '-'; a bearing's designation may lead:
    ``6205-outer-defect``); must equal the spec file's name without ``.toml``. The generated
    module is the name with '-' as '_' (imported by path, so a leading digit is fine)."""
    title: str = Field(min_length=1, max_length=200)
    """One line for the model card, the generated headers and ``bearingdyn models``."""
    reference: str = ""
    """Where the equations come from (paper, book, section)."""
    description: str = ""
    """Free text for the model card."""

    @field_validator("title")
    @classmethod
    def _plain_title(cls, title: str) -> str:
        """The title is copied into the generated module's docstring and the C file's
        comment: it must not be able to end either (nor hold an escape)."""
        for bad in ('"""', "*/", "\\", "\n", "\r"):
            if bad in title:
                raise ValueError(f"must be one line without {bad!r} (it is copied into "
                                 "generated code comments)")
        return title

    @property
    def module(self) -> str:
        """Python module name of the generated model (``-`` becomes ``_``; ``model_`` before
        a leading digit: ``modelgen.locations.module_name``)."""
        return module_name(self.name)


class Structure(_Strict):
    """``[structure]`` of a one-body spec: the balls of its one bearing (``bearing``)."""

    n_balls: int = Field(ge=N_BALLS_RANGE[0], le=N_BALLS_RANGE[1])
    """Default number of balls; any number in range can be built at run time."""


MOTIONS: dict[str, tuple[str, ...]] = {
    "planar": ("x", "y"), "linear": ("x",), "planar_tilt": ("x", "y", "tx", "ty"),
}
"""The coordinates of a body by its motion: displacement x, y (m) of its centre and, for
``planar_tilt``, its tilt tx = dx/dz, ty = dy/dz (rad) about the centre."""
COORDINATE_UNITS = {"x": ("m", "m/s"), "y": ("m", "m/s"), "tx": ("rad", "rad/s"),
                    "ty": ("rad", "rad/s")}
"""Units of each coordinate and of its velocity."""
GROUND = "ground"
"""The outer 'body' of a bearing whose outer race does not move."""


class Support(_Strict):
    """Isotropic linear spring and viscous damper from a body's centre to ground."""

    stiffness: str | None = None
    """Parameter name of the support stiffness, N/m."""
    damping: str | None = None
    """Parameter name of the support damping, N·s/m."""


class Body(_Strict):
    """``[[bodies]]``: a rigid body, its coordinates and its mass."""

    name: str = Field(pattern=OWNER_NAME)
    """Name of the body; with several bodies its coordinates are named ``<coordinate>_<name>``
    (``x_rotor``, ``vx_housing``)."""
    motion: Literal["planar", "linear", "planar_tilt"] = "planar"
    """``planar``: x, y; ``linear``: x only; ``planar_tilt``: x, y and tilts tx, ty."""
    mass: str | None = None
    """Parameter name of the mass, kg (default ``<name>_mass``)."""
    inertia: str | None = None
    """Parameter name of the transverse moment of inertia about the centre, kg·m²
    (``planar_tilt`` only; default ``<name>_inertia``)."""
    support: Support | None = None
    """A linear spring and damper from the body's centre to ground: ``support = { stiffness = "…",
    damping = "…" }``."""

    @property
    def mass_parameter(self) -> str:
        return self.mass or f"{self.name}_mass"

    @property
    def inertia_parameter(self) -> str:
        return self.inertia or f"{self.name}_inertia"

    @property
    def coordinates(self) -> tuple[str, ...]:
        return MOTIONS[self.motion]

    def inertias(self) -> tuple[str, ...]:
        """The parameter of the mass or inertia of each coordinate."""
        return tuple(self.inertia_parameter if c in ("tx", "ty") else self.mass_parameter
                     for c in self.coordinates)


class Bearing(_Strict):
    """``[[bearings]]``: rolling elements between an inner body and an outer body (or
    ground). Its contact and ball terms name it (``bearing = "…"``); its parameters are the
    model's, or ``<quantity>_<bearing name>`` where the spec declares one for it (e.g.
    ``radial_clearance_left``); ``station_<name>`` (m) is its axial position on a tilting
    inner body."""

    name: str = Field(pattern=OWNER_NAME)
    """Name of the bearing: terms name it (``bearing = "left"``), its parameters may be given as
    ``<quantity>_<name>``, its number of balls as ``--n-balls <name>=N``."""
    inner: str = Field(pattern=OWNER_NAME)
    """The body that carries the inner race (a ``planar`` or ``planar_tilt`` body)."""
    outer: str = Field(GROUND, pattern=OWNER_NAME)
    """The body that holds the outer race, or ``ground`` (fixed)."""
    n_balls: int = Field(ge=N_BALLS_RANGE[0], le=N_BALLS_RANGE[1])
    """Default number of rolling elements (structural: any number in range is built at run
    time without SymPy)."""
    node: int | None = Field(None, ge=0)
    """The shaft node that carries the inner race, in a spec with ``[shaft]`` (there
    ``inner = "shaft"``): the node's x, y are the inner race's centre."""


SHAFT = "shaft"
"""The inner body of a ball bearing on a finite-element shaft (``node`` says where)."""


class Reduction(_Strict):
    """``[reduction]`` of a spec with ``[shaft]``: how the finite-element rotor is reduced to
    the coordinates of its generated model (``modelgen/fe/reduction.py``)."""

    method: Literal["craig_bampton", "modal", "none"] = "craig_bampton"
    """``craig_bampton``: the ball-bearing nodes' translations kept physical plus ``modes``
    fixed-interface modes per bending plane; ``modal``: the ``modes`` lowest modes of the
    shaft on its linear bearings (a shaft without ball bearings); ``none``: every DOF."""
    modes: int = Field(4, ge=0, le=400)
    """Modes kept per bending plane (x–z and y–z): fixed-interface modes (Craig–Bampton) or
    the shaft's modes (modal); at most the DOFs of a plane besides its interface."""
    node: int | None = Field(None, ge=0)
    """The node whose displacements are the first states ``x``, ``y`` (the model's one body,
    ``node<K>``: its orbit, and what the blow-up checks watch; default: the first ball
    bearing's node, else the first disk's, else node 0)."""
    max_speed_rpm: float = Field(10000.0, gt=0, le=1e6)
    """The highest speed of interest, rpm: the reduction's error is stated over speeds up
    to it, for every mode below twice its frequency."""


class SimulationDefaults(_Strict):
    dt: float = Field(1e-5, gt=0, le=10.0)
    """RK4 step and output spacing, s."""
    duration: float = Field(1.0, gt=0, le=1e5)
    """Simulated time, s."""
    transient: float = Field(0.0, ge=0, le=1e5)
    """Initial time left out of the result, s (shorter than ``duration``)."""
    x0: float | None = None
    """Initial x, m (a model with a state ``x``; else use ``initial``)."""
    y0: float | None = None
    """Initial y, m (a model with a state ``y``; else use ``initial``)."""
    vx0: float | None = None
    """Initial vx, m/s (a model with a state ``vx``)."""
    vy0: float | None = None
    """Initial vy, m/s (a model with a state ``vy``)."""
    initial: dict[str, float] = Field(default_factory=dict)
    """Initial value of any state by name (m, m/s, rad, rad/s); the others start at 0, and
    in a model with state x, y, vx, vy, x and y start at 1e-6 m unless given."""

    def times(self) -> dict[str, float]:
        return {"dt": self.dt, "duration": self.duration, "transient": self.transient}


class Parameter(_Strict):
    value: float
    """Default value, in its unit (SI; speeds in rpm)."""
    unit: str
    """The unit: a built-in quantity's own unit (see the table of quantities), or any unit of a
    declared parameter ('N/m^3')."""
    source: str = Field(min_length=1)
    """Where the value comes from ('paper Table 1', 'assumption: …'): shown in the model card."""
    note: str = ""
    """What a declared parameter means (the model card's text for it)."""
    low: float | None = None
    """Smallest allowed value (inclusive) of a user-declared parameter."""
    high: float | None = None
    """Largest allowed value (inclusive) of a user-declared parameter."""


TermEntry = Annotated[functools.reduce(operator.or_, TERM_CLASSES), Field(discriminator="kind")]
"""One ``[[terms]]`` entry: any term class, chosen by its ``kind``."""


class Spec(_Strict):
    """A model: bodies, bearings between them, terms acting on both, and parameters.

    A spec without ``[[bodies]]`` has one planar body ``rotor`` (mass ``rotor_mass``); with
    ``[structure]`` it has one bearing ``bearing`` from the rotor to ground. That is the
    shape of the paper's model, its state is ``x, y, vx, vy``, and the shipped specs of that
    shape are written that way.
    """

    model: ModelInfo
    """What the model is called and where it comes from."""
    structure: Structure | None = None
    """The ball set of a one-body spec's one bearing (use ``[[bearings]]`` otherwise)."""
    bodies: list[Body] | None = None
    """The rigid bodies and their coordinates (left out: one planar body ``rotor`` with mass
    ``rotor_mass``)."""
    bearings: list[Bearing] | None = None
    """The ball bearings between bodies, or between a body and ``ground`` (on a
    ``[shaft]``: ``inner = "shaft"`` and the ``node`` that carries the inner race)."""
    shaft: Shaft | None = None
    """A finite-element rotor (``modelgen/fe/schema.py``): its elements, materials, disks,
    unbalances and linear bearings; ball bearings sit at its nodes, and body terms
    (``radial_load``, …) name a node as their body (``body = "node3"``; default: the node of
    the states x, y). Its model's state is the reduced coordinates (``[reduction]``)."""
    reduction: Reduction | None = None
    """How a ``[shaft]`` is reduced (default: Craig–Bampton, 4 modes per plane)."""
    simulation: SimulationDefaults = SimulationDefaults()
    """Default times and initial state of a run (``--duration``, ``--dt`` … override them)."""
    parameters: dict[str, Parameter]
    """Every runtime parameter by name: a built-in quantity (fixed unit and range), a built-in
    quantity of one bearing or body (``<quantity>_<name>``), or a parameter the spec declares
    (with ``low`` and ``high``)."""
    terms: list[TermEntry] = Field(min_length=1)  # type: ignore[valid-type]
    """The force terms, summed into the equations of motion; each attaches to a body or a
    bearing."""

    @model_validator(mode="after")
    def _check_physics(self) -> Spec:
        problems = _layout_problems(self)
        if not problems:  # the rest needs known bodies and bearings
            attached = _attachment_problems(self)
            problems = [*_parameter_problems(self), *attached, *_geometry_problems(self),
                        *_initial_problems(self)]
            if not attached:  # and these, every term on a known body or bearing
                problems += [*_structure_problems(self), *_term_problems(self),
                             *_contact_problems(self)]
                if self.shaft is None:  # a shaft is held by its bearings (_layout_problems)
                    problems += _holding_problems(self)
        if self.simulation.transient >= self.simulation.duration:
            problems.append("simulation.transient: must be shorter than simulation.duration "
                            f"({self.simulation.duration:g} s)")
        if problems:
            raise ValueError("\n".join(problems))
        return self

    def parameter_values(self) -> dict[str, float]:
        return {n: p.value for n, p in self.parameters.items()}

    def body_list(self) -> list[Body]:
        """The bodies (one planar ``rotor`` when the spec names none; on a ``[shaft]``, its
        nodes ``node0``, ``node1``, …: where body terms act)."""
        if self.shaft is not None:
            return [Body(name=f"node{k}") for k in range(self.shaft.node_count)]
        return list(self.bodies) if self.bodies is not None else [Body(name="rotor")]

    def bearing_list(self) -> list[Bearing]:
        """The bearings (``bearing`` from ``[structure]`` in a one-body spec)."""
        if self.bearings is not None:
            return list(self.bearings)
        if self.structure is not None:
            return [Bearing(name="bearing", inner="rotor", n_balls=self.structure.n_balls)]
        return []

    def reduction_options(self) -> Reduction:
        """The ``[reduction]`` of a spec with ``[shaft]`` (its defaults when not given)."""
        return self.reduction if self.reduction is not None else Reduction()

    def shaft_node(self) -> int:
        """The node whose x, y are the first states of a ``[shaft]`` model."""
        shaft, chosen = self.shaft, self.reduction_options().node
        if chosen is not None or shaft is None:
            return chosen or 0
        first = [b.node for b in self.bearing_list() if b.node is not None]
        return next(iter(first + [d.node for d in shaft.disks]), 0)

    def interface_nodes(self) -> tuple[int, ...]:
        """The shaft nodes that carry ball bearings, ascending."""
        return tuple(sorted({b.node for b in self.bearing_list() if b.node is not None}))

    def shaft_coordinates(self) -> tuple[str, ...]:
        """The reduced coordinates of a ``[shaft]`` model (m): ``x, y`` of the chosen node
        (``shaft_node``), then ``x_q<j>, y_q<j>`` (``modelgen/fe/reduction.py``)."""
        assert self.shaft is not None
        options = self.reduction_options()
        per_plane = {"none": 2 * self.shaft.node_count, "modal": options.modes,
                     "craig_bampton": len(self.interface_nodes()) + options.modes}
        return shaft_coordinates(per_plane[options.method])

    def state_names(self) -> tuple[str, ...]:
        """Positions of every body, then their velocities (``<coordinate>_<body>`` when the
        model has several bodies; a ``[shaft]``'s reduced coordinates)."""
        if self.shaft is not None:
            positions = self.shaft_coordinates()
            return (*positions, *(f"v{n}" for n in positions))
        bodies = self.body_list()
        suffix = (lambda b: "") if len(bodies) == 1 else (lambda b: f"_{b.name}")
        positions = [f"{c}{suffix(b)}" for b in bodies for c in b.coordinates]
        return (*positions, *(f"v{n}" for n in positions))

    def state_units(self) -> tuple[str, ...]:
        if self.shaft is not None:
            n = len(self.shaft_coordinates())
            return (*("m",) * n, *("m/s",) * n)
        units = [COORDINATE_UNITS[c] for b in self.body_list() for c in b.coordinates]
        return (*(u[0] for u in units), *(u[1] for u in units))

    def initial_state(self) -> tuple[float, ...]:
        """The default initial state, in the order of ``state_names``."""
        names = self.state_names()
        sim = self.simulation
        values = dict.fromkeys(names, 0.0)
        if names == STATE_NAMES:
            values.update(x=1e-6, y=1e-6)
        for name in ("x", "y", "vx", "vy"):
            if getattr(sim, f"{name}0") is not None:
                values[name] = float(getattr(sim, f"{name}0"))
        values.update(sim.initial)
        return tuple(values[n] for n in names)

    def attachment(self, term: Term) -> dict[str, str]:
        """Where ``term`` acts: {"body": name} and/or {"bearing": name}."""
        found = {}
        for owner in term.owners():
            named = getattr(term, owner)
            pool = self.body_list() if owner == "body" else self.bearing_list()
            if named is None and len(pool) == 1:
                named = pool[0].name
            elif named is None and owner == "body" and self.shaft is not None:
                named = f"node{self.shaft_node()}"  # the model's body: the node of x, y
            if named is not None:
                found[owner] = named
        return found

    def contacts(self) -> dict[str, HertzContact]:
        """The contact term of each bearing, by bearing name."""
        return {self.attachment(t)["bearing"]: t for t in self.terms
                if isinstance(t, HertzContact)}

    def contact(self) -> HertzContact | None:
        """The contact term of the first bearing, or None in a model without balls."""
        return next(iter(self.contacts().values()), None)

    @property
    def n_balls(self) -> int:
        """Default number of balls of the first bearing (0 for a model without balls)."""
        bearings = self.bearing_list()
        return bearings[0].n_balls if bearings else 0

    def owner_names(self) -> list[str]:
        return [b.name for b in (*self.body_list(), *self.bearing_list())]

    def quantity(self, name: str) -> Quantity:
        """Unit, allowed range and symbol of parameter ``name`` (built-in, a built-in one
        of a body or bearing (``<quantity>_<owner>``), or declared)."""
        if name in QUANTITIES:
            return QUANTITIES[name]
        base = _scoped_quantity(name, self.owner_names())
        if base is not None:
            q = QUANTITIES[base]
            owner = name[len(base) + 1:]
            return Quantity(name, q.unit, q.low, q.high, rf"{q.latex}^{{({owner})}}",
                            f"{q.meaning} ({owner})", q.low_inclusive)
        par = self.parameters[name]
        return Quantity(name, par.unit, par.low, par.high, sp.latex(sp.Symbol(name)),
                        par.note or "user-declared parameter")


def shaft_coordinates(per_plane: int) -> tuple[str, ...]:
    """Names of a reduced shaft's coordinates, two per kept shape (x–z and y–z plane): the
    chosen node's ``x, y`` (the model's one body, as a rigid rotor's), then ``x_q<j>, y_q<j>``
    (generalised coordinates of the body ``q<j>``)."""
    return tuple(f"{axis}_q{j}" if j else axis for j in range(per_plane) for axis in ("x", "y"))


def _scoped_quantity(name: str, owners: list[str]) -> str | None:
    """The built-in quantity of ``name = <quantity>_<owner>``, or None."""
    for owner in owners:
        base = name.removesuffix(f"_{owner}")
        if base != name and base in QUANTITIES:
            return base
    return None


def _layout_problems(spec: Spec) -> list[str]:
    """Names unique, bearings between known bodies, one way of giving the balls."""
    if spec.shaft is not None:
        return _shaft_layout_problems(spec)
    problems: list[str] = []
    if spec.reduction is not None:
        problems.append("reduction: only in a spec with [shaft] (a finite-element rotor)")
    for i, bearing in enumerate(spec.bearing_list()):
        if bearing.node is not None:
            problems.append(f"bearings[{i}].node: only in a spec with [shaft] (a bearing on a "
                            "rigid body sits at its station)")
    if spec.structure is not None and (spec.bodies is not None or spec.bearings is not None):
        problems.append("structure: only in a spec without [[bodies]] and [[bearings]]; give "
                        "each bearing its n_balls in [[bearings]]")
    if spec.bodies is not None and not spec.bodies:
        problems.append("bodies: must not be empty")
    names = spec.owner_names()
    for name in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"bodies/bearings: the name '{name}' is used {names.count(name)} "
                        "times; each body and bearing needs its own name")
    bodies = {b.name: b for b in spec.body_list()}
    for i, bearing in enumerate(spec.bearing_list()):
        for side in ("inner", "outer"):
            name = getattr(bearing, side)
            allowed = [*bodies, GROUND] if side == "outer" else list(bodies)
            if name not in allowed:
                problems.append(f"bearings[{i}].{side}: unknown body '{name}'"
                                f"{_suggest(name, allowed)}; bodies: {', '.join(allowed)}")
            elif name != GROUND and bodies[name].motion == "linear":
                problems.append(f"bearings[{i}].{side}: body '{name}' moves along x only; a "
                                "bearing needs planar bodies (motion = 'planar' or "
                                "'planar_tilt')")
        if bearing.inner == bearing.outer:
            problems.append(f"bearings[{i}].outer: must differ from the inner body")
    if GROUND in bodies:
        problems.append("bodies: 'ground' is the fixed frame; give the body another name")
    for i, body in enumerate(spec.body_list()):
        if body.inertia is not None and body.motion != "planar_tilt":
            problems.append(f"bodies[{i}].inertia: only a 'planar_tilt' body has an inertia")
    return problems


def _shaft_layout_problems(spec: Spec) -> list[str]:
    """A ``[shaft]`` spec: no rigid bodies; every bearing on a node of the shaft, to ground;
    the reduction keeps what the shaft has."""
    assert spec.shaft is not None
    problems: list[str] = []
    count = spec.shaft.node_count
    nodes = f"the shaft's nodes are 0 to {count - 1}"
    if spec.bodies is not None:
        problems.append("bodies: a spec with [shaft] has no rigid bodies (body terms name a "
                        "node: body = \"node3\")")
    if spec.structure is not None:
        problems.append("structure: a spec with [shaft] gives its ball bearings in "
                        "[[bearings]] with inner = \"shaft\" and node = …")
    names = spec.owner_names()
    for name in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"bearings: the name '{name}' is used {names.count(name)} times; "
                        "each bearing needs its own name (not a node's)")
    for i, bearing in enumerate(spec.bearing_list()):
        if bearing.inner != SHAFT:
            problems.append(f"bearings[{i}].inner: must be '{SHAFT}' in a spec with [shaft], "
                            f"got '{bearing.inner}'")
        if bearing.outer != GROUND:
            problems.append(f"bearings[{i}].outer: must be '{GROUND}' in a spec with [shaft], "
                            f"got '{bearing.outer}'")
        if bearing.node is None:
            problems.append(f"bearings[{i}].node: missing; the shaft node that carries the "
                            f"bearing ({nodes})")
        elif bearing.node >= count:
            problems.append(f"bearings[{i}].node: no node {bearing.node}; {nodes}")
    options = spec.reduction_options()
    if options.node is not None and options.node >= count:
        problems.append(f"reduction.node: no node {options.node}; {nodes}")
    interface = spec.interface_nodes()
    if options.method == "modal" and interface:
        problems.append("reduction.method: 'modal' is for a shaft on linear bearings only; "
                        "with ball bearings use 'craig_bampton' (their nodes kept physical)")
    high = 2 * count - (len(interface) if options.method == "craig_bampton" else 0)
    if options.method != "none" and options.modes > high:
        problems.append(f"reduction.modes: must be in [{int(options.method == 'modal')}, "
                        f"{high}] (the DOFs of a bending plane"
                        f"{' besides the ball-bearing nodes' if interface else ''}), got "
                        f"{options.modes}")
    elif options.method == "modal" and options.modes < 1:
        problems.append(f"reduction.modes: must be in [1, {high}] for modal truncation, got 0")
    if not problems:
        problems.extend(_shaft_held_problems(spec))
    return problems


def _shaft_held_problems(spec: Spec) -> list[str]:
    """The shaft cannot move freely with its ball-bearing nodes held (Craig–Bampton needs
    the held shaft's stiffness to be invertible): in each bending plane at least two nodes
    held, by ball bearings or by linear bearings of positive direct stiffness (a connected
    beam held at two nodes has no rigid motion left)."""
    assert spec.shaft is not None
    if spec.reduction_options().method != "craig_bampton":
        return []
    interface = set(spec.interface_nodes())
    for direct in ("kxx", "kyy"):
        held = set(interface)
        for bearing in spec.shaft.bearings:
            value = getattr(bearing, direct)
            if value is None:  # kyy defaults to kxx
                value = bearing.kxx
            if max(value if isinstance(value, list) else [value]) > 0:
                held.add(bearing.node)
        if len(held) < 2:
            nodes = ", ".join(str(n) for n in sorted(interface)) or "none"
            return [f"shaft: the shaft moves freely with its ball-bearing nodes held (nodes "
                    f"{nodes}): give it ball bearings at two different nodes, or linear "
                    "bearings ([[shaft.bearings]]) at other nodes"]
    return []


def _parameter_problems(spec: Spec) -> list[str]:
    """Built-in parameters (also those of one body or bearing, ``<quantity>_<owner>``):
    unit and range; others: a valid name, a unit and a range."""
    problems: list[str] = []
    owners = spec.owner_names()
    for name, par in spec.parameters.items():
        base = name if name in QUANTITIES else _scoped_quantity(name, owners)
        q = spec.quantity(name) if base is not None else None
        declared = par.low is not None or par.high is not None
        if q is not None and declared:
            problems.append(f"parameters.{name}: '{name}' is built in with the fixed range "
                            f"{q.range_text()}; remove low and high")
        elif q is not None:
            if par.unit != q.unit:
                problems.append(f"parameters.{name}.unit: must be '{q.unit}', got '{par.unit}'")
            if not q.contains(par.value):
                problems.append(f"parameters.{name}.value: must be in {q.range_text()}, "
                                f"got {par.value:g}")
        elif not declared:
            problems.append(f"parameters.{name}: unknown parameter{_suggest(name, QUANTITIES)}"
                            f" (known: {', '.join(QUANTITIES)}); a new parameter needs its "
                            "allowed range: low = …, high = …")
        elif name in spec.state_names():
            problems.append(f"parameters.{name}: '{name}' is a state of the model; give the "
                            "parameter another name")
        else:
            problems.extend(_user_parameter_problems(name, par))
    return problems


def _user_parameter_problems(name: str, par: Parameter) -> list[str]:
    if not USER_NAME.match(name) or name in RESERVED_NAMES or re.fullmatch(r"w\d+", name):
        why = ("is taken (a symbol, function, Python or generated-code name)"
               if USER_NAME.match(name) else "is not a valid name")
        return [f"parameters.{name}: '{name}' {why}; a new parameter's name is lower case "
                "letters, digits and '_' (at most 32, starting with a letter), not one of "
                "x, y, vx, vy, t, c, s, delta, omega, pi or a function name"]
    for bound in ("low", "high"):
        if getattr(par, bound) is None:
            return [f"parameters.{name}.{bound}: missing; a new parameter needs its allowed "
                    "range: low = …, high = …"]
    if not par.low < par.high:  # type: ignore[operator]
        return [f"parameters.{name}.low: must be smaller than high ({par.high:g}), "
                f"got {par.low:g}"]
    problems = []
    if not USER_UNIT.match(par.unit):
        problems.append(f"parameters.{name}.unit: must be a unit such as 'N/m^3' (letters, "
                        f"digits, ^ * / . ( ) _ -, at most 32 characters), got {par.unit!r}")
    if not par.low <= par.value <= par.high:  # type: ignore[operator]
        problems.append(f"parameters.{name}.value: must be in [{par.low:g}, {par.high:g}] "
                        f"{par.unit}, got {par.value:g}")
    return problems


def _attachment_problems(spec: Spec) -> list[str]:
    """Every term acts on a known body or bearing, of the kind it can act on."""
    problems: list[str] = []
    pools = {"body": [b.name for b in spec.body_list()],
             "bearing": [b.name for b in spec.bearing_list()]}
    for i, term in enumerate(spec.terms):
        for owner in ("body", "bearing"):
            named = getattr(term, owner)
            if named is not None and owner not in term.owners():
                where = " or ".join(f"a {o}" for o in term.attaches)
                hint = " (fx, fy: a body; ball: a bearing)" if term.kind == "expression" else ""
                problems.append(f"terms[{i}] ({term.kind}).{owner}: this term acts on "
                                f"{where}{hint}")
            elif named is not None and named not in pools[owner]:
                problems.append(f"terms[{i}] ({term.kind}).{owner}: unknown {owner} '{named}'"
                                f"{_suggest(named, pools[owner])}; {owner}s: "
                                f"{', '.join(pools[owner]) or 'none'}")
        if problems:
            continue
        found = spec.attachment(term)
        for owner in term.owners():
            if owner in found:
                continue
            if owner == "bearing" and not pools["bearing"]:
                problems.append(f"terms[{i}] ({term.kind}): acts on the balls and needs a "
                                "bearing ([structure] n_balls in a one-body spec, else "
                                "[[bearings]]) with a 'hertz_contact' term")
            else:
                problems.append(f"terms[{i}] ({term.kind}).{owner}: missing; name the "
                                f"{owner} it acts on, one of: {', '.join(pools[owner])}")
    return problems


def _structure_problems(spec: Spec) -> list[str]:
    """Each bearing has exactly one contact term."""
    problems: list[str] = []
    contacts = spec.contacts()
    for i, bearing in enumerate(spec.bearing_list()):
        if bearing.name not in contacts:
            where = "structure" if spec.structure is not None else f"bearings[{i}]"
            problems.append(f"{where}: bearing '{bearing.name}' has no contact term; add "
                            "[[terms]] kind = 'hertz_contact' (or 'two_contact') for it, or "
                            "remove the bearing")
    return problems


HOLDING_TERMS = ("cubic_spring", "expression")
"""Terms on a body that may hold it to ground by themselves (a spring of their own)."""


def _holding_problems(spec: Spec) -> list[str]:
    """Every body is acted on by something (else its states stay 0) and held to ground:
    by its support's stiffness, a bearing to ground or a spring term of its own, or through
    bearings by a body that is (else it drifts without bound under any constant load)."""
    bodies = [b.name for b in spec.body_list()]
    group = {name: name for name in bodies}

    def root(name: str) -> str:
        while group[name] != name:
            name = group[name]
        return name

    held, joined, acted = set(), {n: [] for n in bodies}, set()
    for body in spec.body_list():
        if body.support is not None and body.support.stiffness is not None:
            held.add(body.name)
    for bearing in spec.bearing_list():
        acted.add(bearing.inner)
        if bearing.outer == GROUND:
            held.add(bearing.inner)
        else:
            acted.add(bearing.outer)
            group[root(bearing.inner)] = root(bearing.outer)
            joined[bearing.inner].append(f"bearing '{bearing.name}' to '{bearing.outer}'")
            joined[bearing.outer].append(f"bearing '{bearing.name}' to '{bearing.inner}'")
    for term in spec.terms:
        body = spec.attachment(term).get("body")
        if body in group:
            acted.add(body)
            if term.kind in HOLDING_TERMS:
                held.add(body)
    grounded = {root(n) for n in held}
    start = dict(zip(spec.state_names(), spec.initial_state(), strict=True))
    several = len(bodies) > 1

    def moved(body: str) -> bool:
        return any(v != 0 and (not several or k.endswith(f"_{body}")) for k, v in start.items())

    problems, named = [], set()
    for i, name in enumerate(bodies):
        where = f"bodies[{i}] ('{name}')" if spec.bodies is not None else f"body '{name}'"
        if name not in acted and not moved(name):
            problems.append(f"{where}: attached to nothing (no bearing or term acts on it and "
                            "it starts at rest: its states would stay 0); join it with a "
                            "bearing, put a term on it, or remove it")
        elif root(name) not in grounded and root(name) not in named:
            named.add(root(name))
            others = [n for n in bodies if n != name and root(n) == root(name)]
            through = f" (held only by {', '.join(joined[name])})" if joined[name] else ""
            fix = "it or a body it is joined to" if others else "it"
            problems.append(f"{where}: nothing holds it to ground{through}; give {fix} "
                            "support = { stiffness = \"…\", damping = \"…\" }, a bearing with "
                            f"outer = 'ground', or a spring term ({', '.join(HOLDING_TERMS)})")
    return problems


def _term_problems(spec: Spec) -> list[str]:
    """Each built-in term at most once per body or bearing; every parameter a term uses is
    declared (for its body or bearing, or for the whole model)."""
    problems: list[str] = []
    kinds = [(t.kind, tuple(sorted(spec.attachment(t).items()))) for t in spec.terms
             if not isinstance(t, ExpressionTerm)]
    for kind, where in sorted({k for k in kinds if kinds.count(k) > 1}):
        several = len(spec.owner_names()) > 2
        owner = f" on {' '.join(f'{k} {v!r}' for k, v in where)}" if several else ""
        problems.append(f"terms: '{kind}' appears {kinds.count((kind, where))} times{owner}; "
                        "at most once")
    state = spec.state_names()
    ctx = make_context([*spec.parameters, *(n for n in QUANTITIES if n not in spec.parameters)],
                       state_names=state)
    for i, term in enumerate(spec.terms):
        if isinstance(term, ExpressionTerm):
            problems.extend(_expression_problems(i, term, spec, ctx))
    needed: dict[tuple[str, str], str] = {}
    if spec.shaft is not None:
        needed[("speed_rpm", "")] = "the shaft (gyroscopic terms, unbalances)"
    for body in spec.body_list() if spec.shaft is None else []:
        for name in dict.fromkeys(body.inertias()):
            needed.setdefault((name, ""), f"body '{body.name}'")
        for name in (body.support.stiffness, body.support.damping) if body.support else ():
            if name is not None:
                needed.setdefault((name, ""), f"the support of body '{body.name}'")
    by_expression: set[str] = set()
    for i, term in enumerate(spec.terms):
        scope = next(iter(spec.attachment(term).values()), "")
        names = (term.required_parameters(state) if isinstance(term, ExpressionTerm)
                 else term.required_parameters())
        problems.extend(_bind_problems(i, term, names))
        if isinstance(term, ExpressionTerm):
            by_expression.update(names)
            names = (*names, *([term.period] if term.period is not None else []))
        for name in names:
            needed.setdefault((term.bound_name(name), scope), f"terms[{i}] ({term.kind})")
    for (name, scope), user in needed.items():
        if name in spec.parameters or f"{name}_{scope}" in spec.parameters:
            continue
        if name in QUANTITIES:
            problems.append(f"parameters.{name}: missing; {user} needs it "
                            f"(allowed range {QUANTITIES[name].range_text()})")
        elif not user.startswith("terms") or name not in by_expression:
            # names in expressions: _expression_problems; others (waviness amplitudes) here
            problems.append(f"parameters.{name}: missing; {user} needs it (declare it with "
                            "value, unit, source, low and high)")
    return problems


def _bind_problems(i: int, term: Term, names: tuple[str, ...]) -> list[str]:
    """A term binds only quantities it reads (an expression names its parameters itself)."""
    if isinstance(term, ExpressionTerm) and term.bind:
        return [f"terms[{i}] (expression).bind: an expression names its parameters itself; "
                "remove bind"]
    return [f"terms[{i}] ({term.kind}).bind.{name}: the term reads no parameter "
            f"'{name}'{_suggest(name, names)}; it reads: {', '.join(names)}"
            for name in (term.bind or {}) if name not in names]


def _contact_problems(spec: Spec) -> list[str]:
    """One contact term per bearing; a two-contact bearing already holds the balls'
    centrifugal force."""
    problems: list[str] = []
    for bearing in spec.bearing_list():
        terms = [(i, t) for i, t in enumerate(spec.terms)
                 if spec.attachment(t).get("bearing") == bearing.name]
        contacts = sorted({t.kind for _, t in terms if isinstance(t, HertzContact)})
        if len(contacts) > 1:  # the same kind twice is reported by _term_problems
            problems.append(f"terms: {' and '.join(repr(k) for k in contacts)} both model the "
                            "ball contacts; keep one")
        if contacts == ["two_contact"]:
            problems.extend(
                f"terms[{i}] (centrifugal): 'two_contact' already holds the centrifugal force "
                "of the balls (outer load = inner load + F_c); remove this term"
                for i, t in terms if isinstance(t, Centrifugal))
        high = n_balls_range(spec, bearing)[1]
        problems.extend(
            f"terms[{i}] ({spec.terms[i].kind}).ball: must be in "
            f"[1, {min(bearing.n_balls, high)}] (a ball of bearing '{bearing.name}', "
            f"{bearing.n_balls} by default), got {ball}"
            for i, ball in _defect_balls(spec, bearing) if ball > min(bearing.n_balls, high))
    return problems


def _initial_problems(spec: Spec) -> list[str]:
    """Initial values name states of the model."""
    names = spec.state_names()
    problems = [f"simulation.{name}0: the model has no state '{name}' (state: "
                f"{', '.join(names)}); use simulation.initial"
                for name in ("x", "y", "vx", "vy")
                if getattr(spec.simulation, f"{name}0") is not None and name not in names]
    for name, value in spec.simulation.initial.items():
        if name not in names:
            problems.append(f"simulation.initial.{name}: unknown state{_suggest(name, names)}; "
                            f"state: {', '.join(names)}")
        elif not math.isfinite(value):
            problems.append(f"simulation.initial.{name}: must be a finite number, got {value}")
    return problems


def _expression_problems(i: int, term: ExpressionTerm, spec: Spec, ctx: Context) -> list[str]:
    """Undeclared names; then what only building the expression shows (1/0, sqrt(-1))."""
    problems = []
    parameters = spec.parameters
    state = spec.state_names()
    for field, names in term.names(state).items():
        unknown = sorted(names - parameters.keys() - QUANTITIES.keys())
        for name in unknown:
            symbols = (*state, *TIME_SYMBOLS, *(BALL_SYMBOLS if field == "ball" else ()))
            problems.append(f"terms[{i}] ({term.kind}).{field}: unknown name '{name}'"
                            f"{_suggest(name, [*parameters, *symbols])}; a new parameter "
                            f"needs a declaration [parameters.{name}] with value, unit, "
                            "source, low and high")
        if not unknown:
            try:
                term.parse(field, ctx)
            except ExpressionError as exc:
                problems.append(f"terms[{i}] ({term.kind}).{field}: {exc}")
    return problems


def _scoped_values(spec: Spec, owner: str) -> dict[str, float]:
    """The parameter values as the body or bearing ``owner`` sees them (m, …)."""
    values = spec.parameter_values()
    values.update({n[: -len(owner) - 1]: v for n, v in values.items()
                   if n.endswith(f"_{owner}") and n[: -len(owner) - 1] in QUANTITIES})
    return values


def fitting_balls(spec: Spec, bearing: Bearing) -> int | None:
    """How many balls of the bearing's diameter fit on its pitch circle (None without
    geometry): floor(π / asin(D_b / D_m))."""
    p = _scoped_values(spec, bearing.name)
    d_i, d_o = p.get("inner_race_diameter"), p.get("outer_race_diameter")
    d_m, d_b = p.get("pitch_diameter"), p.get("ball_diameter")
    pitch = d_m if d_m is not None else (d_i + d_o) / 2 if None not in (d_i, d_o) else None
    if d_b is None or pitch is None or not 0 < d_b < pitch:
        return None
    return math.floor(math.pi / math.asin(d_b / pitch))


def _defect_balls(spec: Spec, bearing: Bearing) -> list[tuple[int, int]]:
    """(term index, ball number) of every pit on a ball of ``bearing``."""
    return [(i, t.ball) for i, t in enumerate(spec.terms)
            if t.kind == "localized_defect" and t.race == "ball"
            and spec.attachment(t).get("bearing") == bearing.name]


def n_balls_range(spec: Spec, bearing: Bearing) -> tuple[int, int]:
    """Allowed numbers of balls of ``bearing``: [3, 64], no more than fit, and at least the
    number of a ball that carries a pit (``localized_defect`` with ``race = "ball"``)."""
    fit = fitting_balls(spec, bearing)
    high = N_BALLS_RANGE[1] if fit is None else min(N_BALLS_RANGE[1], fit)
    low = max([N_BALLS_RANGE[0], *(ball for _, ball in _defect_balls(spec, bearing))])
    return low, high


def _geometry_problems(spec: Spec) -> list[str]:
    """The races, balls and pitch circle of every bearing fit together (m)."""
    problems: list[str] = []
    for index, bearing in enumerate(spec.bearing_list()):
        problems.extend(_bearing_geometry_problems(spec, index, bearing))
    return problems


def _bearing_geometry_problems(spec: Spec, index: int, bearing: Bearing) -> list[str]:
    p = _scoped_values(spec, bearing.name)
    suffix = "" if spec.structure is not None else f"_{bearing.name}"

    def field(name: str) -> str:
        return f"parameters.{name}{suffix}" if f"{name}{suffix}" in spec.parameters \
            else f"parameters.{name}"

    d_i, d_o = p.get("inner_race_diameter"), p.get("outer_race_diameter")
    d_m, d_b = p.get("pitch_diameter"), p.get("ball_diameter")
    problems: list[str] = []
    races = d_i is not None and d_o is not None
    if races and not d_i < d_o:
        return [f"{field('inner_race_diameter')}: must be smaller than outer_race_diameter "
                f"({d_o:g} m), got {d_i:g} m"]
    if races:
        gap = (d_o - d_i) / 2
        if d_b is not None and d_b > gap * (1 + RACE_GAP_TOLERANCE):
            problems.append(f"{field('ball_diameter')}: must be at most the race gap "
                            f"(outer_race_diameter − inner_race_diameter)/2 = {gap:g} m, "
                            f"got {d_b:g} m")
        if d_m is not None and not d_i < d_m < d_o:
            problems.append(f"{field('pitch_diameter')}: must be in ({d_i:g}, {d_o:g}) m, "
                            f"between the races, got {d_m:g} m")
    pitch = d_m if d_m is not None else (d_i + d_o) / 2 if races else None
    if d_b is not None and pitch is not None and not problems:
        where = "structure" if spec.structure is not None else f"bearings[{index}]"
        if not d_b < pitch:
            problems.append(f"{field('ball_diameter')}: must be smaller than the pitch "
                            f"diameter ({pitch:g} m), got {d_b:g} m")
        elif bearing.n_balls > (fit := math.floor(math.pi / math.asin(d_b / pitch))):
            problems.append(f"{where}.n_balls: must be in [{N_BALLS_RANGE[0]}, {fit}]: "
                            f"at most {fit} balls of {d_b:g} m fit on the pitch circle "
                            f"({pitch:g} m), got {bearing.n_balls}")
    return problems


def _all_field_names() -> set[str]:
    names: set[str] = set(QUANTITIES) | {"kind", "variant", "cage"}
    for cls in (Spec, ModelInfo, Structure, SimulationDefaults, Parameter, Body, Bearing,
                Support, Reduction, Shaft, *SHAFT_SECTIONS.values(), *TERM_CLASSES):
        names |= set(cls.model_fields)
    return names


def _suggest(word: str, choices: Any) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def field_path(parts: tuple) -> str:
    """The one path style of every spec message: list items by index in brackets, a term
    followed by its kind (``terms[0] (hertz_contact).bearing``, ``bearings[1].n_balls``,
    ``parameters.damping.value``), from Pydantic's location tuple."""
    text = ""
    for i, part in enumerate(parts):
        if isinstance(part, int):
            text += f"[{part}]"
        elif _is_union_tag(parts, i):
            text += f" ({part})"
        else:
            text += f".{part}" if text else str(part)
    return text


def _format_error(err: dict[str, Any]) -> str:
    parts = err["loc"]
    loc = field_path(parts)
    kind, msg, got = err["type"], err["msg"], _shown(err.get("input"))
    if kind == "extra_forbidden":
        return f"{loc}: unknown field{_suggest(parts[-1], _all_field_names())}"
    if kind == "union_tag_invalid":
        tag = err.get("input", {}).get("kind") if isinstance(err.get("input"), dict) else None
        return (f"{loc}.kind: unknown term '{tag}'{_suggest(tag, TERMS)}; "
                f"allowed: {', '.join(TERMS)}")
    if kind == "union_tag_not_found":
        return f"{loc}.kind: missing; allowed: {', '.join(TERMS)}"
    if kind == "missing":
        return f"{loc}: missing required field"
    if kind == "value_error":
        text = msg.removeprefix("Value error, ")
        if loc.startswith("shaft"):  # the shaft's own checks name their fields
            return "\n".join(line if line.startswith(("shaft.", "shaft:")) else f"{loc}: {line}"
                             for line in text.splitlines())
        return f"{loc}: {text}" if loc else text
    within = _allowed(parts)
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        return f"{loc}: must be{within}, got {got}"
    if kind in NUMBER_ERRORS:
        return f"{loc}: must be {NUMBER_ERRORS[kind]}{within}, got {got}"
    if kind == "literal_error":
        word = err.get("input")
        choices = re.findall(r"'([^']*)'", err.get("ctx", {}).get("expected", ""))
        return (f"{loc}: must be {err.get('ctx', {}).get('expected')}, got {got}"
                f"{_suggest(word, choices) if isinstance(word, str) else ''}")
    if kind in TYPE_ERRORS:
        return f"{loc}: must be {TYPE_ERRORS[kind]}, got {got}"
    if kind == "string_pattern_mismatch" and loc == "model.name":
        return (f"{loc}: must be lower case letters, digits and '-', starting with a letter "
                f"or digit (at most 63 characters), got {got}")
    if kind in ("too_short", "string_too_short"):
        return f"{loc}: must not be empty"
    return f"{loc}: {msg}" + (f", got {got}" if "input" in err else "")


NUMBER_ERRORS = {
    "float_parsing": "a number", "float_type": "a number", "finite_number": "a finite number",
    "int_parsing": "a whole number", "int_type": "a whole number",
    "int_from_float": "a whole number",
}
"""Pydantic's number errors, as the value the field must be."""
TYPE_ERRORS = {
    "string_type": "text in quotes", "dict_type": "a table", "model_type": "a table",
    "model_attributes_type": "a table", "list_type": "a list of tables ([[…]])",
}
"""Pydantic's type errors, as the kind of TOML value the field must be."""
FIELD_UNITS = {"dt": "s", "duration": "s", "transient": "s", "x0": "m", "y0": "m",
               "vx0": "m/s", "vy0": "m/s"}
"""Units of the [simulation] fields."""


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:59] + "…"


def _allowed(loc: tuple) -> str:
    """' in [low, high] unit' of the field at ``loc``, ' (unit)' when it has no bounds."""
    if len(loc) == 3 and loc[0] == "parameters" and loc[2] == "value" and loc[1] in QUANTITIES:
        return f" in {QUANTITIES[loc[1]].range_text()}"
    section = {"simulation": SimulationDefaults, "structure": Structure,
               "bearings": Bearing, "bodies": Body, "reduction": Reduction}.get(str(loc[0]))
    if loc[0] == "shaft" and len(loc) >= 3:  # shaft.<group>[i].<field>
        section = SHAFT_SECTIONS.get(str(loc[1]))
    if len(loc) >= 4 and _is_union_tag(loc, 2):  # terms.<i>.<kind>.<field>: the term's own
        section = TERMS[loc[2]]
    info = section.model_fields.get(str(loc[-1])) if section else None
    low, high, left, right = "-inf", "inf", "(", ")"
    for rule in info.metadata if info else ():
        for attr, bracket in (("gt", "("), ("ge", "[")):
            if getattr(rule, attr, None) is not None:
                low, left = f"{getattr(rule, attr):g}", bracket
        for attr, bracket in (("lt", ")"), ("le", "]")):
            if getattr(rule, attr, None) is not None:
                high, right = f"{getattr(rule, attr):g}", bracket
    unit = FIELD_UNITS.get(str(loc[-1]), "")
    if (low, high) == ("-inf", "inf"):
        return f" ({unit})" if unit else ""
    return f" in {left}{low}, {high}{right}" + (f" {unit}" if unit else "")


SHAFT_SECTIONS = {"materials": Material, "elements": ShaftElement, "disks": Disk,
                  "unbalances": ShaftUnbalance, "bearings": LinearBearing}
"""The classes of a ``[shaft]``'s lists (``modelgen/fe/schema.py``), for the allowed ranges."""


def _is_union_tag(loc: tuple, index: int) -> bool:
    """Pydantic puts the term kind into the path of a term's errors: terms.2.<kind>.field."""
    return index == 2 and loc[0] == "terms" and loc[index] in TERMS


def parse_spec(data: dict[str, Any], source: str = "<spec>") -> Spec:
    """Validate spec data (as read from TOML) and return the spec, or raise ``SpecError``."""
    try:
        return Spec.model_validate(data)
    except ValidationError as exc:
        problems: list[str] = []
        for err in exc.errors():
            problems.extend(_format_error(err).splitlines())
        raise SpecError(source, lists_once(problems)) from None


_NAME_LIST = re.compile(r"\b(known|allowed): ([^;()]+)")


def lists_once(problems: list[str]) -> list[str]:
    """``problems`` with each list of known or allowed names written out once: a later
    problem that would repeat the same list says 'as above' instead."""
    seen: set[str] = set()

    def shorten(match: re.Match) -> str:
        names = match.group(2).strip()
        if names in seen:
            return f"{match.group(1)}: as above"
        seen.add(names)
        return match.group(0)

    return [_NAME_LIST.sub(shorten, problem) for problem in problems]


def spec_path(name_or_path: str | Path) -> Path:
    """The TOML file of a spec: an explicit path, a shipped name (``vakharia2015``), or the
    name of a spec in a ``BEARINGDYN_MODELS`` folder."""
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        return candidate
    path = shipped_spec_dir() / f"{name_or_path}.toml"
    if path.exists():
        return path
    users = user_specs()
    if str(name_or_path) in users:
        return users[str(name_or_path)]
    known = [*shipped_spec_names(), *users]
    raise SpecError(str(name_or_path), [f"model: no spec named '{name_or_path}'"
                                        f"{_suggest(name_or_path, known)}; "
                                        f"known specs: {', '.join(known)} (a spec of your "
                                        f"own: give its .toml path, or put its folder in "
                                        f"{MODELS_ENV})"])


def shipped_spec_names() -> list[str]:
    return sorted(p.stem for p in shipped_spec_dir().glob("*.toml"))


def spec_hash(path: Path) -> str:
    """SHA-256 of the spec file's bytes: ``sha256sum`` of the file gives the same digest."""
    return spec_digest(path)


MAX_SPEC_BYTES = 1_000_000
"""Largest spec file read (a spec is a page of TOML)."""


def load_spec(name_or_path: str | Path) -> tuple[Spec, Path]:
    """Read and validate a spec by shipped name or path; returns the spec and its file."""
    path = spec_path(name_or_path)
    if not path.exists():
        raise SpecError(str(path), [broken_link(path) or "file not found"])
    if path.is_dir() or not path.is_file():
        raise SpecError(str(path), ["not a plain file (a folder, a pipe or a device)"])
    size = path.stat().st_size
    if size > MAX_SPEC_BYTES:
        raise SpecError(str(path), [f"{size} bytes; a spec may have at most {MAX_SPEC_BYTES}"])
    try:  # a byte-order mark (some editors write one) is read as nothing
        data = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(str(path), [f"not valid TOML: {exc}"]) from None
    except RecursionError:
        raise SpecError(str(path), ["not valid TOML: arrays or tables nested too deeply"]) \
            from None
    spec = parse_spec(data, str(path))
    if spec.model.name != path.stem:
        raise SpecError(str(path), [f"model.name: must equal the file name '{path.stem}', "
                                    f"got '{spec.model.name}'"])
    return spec, path

