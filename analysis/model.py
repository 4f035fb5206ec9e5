"""The one door from the analysis layer to generated models, and the System contract.

``load_model`` finds a model by

- the name of a shipped model (``"vakharia2015"``: the committed ``generated/`` package,
  checked against its spec: stale code is an error);
- the name of a spec in a folder of ``BEARINGDYN_MODELS``, or the path of a ``.toml`` spec
  anywhere: its code is generated on first use into the user cache (keyed by the spec's
  SHA-256 and path) and loaded from there, never from or into the package;
- a folder written by ``bearingdyn generate SPEC --out DIR`` (the folder, or the model's
  folder inside it).

A generated module meets the ``GeneratedModel`` Protocol; ``Model`` wraps it with parameter
handling, the numbers of balls per bearing and the characteristic frequencies; a ``System``
is a model with its structure (balls per bearing), parameter values and initial state: what
every analysis takes. Nothing here imports SymPy (only a user spec without cached code
imports ``modelgen`` to generate it).
"""

from __future__ import annotations

import difflib
import hashlib
import importlib
import importlib.util
import math
import pkgutil
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache, cached_property
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

import generated
from analysis.errors import InputError, StaleModelError, check_count
from modelgen.locations import (
    MANIFEST,
    MODELS_ENV,
    broken_link,
    cached_model_root,
    is_shipped,
    manifest_problem,
    manifest_text,
    module_name,
    shipped_spec_dir,
    spec_digest,
    user_spec_dirs,
    user_specs,
)

Structure = tuple[int, ...]


class Balls(tuple):
    """Balls per bearing as ``Model.structure`` returns them: checked against the ranges of
    the model named by ``checked_by`` (its name and spec SHA-256). Handed back to that
    model, they are not checked again: a run checks its balls once, where its System is
    made, however many internals ask the model for its functions or frequencies."""

    checked_by: tuple[str, str] = ("", "")

    @classmethod
    def of(cls, model: Model, counts) -> Balls:
        balls = cls(int(n) for n in counts)
        balls.checked_by = (model.name, model.spec_sha256)
        return balls
"""Number of rolling elements of each bearing, in the order of the model's bearings."""
BallCounts = int | Mapping[str, int] | Sequence[int] | None
"""What a caller may give as ``n_balls``: one number (a model with one bearing), a mapping
bearing name -> number, a sequence in bearing order, or None (the spec's defaults)."""


LEGACY_ROLES: dict[str, tuple[str, bool]] = {
    "clearance": ("radial_clearance", True), "ball_diameter": ("ball_diameter", True),
    "contact_stiffness": ("contact_stiffness", False), "radial_load": ("radial_load", False),
    "unbalance_force": ("unbalance_force", False),
    "forcing_period": ("forcing_period", False),
}
"""The roles of a generated module without ``ROLES`` (written by ``generate --out`` before
modules said which parameter plays which role): role -> (the parameter name the analysis
layer read, whether names that begin with it count too, as ``radial_clearance_left``)."""


@runtime_checkable
class GeneratedModelCore(Protocol):
    """What every generated model module provides, also one written before ``ROLES``."""

    NAME: str
    TITLE: str
    SPEC_FILE: str
    SPEC_SHA256: str
    GENERATOR: dict[str, str]
    STATE: tuple[str, ...]
    STATE_UNITS: tuple[str, ...]
    BODIES: tuple[tuple[str, str, tuple[str, ...]], ...]
    BEARINGS: tuple[tuple[str, str, str, int, tuple[int, int]], ...]
    DEFAULT_N_BALLS: tuple[int, ...]
    SIMULATION: dict[str, float]
    INITIAL_STATE: tuple[float, ...]
    PARAMETERS: tuple[tuple[str, float, str, str], ...]
    RANGES: dict[str, tuple[float, float, bool]]

    def external_force(self, z: Any, t: Any, p: Any) -> tuple[Any, ...]: ...

    def mass(self, p: Any) -> tuple[Any, ...]: ...

    def shaft_speed(self, p: Any) -> Any: ...

    def build(self, n_balls: Structure | None = None) -> Any: ...


@runtime_checkable
class GeneratedModel(GeneratedModelCore, Protocol):
    """What a generated model module provides (``generated/<model>/__init__.py``): also
    ``ROLES``, role -> the parameters that play it (``Model.role``)."""

    ROLES: dict[str, tuple[str, ...]]


@dataclass(frozen=True)
class BearingInfo:
    """A bearing of a generated model: the bodies it links and its numbers of balls."""

    name: str
    inner: str
    outer: str
    default_n_balls: int
    fewest: int
    most: int


@dataclass(frozen=True)
class FaultFrequencies:
    """The characteristic defect frequencies of one bearing (Hz), outer race stationary.

    From the model's own kinematics: the shaft frequency f_s, the cage frequency
    FTF = ω_cage/2π of the bearing's contact term, N_b and the contact angle α. For balls
    rolling without slip on both races (contact radii R_i, R_o, ball radius ρ with
    R_o − R_i = 2ρ cos α), FTF·R_o = (f_s − FTF)·R_i, so with k = R_o/R_i = f_s/FTF − 1

        BPFO = N_b·FTF,   BPFI = N_b·(f_s − FTF),   BSF = FTF·R_o/ρ = FTF·2 cos α·k/(k − 1).

    With the rolling-without-slip cage FTF = f_s/2·(1 − (d/D) cos α) these are the textbook
    formulas BPFI = N_b f_s/2·(1 + (d/D) cos α), BSF = D/(2d)·f_s·(1 − ((d/D) cos α)²)
    (R. B. Randall, J. Antoni, "Rolling element bearing diagnostics—A tutorial", MSSP 25
    (2011) 485–520, Eqs. 1–4; T. A. Harris, Rolling Bearing Analysis); with the paper's cage
    (Eq. 1, race diameters) they are the same relations for the ball of diameter
    (D_o − D_i)/2 that that cage rolls (docs/faults.md).
    """

    ftf: float
    bpfo: float
    bpfi: float
    bsf: float

    @classmethod
    def from_kinematics(cls, shaft_hz: float, cage_hz: float, n_balls: int,
                        contact_angle: float = 0.0) -> FaultFrequencies:
        """The four frequencies (Hz) from f_s, FTF (Hz), N_b and α (rad)."""
        if not cage_hz > 0 or not shaft_hz > cage_hz:
            return cls(ftf=cage_hz, bpfo=n_balls * cage_hz,
                       bpfi=n_balls * (shaft_hz - cage_hz), bsf=0.0)
        k = shaft_hz / cage_hz - 1.0
        return cls(ftf=cage_hz, bpfo=n_balls * cage_hz, bpfi=n_balls * (shaft_hz - cage_hz),
                   bsf=cage_hz * 2.0 * math.cos(contact_angle) * k / (k - 1.0))

    def as_dict(self) -> dict[str, float]:
        """``{"FTF": …, "BPFO": …, "BPFI": …, "BSF": …}`` in Hz."""
        return {"FTF": self.ftf, "BPFO": self.bpfo, "BPFI": self.bpfi, "BSF": self.bsf}


@dataclass(frozen=True)
class Frequencies:
    """Characteristic frequencies (Hz): shaft X, and per bearing its cage (FTF),
    varying compliance VC = N_b·cage and defect frequencies (FTF, BPFO, BPFI, BSF)."""

    shaft_hz: float
    cage: dict[str, float] = field(default_factory=dict)
    vc: dict[str, float] = field(default_factory=dict)
    faults: dict[str, FaultFrequencies] = field(default_factory=dict)
    forcing_parameter: str = ""
    """The parameter that holds the model's own forcing period (s; the ``forcing_period``
    role), '' without one."""
    unbalance_parameter: str = ""
    """The parameter that plays the ``unbalance_force`` role, '' without one (a shaft's
    ``unbalance_scale``, or ``unbalance_force``)."""

    @property
    def cage_hz(self) -> float:
        """Cage frequency of the first bearing (0 without bearings), Hz."""
        return next(iter(self.cage.values()), 0.0)

    @property
    def vc_hz(self) -> float:
        """VC frequency of the first bearing (0 without bearings), Hz."""
        return next(iter(self.vc.values()), 0.0)

    def as_dict(self) -> dict[str, float | str]:
        """Result-file attributes: ``cage_hz``, ``vc_hz`` with one bearing (or none), else
        ``cage_hz_<bearing>``, ``vc_hz_<bearing>`` per bearing; ``forcing_parameter`` (text)
        for a model forced at a parameter's period; ``unbalance_parameter`` (text) when a
        parameter other than ``unbalance_force`` plays that role (a shaft's
        ``unbalance_scale``: ``analysis.forcing.run_unbalance``)."""
        out: dict[str, float | str] = {"shaft_hz": self.shaft_hz}
        if len(self.vc) <= 1:
            out.update(cage_hz=self.cage_hz, vc_hz=self.vc_hz)
        else:
            for name in self.vc:
                out[f"cage_hz_{name}"] = self.cage[name]
                out[f"vc_hz_{name}"] = self.vc[name]
        for name, fault in self.faults.items():  # ftf_hz, bpfo_hz, … (…_<bearing>)
            suffix = "" if len(self.faults) == 1 else f"_{name}"
            out.update({f"{key.lower()}_hz{suffix}": value
                        for key, value in fault.as_dict().items()})
        if self.forcing_parameter:
            out["forcing_parameter"] = self.forcing_parameter
        if self.unbalance_parameter not in ("", LEGACY_ROLES["unbalance_force"][0]):
            out["unbalance_parameter"] = self.unbalance_parameter
        return out


@dataclass(eq=False)  # compared and hashed by identity: load_model caches one per model
class Model:
    """A generated model with its parameter table (defaults in SI units, speed in rpm)."""

    module: Any
    spec_path: str = ""
    """The spec file the model was loaded for, as the user gave it (or the generated
    header's when loaded by name or folder)."""
    _functions: dict[Structure, Any] = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.module.NAME

    @property
    def spec_sha256(self) -> str:
        return self.module.SPEC_SHA256

    @property
    def spec_file(self) -> str:
        """The spec's path as cited: ``modelgen/specs/NAME.toml`` for a shipped model."""
        return self.spec_path or self.module.SPEC_FILE

    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(self.module.STATE)

    @property
    def state_units(self) -> dict[str, str]:
        return dict(zip(self.module.STATE, self.module.STATE_UNITS, strict=True))

    @property
    def n_state(self) -> int:
        return len(self.module.STATE)

    @property
    def bearings(self) -> list[BearingInfo]:
        return [BearingInfo(name, inner, outer, n, lo, hi)
                for name, inner, outer, n, (lo, hi) in self.module.BEARINGS]

    @property
    def bearing_names(self) -> list[str]:
        return [b[0] for b in self.module.BEARINGS]

    @property
    def parameter_names(self) -> list[str]:
        return [row[0] for row in self.module.PARAMETERS]

    @property
    def roles(self) -> dict[str, tuple[str, ...]]:
        """Role -> the parameters that play it: the module's ``ROLES`` (written from what
        its terms read, ``modelgen.codegen.parameter_roles``). A module generated before
        ``ROLES`` existed falls back to the names the analysis layer used to assume
        (``LEGACY_ROLES``): the parameters so named that the model has."""
        written = getattr(self.module, "ROLES", None)
        names = self.parameter_names
        if written is not None:
            roles = {role: tuple(names) for role, names in written.items()}
        else:
            roles = {role: tuple(n for n in names if n == base or (prefix and n.startswith(base)))
                     for role, (base, prefix) in LEGACY_ROLES.items()}
        roles.setdefault("speed", self.speed_parameters)
        return roles

    @cached_property
    def speed_parameters(self) -> tuple[str, ...]:
        """The parameters the shaft's angular speed ``shaft_speed(p)`` reads (``speed_rpm``
        in every shipped model): the ``speed`` role, found in the model's equations as the
        other roles are found in its terms; () for a model without a turning shaft."""
        import casadi as ca

        p = ca.SX.sym("p", len(self.parameter_names))
        omega = ca.SX(self.module.shaft_speed(p))
        return tuple(name for i, name in enumerate(self.parameter_names)
                     if ca.depends_on(omega, p[i]))

    def role(self, role: str) -> tuple[str, ...]:
        """The parameters that play ``role`` (``clearance``, ``ball_diameter``,
        ``contact_stiffness``, ``radial_load``, ``unbalance_force``, ``forcing_period``,
        ``speed``), in the order of the bodies and bearings; () when none does.

        >>> load_model("vakharia2015").role("speed"), load_model("mathieu").role("speed")
        (('speed_rpm',), ())
        """
        roles = self.roles
        if role not in roles:
            raise ValueError(f"role: must be one of {', '.join(roles)}, got {role!r}")
        return roles[role]

    def role_values(self, role: str, values: Mapping[str, float]) -> tuple[float, ...]:
        """The values (SI units) in ``values`` of the parameters that play ``role``."""
        return tuple(float(values[n]) for n in self.role(role) if n in values)

    def role_value(self, role: str, values: Mapping[str, float],
                   default: float | None = None) -> float | None:
        """The value of the first parameter that plays ``role`` (the first body's or
        bearing's), else ``default``."""
        return next(iter(self.role_values(role, values)), default)

    @property
    def defaults(self) -> dict[str, float]:
        return {row[0]: float(row[1]) for row in self.module.PARAMETERS}

    @property
    def units(self) -> dict[str, str]:
        return {row[0]: row[2] for row in self.module.PARAMETERS}

    @property
    def sources(self) -> dict[str, str]:
        return {row[0]: row[3] for row in self.module.PARAMETERS}

    @property
    def default_structure(self) -> Structure:
        return Balls.of(self, self.module.DEFAULT_N_BALLS)

    @property
    def default_n_balls(self) -> int:
        """Default balls of the first bearing (0 for a model without bearings)."""
        return self.default_structure[0] if self.default_structure else 0

    @property
    def simulation_defaults(self) -> dict[str, float]:
        """Default ``dt``, ``duration`` and ``transient`` (s)."""
        return dict(self.module.SIMULATION)

    @property
    def initial_state(self) -> np.ndarray:
        """The spec's initial state, in the order of ``state_names``."""
        return np.array(self.module.INITIAL_STATE, dtype=float)

    def structure(self, n_balls: BallCounts = None) -> Structure:
        """Balls per bearing from what a caller gave (see ``BallCounts``), each checked
        against the bearing's range."""
        if type(n_balls) is Balls and n_balls.checked_by == (self.name, self.spec_sha256):
            return n_balls  # checked by this model already: once per run
        bearings = self.bearings
        if n_balls is None:
            return self.default_structure
        if not bearings:
            if isinstance(n_balls, (Mapping, Sequence)) and not n_balls:
                return ()
            raise InputError(f"n_balls: model '{self.name}' has no balls; leave n_balls out, "
                             f"got {n_balls!r}")
        if isinstance(n_balls, Mapping):
            unknown = [k for k in n_balls if k not in self.bearing_names]
            if unknown:
                raise InputError(f"n_balls: model '{self.name}' has no bearing "
                                 f"'{unknown[0]}'; bearings: {', '.join(self.bearing_names)}")
            counts = [n_balls.get(b.name, b.default_n_balls) for b in bearings]
        elif isinstance(n_balls, Sequence) and not isinstance(n_balls, str):
            if len(n_balls) != len(bearings):
                raise InputError(f"n_balls: model '{self.name}' has {len(bearings)} "
                                 f"bearing(s) ({', '.join(self.bearing_names)}), got "
                                 f"{len(n_balls)} numbers")
            counts = list(n_balls)
        elif len(bearings) > 1:
            raise InputError(f"n_balls: model '{self.name}' has bearings "
                             f"{', '.join(self.bearing_names)}; give each its number, e.g. "
                             f"--n-balls {bearings[0].name}=8 (API: n_balls={{'"
                             f"{bearings[0].name}': 8}}), got {n_balls!r}")
        else:
            counts = [n_balls]
        for b, n in zip(bearings, counts, strict=True):
            label = "n_balls" if len(bearings) == 1 else f"n_balls[{b.name}]"
            why = (f"at most {b.most} balls fit the geometry"
                   if balls_that_fit(self.defaults, b.name) is not None else
                   "the model gives no ball and pitch diameters, so whether they fit "
                   "cannot be checked")
            check_count(label, n, b.fewest, b.most, f" ({why})")
        return Balls.of(self, counts)

    def structure_attrs(self, structure: Structure) -> dict[str, int]:
        """Result-file attributes: ``n_balls`` and ``bearing_name`` with one bearing (``n_balls``
        0 without), else ``n_balls_<bearing>``."""
        if len(structure) == 1:
            return {"n_balls": structure[0], "bearing_name": self.bearing_names[0]}
        if not structure:
            return {"n_balls": 0}
        return {f"n_balls_{b}": n for b, n in zip(self.bearing_names, structure, strict=True)}

    def structure_label(self, structure: Structure) -> str:
        """``N_b = 8`` or ``N_b[left] = 8, N_b[right] = 10`` for titles and messages."""
        if len(structure) <= 1:
            return f"N_b = {structure[0]}" if structure else "no balls"
        return ", ".join(f"N_b[{b}] = {n}"
                         for b, n in zip(self.bearing_names, structure, strict=True))

    def functions(self, n_balls: BallCounts = None):
        """CasADi Functions (rhs, jac, rk4_step) for these balls (cached)."""
        s = self.structure(n_balls)
        if s not in self._functions:
            self._functions[s] = self.module.build(s)
        return self._functions[s]

    def parameters(self, overrides: dict[str, float] | None = None) -> dict[str, float]:
        """Defaults updated by ``overrides``, each checked against its allowed range."""
        values = self.defaults
        for name, value in (overrides or {}).items():
            if name not in values:
                close = difflib.get_close_matches(name, values, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                raise InputError(f"{name}: not a parameter of model '{self.name}'{hint}; "
                                 f"parameters: {', '.join(values)}")
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise InputError(f"{name}: must be a number, got {value!r}") from None
            low, high, low_inclusive = self.module.RANGES[name]
            above = number >= low if low_inclusive else number > low
            if not (math.isfinite(number) and above and number <= high):
                bracket = "[" if low_inclusive else "("
                raise InputError(f"{name}: must be in {bracket}{low:g}, {high:g}] "
                                 f"{self.units[name]}, got {value!r}")
            values[name] = number
        return values

    def parameter_vector(self, values: dict[str, float]) -> np.ndarray:
        return np.array([values[n] for n in self.parameter_names], dtype=float)

    def cage_speed(self, bearing: str, p: Any) -> Any:
        """Cage angular speed of ``bearing`` (rad/s; a CasADi expression for symbolic p)."""
        return getattr(self.module, f"cage_speed_{bearing}")(p)

    def frequencies(self, n_balls: BallCounts = None,
                    values: dict[str, float] | None = None) -> Frequencies:
        """Shaft frequency and each bearing's cage, VC and defect frequencies (FTF, BPFO,
        BPFI, BSF: :class:`FaultFrequencies`), Hz; the parameter of the model's own forcing
        period."""
        s = self.structure(n_balls)
        p = self.parameter_vector(values or self.defaults)
        shaft = float(self.module.shaft_speed(p)) / (2 * math.pi)
        cage = {b: float(self.cage_speed(b, p)) / (2 * math.pi) for b in self.bearing_names}
        vc = {b: n * cage[b] for b, n in zip(self.bearing_names, s, strict=True)}
        named = values or self.defaults
        faults = {b: FaultFrequencies.from_kinematics(
                      shaft, cage[b], n, named.get(f"contact_angle_{b}",
                                                   named.get("contact_angle", 0.0)))
                  for b, n in zip(self.bearing_names, s, strict=True)}
        return Frequencies(shaft_hz=shaft, cage=cage, vc=vc, faults=faults,
                           forcing_parameter=next(iter(self.role("forcing_period")), ""),
                           unbalance_parameter=next(iter(self.role("unbalance_force")), ""))

    def centre_indices(self) -> list[tuple[int, int | None]]:
        """State indices (x, y) of every body's centre (y None for a body moving along x)."""
        names, bodies = self.state_names, self.module.BODIES
        pairs = []
        for body, _, _ in bodies:
            suffix = "" if len(bodies) == 1 else f"_{body}"
            y = f"y{suffix}"
            pairs.append((names.index(f"x{suffix}"), names.index(y) if y in names else None))
        return pairs

    def support_resonances(self, values: Mapping[str, float] | None = None
                           ) -> tuple[float, ...]:
        """√(k/m)/2π (Hz), ascending, of each body that carries a bearing (its inner or
        outer body) and is sprung to ground: k = −∂F/∂x of the model's external force on the
        body's first coordinate at rest (its supports and springs; the ball loads, and so
        the bearing's coupling, left out), m its mass (``mass(p)``), at the parameter
        ``values`` (default the spec's). Found by the model's structure, not by parameter
        names: e.g. the housing of the 6205 defect models (8 kHz).

        >>> round(load_model("model_6205_outer_defect").support_resonances()[0])
        8000
        >>> load_model("vakharia2015").support_resonances()
        ()
        """
        import casadi as ca

        p = self.parameter_vector({**self.defaults, **(values or {})})
        z = ca.SX.sym("z", self.n_state)
        force = ca.vertcat(*self.module.external_force(z, 0.0, list(p)))
        stiffness = ca.Function("k", [z], [-ca.jacobian(force, z)])(np.zeros(self.n_state))
        stiffness, mass = np.array(stiffness), [float(m) for m in self.module.mass(list(p))]
        carried = {body for bearing in self.bearings for body in (bearing.inner, bearing.outer)}
        found = []
        for (body, _, _), (ix, _) in zip(self.module.BODIES, self.centre_indices(),
                                         strict=True):
            k, m = float(stiffness[ix, ix]), mass[ix]
            if body in carried and k > 0 and m > 0:
                found.append(math.sqrt(k / m) / (2 * math.pi))
        return tuple(sorted(found))

    def _repr_html_(self) -> str:
        """The model card in a notebook: title, spec path and SHA-256, state, bearings and
        every parameter with its default (SI units, speed in rpm), unit and source."""
        from html import escape

        bearings = ", ".join(f"{b.name}: {b.default_n_balls} balls ({b.fewest}…{b.most}), "
                             f"{b.inner} in {b.outer}" for b in self.bearings) or "none"
        rows = "".join(
            f"<tr><td><code>{escape(name)}</code></td><td>{value:.6g}</td>"
            f"<td>{escape(unit)}</td><td>{escape(source)}</td></tr>"
            for name, value, unit, source in self.module.PARAMETERS)
        facts = [("spec", f"<code>{escape(self.spec_file)}</code>"),
                 ("spec sha256", f"<code>{escape(self.spec_sha256)}</code>"),
                 ("state", ", ".join(f"<code>{escape(n)}</code> ({escape(u)})"
                                     for n, u in self.state_units.items())),
                 ("bearings", escape(bearings)),
                 ("reference", escape(str(getattr(self.module, "REFERENCE", "")) or "–"))]
        return (f'<div class="bearingdyn-model"><h4>{escape(self.name)}: '
                f"{escape(self.module.TITLE)}</h4><table>"
                + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in facts)
                + "</table><table><thead><tr><th>parameter</th><th>default</th><th>unit</th>"
                "<th>source</th></tr></thead><tbody>" + rows + "</tbody></table></div>")

    def check_state(self, state: Any, what: str = "initial_state") -> np.ndarray:
        """``state`` as a float array of the model's state size, or one clear error."""
        try:
            z = np.array(state, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            z = np.array([np.nan])
        if z.shape != (self.n_state,) or not np.all(np.isfinite(z)):
            raise InputError(f"{what}: must be {self.n_state} finite numbers "
                             f"({', '.join(self.state_names)}), got {state!r}")
        return z


def balls_text(attrs: Mapping[str, Any], symbol: str = "N_b", none: str = "no balls") -> str:
    """``N_b = 8``, ``N_b[left] = 7, N_b[right] = 11`` or ``none`` from a result's attrs
    (the inverse of ``Model.structure_attrs``)."""
    several = {k[len("n_balls_"):]: v for k, v in attrs.items() if str(k).startswith("n_balls_")}
    if several:
        return ", ".join(f"{symbol}[{b}] = {n}" for b, n in several.items())
    n = attrs.get("n_balls")
    return none if n in (None, 0) else f"{symbol} = {n}"


@dataclass(frozen=True, eq=False)
class System:
    """A model with its structure (balls per bearing), parameter values (SI, speed in rpm)
    and initial state: the one object every analysis takes.

    >>> system = System.make("vakharia2015", n_balls=8, speed_rpm=6000)
    >>> system.state_names
    ('x', 'y', 'vx', 'vy')
    """

    model: Model
    structure: Structure
    parameters: Mapping[str, float]
    state: np.ndarray

    @classmethod
    def make(cls, model: Model | str | Path, n_balls: BallCounts = None,
             state: Any = None, **parameters: float) -> System:
        """Check and bundle: ``n_balls`` (see ``BallCounts``), ``state`` (default: the
        spec's initial state) and parameter overrides by name."""
        m = load_model(model) if isinstance(model, (str, Path)) else model
        z = m.initial_state if state is None else m.check_state(state)
        structure, values = m.structure(n_balls), dict(m.parameters(parameters))
        _check_fit(m, structure, values)
        return cls(m, structure, values, z)

    def replace(self, n_balls: BallCounts = None, state: Any = None,
                **parameters: float) -> System:
        """A copy with other balls, state or parameters."""
        merged = {**self.parameters, **parameters}
        structure = self.structure if n_balls is None else self.model.structure(n_balls)
        z = self.state if state is None else self.model.check_state(state)
        values = self.model.parameters(merged)
        _check_fit(self.model, structure, values)
        return System(self.model, structure, values, z)

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.model.state_names

    @property
    def n_state(self) -> int:
        return self.model.n_state

    @property
    def p(self) -> np.ndarray:
        """The parameter vector of the generated functions."""
        return self.model.parameter_vector(dict(self.parameters))

    @property
    def functions(self):
        return self.model.functions(self.structure)

    def frequencies(self) -> Frequencies:
        return self.model.frequencies(self.structure, dict(self.parameters))


def balls_that_fit(values: Mapping[str, float], bearing: str) -> tuple[int, float, float] | None:
    """(balls that fit, ball diameter, pitch diameter) of ``bearing`` with the parameter
    ``values`` (m; ``<name>_<bearing>`` before ``<name>``; the pitch diameter from the races
    when it is not given): floor(π / asin(D_b / D_m)); None without the diameters."""
    def get(name: str) -> float | None:
        value = values.get(f"{name}_{bearing}", values.get(name))
        return None if value is None else float(value)

    d_b, d_m = get("ball_diameter"), get("pitch_diameter")
    if d_m is None and None not in (races := (get("inner_race_diameter"),
                                              get("outer_race_diameter"))):
        d_m = sum(races) / 2  # type: ignore[arg-type]
    if d_b is None or d_m is None or not 0 < d_b < d_m:
        return None
    return math.floor(math.pi / math.asin(d_b / d_m)), d_b, d_m


def _check_fit(model: Model, structure: Structure, values: Mapping[str, float]) -> None:
    """Raise InputError when the balls of a bearing do not fit its pitch circle with these
    values (a ``--set ball_diameter=…`` or ``pitch_diameter`` the generated range does not
    know)."""
    for name, n in zip(model.bearing_names, structure, strict=True):
        fit = balls_that_fit(values, name)
        if fit is not None and n > fit[0]:
            label = "n_balls" if len(structure) == 1 else f"n_balls[{name}]"
            raise InputError(f"{label}: must be at most {fit[0]}: {fit[0]} balls of "
                             f"{fit[1]:g} m fit on the pitch circle ({fit[2]:g} m), got {n}")


def as_system(target: System | Model | str | Path, n_balls: BallCounts = None,
              state: Any = None, **parameters: float) -> System:
    """The System an analysis works on: ``target`` itself when it is one (changed by any
    balls, state or parameters given), else a System of the model ``target`` (a Model, or
    a name, spec path or folder for ``load_model``)."""
    if isinstance(target, System):
        if n_balls is None and state is None and not parameters:
            return target
        return target.replace(n_balls, state, **parameters)
    return System.make(target, n_balls, state, **parameters)


# ---- finding and importing generated models -------------------------------------------

def user_models(warn: bool = True) -> dict[str, Path]:
    """The specs of the ``BEARINGDYN_MODELS`` folders by name (``user_specs``), the folders
    judged first: ``InputError`` for a folder that does not exist; with ``warn``, a warning
    for each spec whose name a shipped model has (``shadowed_specs``: that name is refused
    by ``load_model``, which one is meant cannot be told)."""
    import os

    for folder in user_spec_dirs():
        if not folder.is_dir():
            raise InputError(f"{MODELS_ENV}: '{folder}' is not an existing folder; give "
                             f"folders of specs, separated by '{os.pathsep}'")
    found = user_specs()
    if warn:
        _warn_shadowed(shadowed_specs(found))
    return found


def _warn_shadowed(shadowed: Mapping[str, Path]) -> None:
    import warnings

    for name, path in shadowed.items():
        warnings.warn(f"{MODELS_ENV}: {shown_path(path)} has the name of the shipped model "
                      f"'{name}', so "
                      f"the name '{name}' is refused; rename the spec (its model.name and "
                      "file) or give its .toml path", stacklevel=2)


def shadowed_specs(users: Mapping[str, Path] | None = None) -> dict[str, Path]:
    """The specs of ``BEARINGDYN_MODELS`` folders (``users``, default ``user_specs()``)
    whose name a shipped model has, by name: asked for by that name, a model is refused
    (``load_model``); ``bearingdyn models`` lists them as shadowed."""
    users = user_specs() if users is None else users
    return {name: path for name, path in users.items() if _is_shipped_name(name)}


def shown_path(path: Path) -> str:
    """``path`` as a message shows it: relative to the working folder when inside it (as a
    ``BEARINGDYN_MODELS=mine`` user wrote it), else whole."""
    try:
        return str(Path(path).relative_to(Path.cwd().resolve()))
    except (ValueError, OSError):
        return str(path)


def _shadowed_error(name: str, path: Path) -> InputError:
    """The refusal of a model name that is both shipped and a spec's in a
    ``BEARINGDYN_MODELS`` folder (at ``path``)."""
    return InputError(f"model: '{name}' is both the shipped model and the spec "
                      f"{shown_path(path)} in "
                      f"{MODELS_ENV}; rename that spec (model.name and the file, e.g. "
                      f"'{name}-mine') or give its .toml path to use it, or take it out of "
                      f"{MODELS_ENV} to use the shipped model")


def available_models() -> list[str]:
    """Names of the shipped models and of the specs in ``BEARINGDYN_MODELS`` folders."""
    names = []
    for info in pkgutil.iter_modules(generated.__path__):
        if info.ispkg:
            names.append(importlib.import_module(f"generated.{info.name}").NAME)
    names += [n for n in user_models(warn=False) if n not in names]
    return sorted(names)


def model_origin(name: str) -> str:
    """'shipped' or the path of the user spec a model name stands for (a shadowed name:
    'shipped', the one ``shadowed_specs`` lists beside it)."""
    users = user_specs()
    return "shipped" if name not in users or _is_shipped_name(name) else str(users[name])


def shipped_spec(name: str) -> Path:
    """The spec file of the shipped model ``name`` (``load_model`` of it loads the shipped
    model even when a ``BEARINGDYN_MODELS`` spec has its name)."""
    return shipped_spec_dir() / f"{name}.toml"


def _is_shipped_name(name: str) -> bool:
    if not name or "/" in name or "\\" in name or name.startswith((".", "_")):
        return False
    return (shipped_spec_dir() / f"{name}.toml").exists()


@cache
def load_model(name: str | Path) -> Model:
    """The model ``name``: a shipped model (``"vakharia2015"``), a spec in a
    ``BEARINGDYN_MODELS`` folder, the path of a ``.toml`` spec, or a generated folder."""
    text = str(name)
    if not text.strip():
        raise InputError("model: the name is empty; give a model name (see 'bearingdyn "
                         "models') or the path of a .toml spec")
    users = user_models(warn=False)  # the folders judged whatever the name
    path = Path(text).expanduser()
    if (broken := broken_link(path)) is not None:
        raise InputError(f"model: '{text}' {broken}")
    if text.endswith(".toml") or path.is_dir() or path.exists():
        return _load_path(path)
    shadowed = shadowed_specs(users)
    if text in shadowed:
        raise _shadowed_error(text, shadowed[text])
    _warn_shadowed(shadowed)  # a spec that shadows another name: said, not refused
    if _is_shipped_name(text) or _generated_exists(text):
        return _load_shipped(text)
    if text in users:
        return _load_spec_file(users[text])
    known = available_models()
    close = difflib.get_close_matches(text, known, n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    raise InputError(f"model: no model named '{text}'{hint}; available: {', '.join(known)} "
                     f"(a spec of your own: give its .toml path, or put its folder in "
                     f"{MODELS_ENV})")


def _generated_exists(name: str) -> bool:
    if not name or name.startswith(("_", ".")):  # _runtime, __init__: not models
        return False
    module = module_name(name)
    return importlib.util.find_spec(f"generated.{module}") is not None \
        if module.isidentifier() else False


def _load_shipped(name: str) -> Model:
    module = importlib.import_module(f"generated.{module_name(name)}")
    check_fresh(module, name)
    return Model(module=module)


def _load_path(path: Path) -> Model:
    if path.is_dir():
        return _load_folder(path)
    if not path.exists():
        raise InputError(f"model: spec file {path} {broken_link(path) or 'not found'}")
    if is_shipped(path):
        return _load_shipped(path.stem)
    return _load_spec_file(path)


def _load_spec_file(path: Path) -> Model:
    """A user spec: its cached generated code, generated first when missing."""
    root = cached_model_root(path)
    if root.is_dir() and (problem := manifest_problem(root)) is not None:
        import warnings

        warnings.warn(f"the cached code of {path.name} is damaged ({problem}); generating it "
                      f"again in {root}", stacklevel=2)
        _discard(root)
    module_dir = _only_model(root) if root.is_dir() else None
    if module_dir is None:
        _generate_into_cache(path, root)
        module_dir = _only_model(root)
    return Model(module=_import_folder(root, module_dir.name), spec_path=str(path.resolve()))


def _generate_into_cache(path: Path, root: Path) -> None:
    """Generate a user spec's code into its cache folder (validated first; written to a
    temporary folder with its manifest and renamed, so concurrent processes never see half
    a model, and a full disk leaves nothing)."""
    import shutil

    from modelgen.codegen import package_files, render
    from modelgen.tree import stage

    files = {**package_files(), **render(path).files}  # validates the spec first
    tmp = stage(root, {**files, MANIFEST: manifest_text(files)})
    try:
        tmp.rename(root)
    except OSError:  # another process was first: use theirs
        shutil.rmtree(tmp, ignore_errors=True)


def _discard(root: Path) -> None:
    """Remove a damaged cache entry: renamed aside first (one rename: another process sees
    the entry or none), then deleted."""
    import os
    import shutil

    aside = root.with_name(f".{root.name}.damaged-{os.getpid()}")
    try:
        os.rename(root, aside)
    except OSError:  # another process moved it already
        return
    shutil.rmtree(aside, ignore_errors=True)


def _only_model(root: Path) -> Path | None:
    models = [p for p in sorted(root.iterdir()) if (p / "__init__.py").exists()]
    return models[0] if len(models) == 1 else None


def _load_folder(folder: Path) -> Model:
    """A folder of ``generate --out``: the root (holding ``_runtime.py``) or one model in it."""
    given, folder = folder, folder.resolve()
    if (folder / "_runtime.py").exists():
        models = [p for p in sorted(folder.iterdir()) if (p / "__init__.py").exists()]
        if len(models) != 1:
            names = ", ".join(p.name for p in models) or "none"
            raise InputError(f"model: {folder} holds {len(models)} generated models "
                             f"({names}); give the model's folder")
        root, module = folder, models[0].name
    elif (folder.parent / "_runtime.py").exists() and (folder / "__init__.py").exists():
        root, module = folder.parent, folder.name
    else:
        raise InputError(f"model: {given} is not a generated model folder (written by "
                         "`bearingdyn generate SPEC --out DIR`)")
    if (root / MANIFEST).exists() and (problem := manifest_problem(root)) is not None:
        shown = given if root == folder else given.parent  # as the user wrote it
        raise InputError(f"model: {given} is damaged ({problem}); write it again with "
                         f"`bearingdyn generate SPEC --out {shown}`")
    loaded = _import_folder(root, module)
    check_fresh(loaded, loaded.NAME)
    return Model(module=loaded)


def _import_folder(root: Path, module: str) -> Any:
    """Import ``root/module`` as a sub-module of a package named after ``root``."""
    package = "_bearingdyn_models_" + hashlib.sha256(str(root.resolve()).encode()).hexdigest()[:12]
    if package not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            package, root / "__init__.py", submodule_search_locations=[str(root)])
        if spec is None or spec.loader is None:
            raise InputError(f"model: cannot import the generated models in {root}")
        pkg = importlib.util.module_from_spec(spec)
        sys.modules[package] = pkg
        spec.loader.exec_module(pkg)
    loaded = importlib.import_module(f"{package}.{module}")
    if not isinstance(loaded, GeneratedModelCore):  # without ROLES: Model.roles falls back
        raise InputError(f"model: {root / module} was generated by an older bearingdyn; "
                         "regenerate it with `bearingdyn generate`")
    return loaded


def check_fresh(module: Any, name: str) -> None:
    """Raise ``StaleModelError`` when the spec a generated module names has changed since
    (a shipped spec, or a user spec whose file still exists)."""
    cited = Path(module.SPEC_FILE)
    spec = shipped_spec_dir() / cited.name if not cited.is_absolute() else cited
    if not spec.exists():
        return
    digest = spec_digest(spec)
    if digest != module.SPEC_SHA256:
        where = f"generated/{module_name(name)}" if not cited.is_absolute() else \
            "the generated code"
        raise StaleModelError(
            f"model '{name}': {where} was generated from a different version of "
            f"{spec.name} (sha256 {module.SPEC_SHA256[:12]}…, the spec is now "
            f"{digest[:12]}…); regenerate it with `bearingdyn generate {name}`"
            if not cited.is_absolute() else
            f"model '{name}': {where} was generated from a different version of {spec} "
            f"(sha256 {module.SPEC_SHA256[:12]}…, the spec is now {digest[:12]}…); "
            f"regenerate it with `bearingdyn generate {spec} --out <folder>`")
