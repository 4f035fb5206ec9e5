"""Priors of a calibration: ``NAME:LO:HI[:log]``, uniform (or log-uniform) boxes.

Every prior maps a unit interval onto its range (``from_unit``, ``to_unit``), so the
sampler works in the unit cube whatever the units: a log prior is uniform in log(value).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError
from analysis.model import Model

STRUCTURAL = ("n_balls",)
"""Names that are not runtime parameters (the balls are a row's condition)."""


@dataclass(frozen=True)
class Prior:
    """A uniform prior of one parameter on [lo, hi] (SI units, speed in rpm); ``log``:
    uniform in log(value) (lo > 0)."""

    name: str
    lo: float
    hi: float
    log: bool = False

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Values at unit coordinates ``u`` in [0, 1]."""
        u = np.asarray(u, dtype=float)
        if self.log:
            return np.exp(np.log(self.lo) + u * (np.log(self.hi) - np.log(self.lo)))
        return self.lo + u * (self.hi - self.lo)

    def to_unit(self, value: np.ndarray) -> np.ndarray:
        """Unit coordinates of ``value`` (outside [0, 1] when outside the prior)."""
        value = np.asarray(value, dtype=float)
        if self.log:
            return (np.log(value) - np.log(self.lo)) / (np.log(self.hi) - np.log(self.lo))
        return (value - self.lo) / (self.hi - self.lo)

    def text(self) -> str:
        """The prior as the command line writes it: ``damping:10:3162:log``."""
        return f"{self.name}:{self.lo:g}:{self.hi:g}" + (":log" if self.log else "")


def parse_prior(text: str) -> Prior:
    """``NAME:LO:HI`` or ``NAME:LO:HI:log`` (``InputError`` naming ``--prior`` and what is
    wrong: LO >= HI, a log prior with LO <= 0, a non-number)."""
    parts = str(text).split(":")
    if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] not in ("log", "lin")):
        raise InputError(f"prior: must be NAME:LO:HI or NAME:LO:HI:log, got {text!r}",
                         field="prior")
    name = parts[0].strip()
    try:
        lo, hi = float(parts[1]), float(parts[2])
    except ValueError:
        raise InputError(f"prior {name}: LO and HI must be numbers, got {text!r}",
                         field="prior") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise InputError(f"prior {name}: LO and HI must be finite, got {text!r}", field="prior")
    if lo >= hi:
        raise InputError(f"prior {name}: LO must be < HI, got LO = {lo:g}, HI = {hi:g}",
                         field="prior")
    log = len(parts) == 4 and parts[3] == "log"
    if log and lo <= 0:
        raise InputError(f"prior {name}: a log prior needs LO > 0, got LO = {lo:g}", field="prior")
    return Prior(name, lo, hi, log)


def check_priors(priors: Sequence[Prior], model: Model) -> tuple[Prior, ...]:
    """The priors checked against ``model``: each names one of its runtime parameters,
    once, and its range lies within the parameter's allowed range (``InputError``)."""
    if not priors:
        raise InputError("prior: give at least one, NAME:LO:HI[:log]", field="prior")
    seen: set[str] = set()
    for prior in priors:
        if prior.name in STRUCTURAL:
            raise InputError(f"prior {prior.name}: the balls are a target row's condition, "
                             "not a calibrated parameter", field="prior")
        if prior.name not in model.parameter_names:
            raise InputError(f"prior {prior.name}: not a parameter of model "
                             f"'{model.name}' ({', '.join(model.parameter_names)})", field="prior")
        if prior.name in seen:
            raise InputError(f"prior {prior.name}: given twice", field="prior")
        seen.add(prior.name)
        for end in (prior.lo, prior.hi):
            try:
                model.parameters({prior.name: end})
            except InputError as exc:
                raise InputError(f"prior {prior.name}: {exc}", field="prior") from None
    return tuple(priors)


def box(priors: Sequence[Prior], unit: np.ndarray) -> np.ndarray:
    """Parameter values (M × P) at unit coordinates (M × P)."""
    return np.column_stack([p.from_unit(unit[:, j]) for j, p in enumerate(priors)])


def unit(priors: Sequence[Prior], values: np.ndarray) -> np.ndarray:
    """Unit coordinates (M × P) of parameter values (M × P)."""
    return np.column_stack([p.to_unit(values[:, j]) for j, p in enumerate(priors)])
