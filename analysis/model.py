"""The one door from the analysis layer to generated models.

``load_model("vakharia2015")`` imports ``generated.vakharia2015``, checks that it still
matches its spec file (stale code is an error), and wraps it with parameter handling and the
characteristic frequencies. Nothing here imports SymPy or ``modelgen`` code.
"""

from __future__ import annotations

import difflib
import hashlib
import importlib
import math
import pkgutil
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

import generated
from analysis.errors import InputError, StaleModelError


@dataclass(frozen=True)
class Frequencies:
    """Characteristic frequencies (Hz): shaft X, cage, varying compliance VC = N_b·cage."""

    shaft_hz: float
    cage_hz: float
    vc_hz: float

    def as_dict(self) -> dict[str, float]:
        return {"shaft_hz": self.shaft_hz, "cage_hz": self.cage_hz, "vc_hz": self.vc_hz}


@dataclass(eq=False)  # compared and hashed by identity: load_model caches one per name
class Model:
    """A generated model with its parameter table (defaults in SI units, speed in rpm)."""

    module: Any
    _functions: dict[int, Any] = field(default_factory=dict, repr=False)

    @property
    def name(self) -> str:
        return self.module.NAME

    @property
    def spec_sha256(self) -> str:
        return self.module.SPEC_SHA256

    @property
    def parameter_names(self) -> list[str]:
        return [row[0] for row in self.module.PARAMETERS]

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
    def default_n_balls(self) -> int:
        return int(self.module.DEFAULT_N_BALLS)

    @property
    def simulation_defaults(self) -> dict[str, float]:
        return dict(self.module.SIMULATION)

    def check_n_balls(self, n_balls: int | None) -> int:
        n = self.default_n_balls if n_balls is None else n_balls
        low, high = self.module.N_BALLS_RANGE
        if high == 0 and n != 0:
            raise InputError(f"n_balls: model '{self.name}' has no balls; leave n_balls out, "
                             f"got {n!r}")
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not low <= n <= high:
            raise InputError(f"n_balls: must be an integer in [{low}, {high}], got {n!r}")
        return int(n)

    def functions(self, n_balls: int | None = None):
        """CasADi Functions (rhs, jac, rk4_step, simulator) for ``n_balls`` balls (cached)."""
        n = self.check_n_balls(n_balls)
        if n not in self._functions:
            self._functions[n] = self.module.build(n)
        return self._functions[n]

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

    def frequencies(self, n_balls: int | None = None,
                    values: dict[str, float] | None = None) -> Frequencies:
        """Shaft, cage and varying-compliance frequencies in Hz."""
        n = self.check_n_balls(n_balls)
        p = self.parameter_vector(values or self.defaults)
        shaft = float(self.module.shaft_speed(p)) / (2 * math.pi)
        cage = float(self.module.cage_speed(p)) / (2 * math.pi)
        return Frequencies(shaft_hz=shaft, cage_hz=cage, vc_hz=n * cage)


def available_models() -> list[str]:
    """Names of the models in ``generated/``."""
    names = []
    for info in pkgutil.iter_modules(generated.__path__):
        if info.ispkg:
            names.append(importlib.import_module(f"generated.{info.name}").NAME)
    return sorted(names)


def _spec_file(module: Any) -> Path | None:
    path = Path(str(resources.files("modelgen") / "specs" / module.SPEC_FILE))
    return path if path.exists() else None


@cache
def load_model(name: str) -> Model:
    """The generated model ``name`` (e.g. ``"vakharia2015"``), checked against its spec."""
    module_name = name.replace("-", "_")
    try:
        module = importlib.import_module(f"generated.{module_name}")
    except ModuleNotFoundError:
        known = available_models()
        close = difflib.get_close_matches(name, known, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise InputError(f"model: no generated model named '{name}'{hint}; "
                         f"available: {', '.join(known)}") from None
    check_fresh(module, name)
    return Model(module=module)


def check_fresh(module: Any, name: str) -> None:
    """Raise ``StaleModelError`` when the shipped spec's sha256 differs from the one the
    generated module was made from."""
    spec = _spec_file(module)
    if spec is None:
        return
    digest = hashlib.sha256(spec.read_bytes()).hexdigest()
    if digest != module.SPEC_SHA256:
        raise StaleModelError(
            f"model '{name}': generated/{name.replace('-', '_')} was generated from a "
            f"different version of {spec.name} (sha256 {module.SPEC_SHA256[:12]}…, the spec "
            f"is now {digest[:12]}…); regenerate it with `bearingdyn generate {name}`")
