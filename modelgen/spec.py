"""The equation-spec schema: load a TOML spec, validate it, and explain what is wrong.

A spec is data: it is read with ``tomllib`` and validated with pydantic; nothing in it is
ever executed. Every problem is reported with the field's dotted path and the allowed range.
"""

from __future__ import annotations

import builtins
import difflib
import functools
import hashlib
import keyword
import math
import operator
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

import sympy as sp
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
from modelgen.quantities import QUANTITIES, TAKEN_NAMES, Quantity
from modelgen.symbols import Context, make_context
from modelgen.terms import TERM_CLASSES, TERMS, Centrifugal, ExpressionTerm, HertzContact
from modelgen.terms.expression import BALL_SYMBOLS, ROTOR_SYMBOLS

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

SPEC_DIR = "specs"
__all__ = ["N_BALLS_RANGE", "Spec", "SpecError", "load_spec", "parse_spec", "spec_hash"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False, strict=True)
    """Strict: a number in quotes is text, not a number (TOML integers still count as
    numbers)."""


class ModelInfo(_Strict):
    name: str = Field(pattern=r"^[a-z][a-z0-9-]{0,62}$")
    title: str = Field(min_length=1, max_length=200)
    reference: str = ""
    description: str = ""

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
        """Python module name of the generated model (``-`` becomes ``_``)."""
        return self.name.replace("-", "_")


class Structure(_Strict):
    n_balls: int = Field(ge=N_BALLS_RANGE[0], le=N_BALLS_RANGE[1])
    """Default number of balls; any number in range can be built at run time."""


class SimulationDefaults(_Strict):
    dt: float = Field(1e-5, gt=0, le=10.0)
    duration: float = Field(1.0, gt=0, le=1e5)
    transient: float = Field(0.0, ge=0, le=1e5)
    x0: float = 1e-6
    y0: float = 1e-6
    vx0: float = 0.0
    vy0: float = 0.0


class Parameter(_Strict):
    value: float
    unit: str
    source: str = Field(min_length=1)
    note: str = ""
    low: float | None = None
    """Smallest allowed value (inclusive) of a user-declared parameter."""
    high: float | None = None
    """Largest allowed value (inclusive) of a user-declared parameter."""

    @model_serializer(mode="wrap")
    def _omit_unset(self, handler):
        """Leave out the range of built-in parameters, so a dump is valid TOML (no None)."""
        return {k: v for k, v in handler(self).items() if v is not None}


TermEntry = Annotated[functools.reduce(operator.or_, TERM_CLASSES), Field(discriminator="kind")]
"""One ``[[terms]]`` entry: any term class, chosen by its ``kind``."""


class Spec(_Strict):
    model: ModelInfo
    structure: Structure | None = None
    """Ball set; required with a ``hertz_contact`` term, absent in models without balls."""
    simulation: SimulationDefaults = SimulationDefaults()
    parameters: dict[str, Parameter]
    terms: list[TermEntry] = Field(min_length=1)  # type: ignore[valid-type]

    @model_validator(mode="after")
    def _check_physics(self) -> Spec:
        problems = [*_parameter_problems(self.parameters), *_structure_problems(self),
                    *_term_problems(self), *_contact_problems(self), *_geometry_problems(self)]
        if self.simulation.transient >= self.simulation.duration:
            problems.append("simulation.transient: must be shorter than simulation.duration "
                            f"({self.simulation.duration:g} s)")
        if problems:
            raise ValueError("\n".join(problems))
        return self

    def parameter_values(self) -> dict[str, float]:
        return {n: p.value for n, p in self.parameters.items()}

    def contact(self) -> HertzContact | None:
        """The contact term, or None in a model without balls."""
        return next((t for t in self.terms if isinstance(t, HertzContact)), None)

    @property
    def n_balls(self) -> int:
        """Default number of balls (0 for a model without balls)."""
        return self.structure.n_balls if self.structure else 0

    def quantity(self, name: str) -> Quantity:
        """Unit, allowed range and symbol of parameter ``name`` (built-in or declared)."""
        if name in QUANTITIES:
            return QUANTITIES[name]
        par = self.parameters[name]
        return Quantity(name, par.unit, par.low, par.high, sp.latex(sp.Symbol(name)),
                        par.note or "user-declared parameter")


def _parameter_problems(parameters: dict[str, Parameter]) -> list[str]:
    """Built-in parameters: unit and range; others: a valid name, a unit and a range."""
    problems: list[str] = []
    for name, par in parameters.items():
        q = QUANTITIES.get(name)
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


def _structure_problems(spec: Spec) -> list[str]:
    """Balls exist exactly when a contact term does; ball terms need them."""
    problems: list[str] = []
    if spec.contact() is not None:
        if spec.structure is None:
            problems.append("structure: missing; a model with a 'hertz_contact' term needs "
                            f"[structure] n_balls in [{N_BALLS_RANGE[0]}, {N_BALLS_RANGE[1]}]")
        return problems
    if spec.structure is not None:
        problems.append("structure: a model without a 'hertz_contact' term has no balls; "
                        "remove [structure]")
    known = {*QUANTITIES, *spec.parameters}
    probe = make_context(sorted(known))
    probe.omega_cage = sp.Symbol("omega_cage", real=True)  # ball terms use the cage speed
    for i, term in enumerate(spec.terms):
        try:
            acts_on_balls = term.ball_load(probe) is not None
        except ExpressionError:  # reported by _term_problems
            continue
        if set(term.required_parameters()) <= known and acts_on_balls:
            problems.append(f"terms[{i}] ({term.kind}): acts on the balls and needs a "
                            "'hertz_contact' term")
    return problems


def _term_problems(spec: Spec) -> list[str]:
    """Each built-in term at most once; every parameter a term uses is declared."""
    problems: list[str] = []
    kinds = [t.kind for t in spec.terms if not isinstance(t, ExpressionTerm)]
    for kind in sorted({k for k in kinds if kinds.count(k) > 1}):
        problems.append(f"terms: '{kind}' appears {kinds.count(kind)} times; at most once")
    ctx = make_context([*spec.parameters, *(n for n in QUANTITIES if n not in spec.parameters)])
    for i, term in enumerate(spec.terms):
        if isinstance(term, ExpressionTerm):
            problems.extend(_expression_problems(i, term, spec.parameters, ctx))
    needed = {"rotor_mass": "the equations of motion"}
    for i, term in enumerate(spec.terms):
        for name in term.required_parameters():
            needed.setdefault(name, f"terms[{i}] ({term.kind})")
    for name, user in needed.items():
        if name in QUANTITIES and name not in spec.parameters:
            problems.append(f"parameters.{name}: missing; {user} needs it "
                            f"(allowed range {QUANTITIES[name].range_text()})")
    return problems


def _contact_problems(spec: Spec) -> list[str]:
    """One contact term; a two-contact model already holds the balls' centrifugal force."""
    contacts = sorted({t.kind for t in spec.terms if isinstance(t, HertzContact)})
    if len(contacts) > 1:  # the same kind twice is reported by _term_problems
        return [f"terms: {' and '.join(repr(k) for k in contacts)} both model the ball "
                "contacts; keep one"]
    if contacts != ["two_contact"]:
        return []
    return [f"terms[{i}] (centrifugal): 'two_contact' already holds the centrifugal force of "
            "the balls (outer load = inner load + F_c); remove this term"
            for i, t in enumerate(spec.terms) if isinstance(t, Centrifugal)]


def _expression_problems(i: int, term: ExpressionTerm, parameters: dict[str, Parameter],
                         ctx: Context) -> list[str]:
    """Undeclared names; then what only building the expression shows (1/0, sqrt(-1))."""
    problems = []
    for field, names in term.names().items():
        unknown = sorted(names - parameters.keys() - QUANTITIES.keys())
        for name in unknown:
            symbols = (*ROTOR_SYMBOLS, *(BALL_SYMBOLS if field == "ball" else ()))
            problems.append(f"terms.{i}.{field}: unknown name '{name}'"
                            f"{_suggest(name, [*parameters, *symbols])}; a new parameter "
                            f"needs a declaration [parameters.{name}] with value, unit, "
                            "source, low and high")
        if not unknown:
            try:
                term.parse(field, ctx)
            except ExpressionError as exc:
                problems.append(f"terms.{i}.{field}: {exc}")
    return problems


def _geometry_problems(spec: Spec) -> list[str]:
    """The races, balls and pitch circle fit together (m)."""
    p = spec.parameter_values()
    d_i, d_o = p.get("inner_race_diameter"), p.get("outer_race_diameter")
    d_m, d_b = p.get("pitch_diameter"), p.get("ball_diameter")
    problems: list[str] = []
    races = d_i is not None and d_o is not None
    if races and not d_i < d_o:
        return [f"parameters.inner_race_diameter: must be smaller than outer_race_diameter "
                f"({d_o:g} m), got {d_i:g} m"]
    if races:
        gap = (d_o - d_i) / 2
        if d_b is not None and d_b > gap * (1 + RACE_GAP_TOLERANCE):
            problems.append(f"parameters.ball_diameter: must be at most the race gap "
                            f"(outer_race_diameter − inner_race_diameter)/2 = {gap:g} m, "
                            f"got {d_b:g} m")
        if d_m is not None and not d_i < d_m < d_o:
            problems.append(f"parameters.pitch_diameter: must be in ({d_i:g}, {d_o:g}) m, "
                            f"between the races, got {d_m:g} m")
    pitch = d_m if d_m is not None else (d_i + d_o) / 2 if races else None
    if d_b is not None and pitch is not None and not problems:
        if not d_b < pitch:
            problems.append(f"parameters.ball_diameter: must be smaller than the pitch "
                            f"diameter ({pitch:g} m), got {d_b:g} m")
        elif spec.n_balls > (fit := math.floor(math.pi / math.asin(d_b / pitch))):
            problems.append(f"structure.n_balls: must be in [{N_BALLS_RANGE[0]}, {fit}]: "
                            f"at most {fit} balls of {d_b:g} m fit on the pitch circle "
                            f"({pitch:g} m), got {spec.n_balls}")
    return problems


def _all_field_names() -> set[str]:
    names: set[str] = set(QUANTITIES) | {"kind", "variant", "cage"}
    for cls in (Spec, ModelInfo, Structure, SimulationDefaults, Parameter, *TERM_CLASSES):
        names |= set(cls.model_fields)
    return names


def _suggest(word: str, choices: Any) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _format_error(err: dict[str, Any]) -> str:
    parts = err["loc"]
    loc = ".".join(str(p) for i, p in enumerate(parts) if not _is_union_tag(parts, i))
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
                f"(at most 63 characters), got {got}")
    if kind in ("too_short", "string_too_short"):
        return f"{loc}: must not be empty"
    return f"{loc}: {msg}" + (f", got {got}" if "input" in err else "")


NUMBER_ERRORS = {
    "float_parsing": "a number", "float_type": "a number", "finite_number": "a finite number",
    "int_parsing": "an integer", "int_type": "an integer", "int_from_float": "an integer",
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
    section = {"simulation": SimulationDefaults, "structure": Structure}.get(str(loc[0]))
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
        raise SpecError(source, problems) from None


def spec_path(name_or_path: str | Path) -> Path:
    """The TOML file of a shipped spec name (``vakharia2015``) or an explicit path."""
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        return candidate
    shipped = resources.files("modelgen") / SPEC_DIR / f"{name_or_path}.toml"
    path = Path(str(shipped))
    if not path.exists():
        known = shipped_spec_names()
        raise SpecError(str(name_or_path), [f"model: no spec named '{name_or_path}'"
                                            f"{_suggest(name_or_path, known)}; "
                                            f"shipped specs: {', '.join(known)}"])
    return path


def shipped_spec_names() -> list[str]:
    folder = Path(str(resources.files("modelgen") / SPEC_DIR))
    return sorted(p.stem for p in folder.glob("*.toml"))


def spec_hash(path: Path) -> str:
    """SHA-256 of the spec file's bytes: ``sha256sum`` of the file gives the same digest."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load_spec(name_or_path: str | Path) -> tuple[Spec, Path]:
    """Read and validate a spec by shipped name or path; returns the spec and its file."""
    path = spec_path(name_or_path)
    if not path.exists():
        raise SpecError(str(path), ["file not found"])
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SpecError(str(path), [f"not valid TOML: {exc}"]) from None
    spec = parse_spec(data, str(path))
    if spec.model.name != path.stem:
        raise SpecError(str(path), [f"model.name: must equal the file name '{path.stem}', "
                                    f"got '{spec.model.name}'"])
    return spec, path

