"""The names of a model's forcings: one grammar for periods and Poincaré sections.

A forcing is named ``KIND``, ``KIND[bearing]``, ``KIND:k`` or ``param:NAME``:

- ``shaft``: the shaft revolution, period 1/X (s);
- ``cage``, ``vc``: the cage or varying-compliance period of a bearing, 1/FTF or
  1/(N_b·FTF) (s); ``[bearing]`` names one bearing of a model with several;
- ``ratio:p/q``: the common period of a ratio VC/X = p/q (p VC periods = q revolutions);
- ``param:NAME``: the value (s) of the parameter NAME, for a model forced at a period of
  its own (the parameter that plays the ``forcing_period`` role, ``Model.role``);
- ``:k`` after ``vc`` or ``shaft``: k of those periods.

Two vocabularies use the grammar: ``PERIOD`` (periodic orbits and flow maps,
``analysis.integrate.flow.Period``) and ``SECTION`` (stroboscopic sections,
``analysis.signal.poincare``). Each parses with its own words and messages. The standard
library and ``analysis.model`` only: nothing here imports above the model layer.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from analysis.errors import InputError
from analysis.model import LEGACY_ROLES, Model

PARAMETER = "param"
"""The kind of a forcing held by a parameter (``param:NAME``)."""


@dataclass(frozen=True)
class ForcingName:
    """A parsed forcing name: ``count`` periods of ``kind``, the ``ratio`` p/q of
    ``ratio:p/q``, and ``name``, the bearing (``vc[left]``; None: the model's first or only
    one) or the parameter of ``param:NAME``."""

    kind: str
    count: int = 1
    ratio: Fraction | None = None
    name: str | None = None


@dataclass(frozen=True)
class Vocabulary:
    """The words one use of the grammar accepts and the messages it gives.

    ``what`` names the input in messages (``period``, ``section``); ``kinds`` are the
    allowed words (``param`` among them or not, it is always accepted as ``param:NAME``);
    ``bearing_kinds`` may name a bearing; ``counted``: ``:k`` and ``ratio:p/q`` are
    allowed; ``syntax`` lists the forms for the message of a name that is none of them."""

    what: str
    kinds: tuple[str, ...]
    bearing_kinds: tuple[str, ...]
    counted: bool
    syntax: str

    def parse(self, text: str) -> ForcingName:
        """The forcing ``text`` names, or ``InputError`` (checked before any work)."""
        head, colon, arg = str(text).strip().partition(":")
        kind, bracket, rest = head.partition("[")
        if kind == PARAMETER and not bracket and (colon or self.counted):
            if not arg.isidentifier():
                raise InputError(f"{self.what}: param:NAME needs a parameter name, "
                                 f"got {text!r}")
            return ForcingName(PARAMETER, name=arg)
        bearing = rest.removesuffix("]") if bracket else None
        if kind not in self.kinds or kind == PARAMETER or (colon and not self.counted) or (
                bracket and (kind not in self.bearing_kinds or not rest.endswith("]")
                             or not bearing)):
            raise InputError(f"{self.what}: must be {self.syntax}, got {text!r}")
        try:
            if kind == "ratio":
                ratio = Fraction(arg)
                if ratio <= 0:
                    raise ValueError
                return ForcingName("ratio", ratio=ratio)
            count = int(arg) if arg else 1
            if count < 1:
                raise ValueError
        except (ValueError, ZeroDivisionError):
            raise InputError(f"{self.what}: the number in {text!r} must be a positive "
                             "integer (or p/q with p, q > 0 for ratio)") from None
        return ForcingName(kind, count, name=bearing)


PERIOD = Vocabulary(
    "period", ("vc", "shaft", "ratio", PARAMETER), ("vc",), True,
    "vc, shaft, vc:k, shaft:k, ratio:p/q, vc[bearing] (a model with several bearings) or "
    "param:NAME (the period in s held by parameter NAME)")
"""Periods of orbits and flow maps: ``vc``, ``shaft``, ``vc:k``, ``shaft:k``,
``ratio:p/q``, ``vc[bearing]``, ``param:NAME``."""
SECTION = Vocabulary("section", ("shaft", "cage", "vc"), ("cage", "vc"), False,
                     "shaft, cage, vc, cage[bearing], vc[bearing] or param:NAME")
"""Stroboscopic sections: ``shaft``, ``cage``, ``vc``, ``cage[bearing]``, ``vc[bearing]``,
``param:NAME``."""


def period_parameter(model: Model) -> str | None:
    """The parameter that holds the model's own forcing period (s): the first that plays
    the ``forcing_period`` role (``Model.role``), or None."""
    return next(iter(model.role("forcing_period")), None)


def run_period_parameter(attrs: Mapping) -> str | None:
    """The parameter of a run (its attrs) that holds the model's own forcing period (s):
    the attr ``forcing_parameter`` (``Frequencies.as_dict``), or for runs written before
    it the parameter ``forcing_period``; None when the run has no such parameter."""
    name = str(attrs.get("forcing_parameter", LEGACY_ROLES["forcing_period"][0]))
    return name if name in attrs else None


def run_unbalance(attrs: Mapping) -> float:
    """The value in a run (its attrs) of the parameter that plays the ``unbalance_force``
    role: the one the attr ``unbalance_parameter`` names (``Frequencies.as_dict``; a
    shaft's ``unbalance_scale``), else ``unbalance_force``; 0 when the run has neither (no
    unbalance)."""
    name = str(attrs.get("unbalance_parameter", LEGACY_ROLES["unbalance_force"][0]))
    return float(attrs.get(name, 0.0))
