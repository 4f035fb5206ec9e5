"""The equation-spec schema: load a TOML spec, validate it, and explain what is wrong.

A spec is data: it is read with ``tomllib`` and validated with pydantic; nothing in it is
ever executed. Every problem is reported with the field's dotted path and the allowed range.
"""

from __future__ import annotations

import difflib
import functools
import hashlib
import operator
import tomllib
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from modelgen.errors import SpecError
from modelgen.quantities import QUANTITIES
from modelgen.symbols import make_context
from modelgen.terms import TERM_CLASSES, TERMS, HertzContact

N_BALLS_RANGE = (3, 64)
"""Allowed number of balls (inclusive)."""

SPEC_DIR = "specs"
__all__ = ["N_BALLS_RANGE", "Spec", "SpecError", "load_spec", "parse_spec", "spec_hash"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ModelInfo(_Strict):
    name: str = Field(pattern=r"^[a-z][a-z0-9-]{0,62}$")
    title: str
    reference: str = ""
    description: str = ""

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


TermEntry = Annotated[functools.reduce(operator.or_, TERM_CLASSES), Field(discriminator="kind")]
"""One ``[[terms]]`` entry: any term class, chosen by its ``kind``."""


_PROBE = make_context(list(QUANTITIES))
"""Symbols for asking a term whether it has a ball load, before a model's context exists."""


class Spec(_Strict):
    model: ModelInfo
    structure: Structure | None = None
    """Ball set; required with a ``hertz_contact`` term, absent in models without balls."""
    simulation: SimulationDefaults = SimulationDefaults()
    parameters: dict[str, Parameter]
    terms: list[TermEntry] = Field(min_length=1)  # type: ignore[valid-type]

    @model_validator(mode="after")
    def _check_physics(self) -> Spec:
        problems: list[str] = []
        for name, par in self.parameters.items():
            q = QUANTITIES.get(name)
            if q is None:
                problems.append(f"parameters.{name}: unknown parameter{_suggest(name, QUANTITIES)}"
                                f" (known: {', '.join(QUANTITIES)})")
                continue
            if par.unit != q.unit:
                problems.append(f"parameters.{name}.unit: must be '{q.unit}', got '{par.unit}'")
            if not q.contains(par.value):
                problems.append(f"parameters.{name}.value: must be in {q.range_text()}, "
                                f"got {par.value:g}")
        contacts = [t for t in self.terms if isinstance(t, HertzContact)]
        if contacts and self.structure is None:
            problems.append("structure: missing; a model with a 'hertz_contact' term needs "
                            f"[structure] n_balls in [{N_BALLS_RANGE[0]}, {N_BALLS_RANGE[1]}]")
        if not contacts:
            if self.structure is not None:
                problems.append("structure: a model without a 'hertz_contact' term has no "
                                "balls; remove [structure]")
            for i, term in enumerate(self.terms):
                if term.ball_load(_PROBE) is not None:
                    problems.append(f"terms[{i}] ({term.kind}): acts on the balls and needs "
                                    "a 'hertz_contact' term")
        kinds = [t.kind for t in self.terms]
        for kind in sorted({k for k in kinds if kinds.count(k) > 1}):
            problems.append(f"terms: '{kind}' appears {kinds.count(kind)} times; at most once")
        needed = {"rotor_mass": "the equations of motion"}
        for i, term in enumerate(self.terms):
            for name in term.required_parameters():
                needed.setdefault(name, f"terms[{i}] ({term.kind})")
        for name, user in needed.items():
            if name not in self.parameters:
                problems.append(f"parameters.{name}: missing; {user} needs it "
                                f"(allowed range {QUANTITIES[name].range_text()})")
        p = {n: v.value for n, v in self.parameters.items()}
        if {"inner_race_diameter", "outer_race_diameter"} <= p.keys() and not (
            p["inner_race_diameter"] < p["outer_race_diameter"]
        ):
            problems.append("parameters.inner_race_diameter: must be smaller than "
                            f"outer_race_diameter ({p['outer_race_diameter']:g} m)")
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


def _all_field_names() -> set[str]:
    names: set[str] = set(QUANTITIES) | {"kind", "variant", "cage"}
    for cls in (Spec, ModelInfo, Structure, SimulationDefaults, Parameter, *TERM_CLASSES):
        names |= set(cls.model_fields)
    return names


def _suggest(word: str, choices: Any) -> str:
    close = difflib.get_close_matches(str(word), list(choices), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _format_error(err: dict[str, Any]) -> str:
    loc = ".".join(str(part) for part in err["loc"] if not _is_union_tag(part))
    kind, msg = err["type"], err["msg"]
    if kind == "extra_forbidden":
        return f"{loc}: unknown field{_suggest(err['loc'][-1], _all_field_names())}"
    if kind == "union_tag_invalid":
        tag = err.get("input", {}).get("kind") if isinstance(err.get("input"), dict) else None
        return (f"{loc}.kind: unknown term '{tag}'{_suggest(tag, TERMS)}; "
                f"allowed: {', '.join(TERMS)}")
    if kind == "missing":
        return f"{loc}: missing required field"
    if kind == "value_error":
        return msg.removeprefix("Value error, ")
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        return f"{loc}: must be in {_field_range(err['loc'])}, got {err.get('input')!r}"
    return f"{loc}: {msg}" + (f", got {err.get('input')!r}" if "input" in err else "")


FIELD_UNITS = {"simulation": "s", "structure": ""}
"""Units of the bounded fields of each section (simulation times in s)."""


def _field_range(loc: tuple) -> str:
    """'[low, high] unit' of a bounded field, from the schema's own constraints."""
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
    unit = FIELD_UNITS.get(str(loc[0]), "")
    return f"{left}{low}, {high}{right}" + (f" {unit}" if unit else "")


def _is_union_tag(part: Any) -> bool:
    return isinstance(part, str) and part in TERMS


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

