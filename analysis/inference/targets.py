"""Calibration targets: tables of observed regimes and spectrum lines, read from TOML.

A target is a list of rows. Each row is a **condition** (the balls ``n_balls``, and any
parameter values, e.g. ``speed_rpm``; a file's ``[conditions]`` table gives values every
row shares) and what was **observed** there, any of:

- ``class``: the motion class, one of ``CLASSES`` or ``periodic-<n>``, or a list of
  alternatives (any one matches);
- ``major``: the largest spectrum line per coordinate, by name (``{x = "X", y = "2X"}``);
- ``present``: lines that must be among a coordinate's peaks (``{x = ["2X", "VC"]}``).

Line names are those ``analysis.signal.spectrum.find_peaks`` gives: m·X + n·VC with
|m| <= 4, 0 <= n <= 3 (``X``, ``2X``, ``VC``, ``VC-X``, ``2VC+3X``; ``VC[<bearing>]`` for a
model of several bearings). The paper's Table 2 ships as ``paper-table2``.

Schema (every field checked against the model, one line per problem, ``InputError``)::

    name = "my-table"            # optional (default: the file's stem)
    description = "..."          # optional
    source = "where it is from"  # optional
    [conditions]                 # optional: parameter values of every row
    speed_rpm = 5000.0
    [[rows]]
    n_balls = 7                  # an integer, or {bearing = n, ...} for several bearings
    speed_rpm = 6000.0           # optional: any parameter of the model (SI, speed in rpm)
    class = "quasi-periodic"     # optional
    major = { x = "X", y = "X" } # optional
    present = { x = ["2X", "VC"] }   # optional
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from analysis.errors import InputError
from analysis.model import Model
from analysis.signal.spectrum import label_frequency

CLASSES = ("chaotic", "quasi-periodic", "periodic", "periodic-k", "diverged")
"""Class words of a target row: ``periodic`` is any periodic-n, ``periodic-k`` any with
n >= 2 (the paper's "multi-orbit periodic" as a subharmonic orbit), ``periodic-<n>`` (e.g.
``periodic-1``) exactly n; ``diverged``: the run blew up (a class of its own in
calibration, never dropped)."""

BUILT_IN = {"paper-table2": "paper-table2.toml", "paper-table2-torus": "paper-table2-torus.toml"}
"""Targets shipped with the package (``analysis/inference/targets/``)."""

MAX_SHAFT_ORDER, MAX_VC_ORDER = 4, 3
"""The orders ``find_peaks`` names lines with (``spectrum.frequency_names``' defaults)."""

_ROW_KEYS = {"n_balls", "class", "major", "present", "label"}
_PERIODIC_N = re.compile(r"periodic-(\d+)$")


@dataclass(frozen=True)
class TargetRow:
    """One observed condition: balls, parameter values, and what was seen."""

    n_balls: int | tuple[tuple[str, int], ...]
    """One number (a model with one bearing) or (bearing, number) pairs."""
    parameters: tuple[tuple[str, float], ...] = ()
    """Parameter values of this row (SI units, speed in rpm), the conditions included."""
    classes: tuple[str, ...] = ()
    """Accepted classes (empty: the class is not asked)."""
    major: tuple[tuple[str, str], ...] = ()
    """(coordinate, line name) of the largest line."""
    present: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(coordinate, line names) that must be among the coordinate's peaks."""
    label: str = ""

    @property
    def balls(self) -> int | dict[str, int]:
        """``n_balls`` as ``Model.structure`` takes it."""
        return self.n_balls if isinstance(self.n_balls, int) else dict(self.n_balls)

    @property
    def has_lines(self) -> bool:
        return bool(self.major or self.present)

    def name(self) -> str:
        """The row as a reader sees it: ``N_b = 7`` (its label when given)."""
        if self.label:
            return self.label
        if isinstance(self.n_balls, int):
            return f"N_b = {self.n_balls}"
        return ", ".join(f"N_b[{b}] = {n}" for b, n in self.n_balls)


@dataclass(frozen=True)
class Target:
    """A calibration target: named rows of observations."""

    name: str
    rows: tuple[TargetRow, ...]
    description: str = ""
    source: str = ""
    path: str = ""
    """The file it was read from (a built-in target's packaged file)."""
    coordinates: tuple[str, ...] = field(default=())
    """Every coordinate whose lines some row asks for (``x``, ``y``, …)."""

    def as_dict(self) -> dict[str, Any]:
        """The target as plain JSON values (what a result's ``target`` holds)."""
        return {"name": self.name, "description": self.description, "source": self.source,
                "path": self.path,
                "rows": [{"label": r.name(), "n_balls": r.balls,
                          "parameters": dict(r.parameters), "class": list(r.classes),
                          "major": dict(r.major),
                          "present": {c: list(v) for c, v in r.present}}
                         for r in self.rows]}


def class_matches(wanted: tuple[str, ...], nature: str) -> bool:
    """Whether a motion class ``nature`` (``classify``'s: periodic-n, quasi-periodic,
    chaotic; or ``diverged``) is one of the ``wanted`` class words (``CLASSES``,
    ``periodic-<n>``). True when nothing is wanted."""
    if not wanted:
        return True
    found = _PERIODIC_N.match(nature)
    for word in wanted:
        if word == nature:
            return True
        if found and word == "periodic":
            return True
        if found and word == "periodic-k" and int(found.group(1)) >= 2:
            return True
    return False


def line_names(model: Model) -> frozenset[str]:
    """Every line name ``find_peaks`` can give for ``model``: m·X + n·VC (|m| <= 4,
    0 <= n <= 3), with ``VC[<bearing>]`` for each bearing of a model of several."""
    bearings = model.bearing_names
    shaft, vc = 1.0, math.pi  # incommensurate: each (m, n) its own frequency
    vcs: dict[str, float] | float = vc if len(bearings) <= 1 else \
        {b: vc * (i + 1) ** 0.5 for i, b in enumerate(bearings)}
    names = set()
    for values in ([vc] if isinstance(vcs, float) else list(vcs.values())):
        for n in range(MAX_VC_ORDER + 1 if bearings else 1):
            for m in range(-MAX_SHAFT_ORDER, MAX_SHAFT_ORDER + 1):
                f = m * shaft + n * values
                if f > 0:
                    named = label_frequency(f, shaft, vcs if bearings else 0.0, 1e-9)
                    if named is not None:
                        names.add(named[0])
    return frozenset(names)


def _check_class(word: Any, where: str) -> str:
    if not isinstance(word, str) or not (word in CLASSES or (_PERIODIC_N.match(word)
                                         and int(word.split("-")[1]) >= 1)):
        raise InputError(f"{where}: must be one of {', '.join(CLASSES)} or periodic-<n> "
                         f"(n >= 1), got {word!r}")
    return word


def _check_line(name: Any, where: str, lines: frozenset[str]) -> str:
    """A line name of this model (``lines``); the refusal shows names of this model's own
    lines (``VC[left]`` on a two-bearing model, never a bare ``VC`` it does not have)."""
    if not isinstance(name, str) or name not in lines:
        ordered = sorted(lines, key=lambda line: (len(line), line))
        examples = [line for line in ordered if "VC" in line][:4]
        shown = ", ".join(["X", "2X", *examples, "…"])
        vc = "VC[<bearing>]" if any("[" in line for line in lines) else "VC"
        raise InputError(f"{where}: must be a line name m X + n {vc} (|m| <= "
                         f"{MAX_SHAFT_ORDER}, 0 <= n <= {MAX_VC_ORDER}: {shown}), got "
                         f"{name!r}")
    return name


def _check_coordinate(name: str, where: str, model: Model) -> str:
    if name not in model.state_names or name.startswith("v"):
        positions = [s for s in model.state_names if not s.startswith("v")]
        raise InputError(f"{where}: must be a coordinate of model '{model.name}' "
                         f"({', '.join(positions)}), got {name!r}")
    return name


def _check_text(value: Any, where: str) -> str:
    """A name or label shown in figures and tables: one line of text without ``$`` (which
    the figures would read as the start of a formula, failing after the work was done)."""
    if not isinstance(value, str) or "$" in value or "\n" in value or len(value) > 120:
        raise InputError(f"{where}: must be one line of text (at most 120 characters, no "
                         f"'$'), got {value!r}")
    return value


def _words(value: Any, where: str, what: str) -> tuple[str, ...]:
    """A word or a list of words (``class = "chaotic"``, ``present = {x = ["X", "VC"]}``)."""
    if isinstance(value, str):
        return (value,)
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return tuple(value)
    raise InputError(f"{where}: must be {what} or a list of them, got {value!r}")


def _check_balls(value: Any, where: str, model: Model) -> int | tuple[tuple[str, int], ...]:
    if not isinstance(value, Mapping) and (isinstance(value, bool)
                                           or not isinstance(value, int)):
        named = ", ".join(f"{b} = 8" for b in model.bearing_names) or "…"
        raise InputError(f"{where}: must be a whole number of balls, or a table by bearing "
                         f"({{{named}}}), got {value!r}")
    if isinstance(value, Mapping):
        for bearing in value:
            if bearing not in model.bearing_names:
                raise InputError(f"{where}: model '{model.name}' has no bearing "
                                 f"{bearing!r}; bearings: {', '.join(model.bearing_names)}")
    try:
        model.structure(dict(value) if isinstance(value, Mapping) else value)
    except InputError as exc:
        raise InputError(f"{where}: {str(exc).partition(': ')[2]}") from None
    return tuple(sorted(value.items())) if isinstance(value, Mapping) else int(value)


def _check_parameters(values: Mapping[str, Any], where: str, model: Model) -> dict[str, float]:
    out = {}
    for name, value in values.items():
        if name not in model.parameter_names:
            raise InputError(f"{where}.{name}: not a parameter of model '{model.name}' "
                             f"({', '.join(model.parameter_names)})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value):
            raise InputError(f"{where}.{name}: must be a finite number, got {value!r}")
        out[name] = float(value)
    try:
        model.parameters(out)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    return out


def parse_target(data: Mapping[str, Any], model: Model, name: str = "",
                 path: str = "") -> Target:
    """A ``Target`` from a TOML document's contents, every field checked against ``model``
    (``InputError`` naming the field, e.g. ``target rows[2].class``)."""
    where = "target"
    unknown = set(data) - {"name", "description", "source", "conditions", "rows"}
    if unknown:
        raise InputError(f"{where}: unknown field {sorted(unknown)[0]!r} (fields: name, "
                         "description, source, conditions, rows)")
    conditions = data.get("conditions", {})
    if not isinstance(conditions, Mapping):
        raise InputError(f"{where} conditions: must be a table of parameter values")
    shared = _check_parameters(conditions, f"{where} conditions", model)
    if "name" in data:
        _check_text(data["name"], f"{where} name")
    for key in ("description", "source"):
        if not isinstance(data.get(key, ""), str):
            raise InputError(f"{where} {key}: must be text, got {data[key]!r}")
    rows_in = data.get("rows", [])
    if not isinstance(rows_in, list):
        raise InputError(f"{where} rows: must be a list of [[rows]] tables, got {rows_in!r}")
    if not rows_in:
        raise InputError(f"{where} rows: must hold at least one [[rows]] entry, got none "
                         "(an empty target)")
    lines = line_names(model)
    rows, coordinates = [], []
    for i, row in enumerate(rows_in):
        at = f"{where} rows[{i}]"
        if not isinstance(row, Mapping):
            raise InputError(f"{at}: must be a table")
        if "n_balls" not in row and model.bearings:
            raise InputError(f"{at}.n_balls: missing (the balls of this row)")
        balls = _check_balls(row.get("n_balls", model.default_n_balls), f"{at}.n_balls", model)
        params = _check_parameters({k: v for k, v in row.items() if k not in _ROW_KEYS},
                                   at, model)
        wanted = _words(row["class"], f"{at}.class", "a class") if "class" in row else ()
        classes = tuple(_check_class(w, f"{at}.class") for w in wanted)
        if "label" in row:
            _check_text(row["label"], f"{at}.label")
        major = row.get("major", {})
        present = row.get("present", {})
        if not isinstance(major, Mapping) or not isinstance(present, Mapping):
            raise InputError(f"{at}: major and present must be tables by coordinate "
                             "(major = {x = \"X\"}, present = {x = [\"2X\"]})")
        major_t = tuple((_check_coordinate(c, f"{at}.major", model),
                         _check_line(v, f"{at}.major.{c}", lines)) for c, v in major.items())
        present_t = []
        for c, names in present.items():
            _check_coordinate(c, f"{at}.present", model)
            names = _words(names, f"{at}.present.{c}", "a line name")
            present_t.append((c, tuple(_check_line(v, f"{at}.present.{c}", lines)
                                       for v in names)))
        if not classes and not major_t and not any(v for _, v in present_t):
            raise InputError(f"{at}: observes nothing; give class, major or present")
        coordinates += [c for c, _ in major_t] + [c for c, _ in present_t]
        rows.append(TargetRow(balls, tuple(sorted({**shared, **params}.items())), classes,
                              major_t, tuple(present_t), str(row.get("label", ""))))
    return Target(str(data.get("name", name)), tuple(rows), str(data.get("description", "")),
                  str(data.get("source", "")), path, tuple(dict.fromkeys(coordinates)))


def target_path(name: str | Path) -> Path:
    """The file of a target: a built-in name (``BUILT_IN``) or a path to a TOML file."""
    if str(name) in BUILT_IN:
        return Path(str(resources.files("analysis.inference") / "targets"
                        / BUILT_IN[str(name)]))
    path = Path(name)
    allowed = f"must be a built-in target ({', '.join(BUILT_IN)}) or a .toml file"
    if not path.exists():
        raise InputError(f"target: {allowed}; there is no file {str(name)!r}", field="target")
    if path.is_dir():
        raise InputError(f"target: {allowed}; {str(name)!r} is a folder", field="target")
    if not path.is_file():  # a FIFO, a device (/dev/zero): never read
        raise InputError(f"target: {allowed}; {str(name)!r} is not a regular file", field="target")
    if path.suffix != ".toml":
        raise InputError(f"target: {allowed}, got {str(name)!r}", field="target")
    if path.stat().st_size > MAX_TARGET_BYTES:
        raise InputError(f"target: {str(name)!r} holds {path.stat().st_size} bytes; a "
                         f"target file has at most {MAX_TARGET_BYTES}", field="target")
    return path


MAX_TARGET_BYTES = 1 << 20
"""Largest target file read (1 MiB: a target is a short table)."""


def load_target(name: str | Path, model: Model) -> Target:
    """Read and check a target (``target_path``) against ``model``. A UTF-8 byte-order mark
    (left by some editors) is skipped."""
    path = target_path(name)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except UnicodeDecodeError:
        raise InputError(f"target: {path} is not UTF-8 text", field="target") from None
    except OSError as exc:
        raise InputError(f"target: cannot read {path} ({exc.strerror or exc})",
                         field="target") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"target: {path} is not valid TOML ({exc})", field="target") from None
    return parse_target(data, model, path.stem, str(path))
