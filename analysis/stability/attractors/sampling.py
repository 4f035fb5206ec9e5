"""Initial states for attractor studies: a box to draw from, a grid to cover.

A coordinate is any state name of the model (``x``, ``vy``, ``x_housing`` …), in its unit
(m, m/s, rad …); the coordinates a box or grid does not name start at the System's initial
state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError
from analysis.model import System


def _number(field: str, text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{field}: {what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{field}: {what} must be finite, got {text!r}")
    return value


@dataclass(frozen=True)
class Range:
    """``coordinate`` from ``low`` to ``high`` (its unit), with ``num`` points on a grid."""

    coordinate: str
    low: float
    high: float
    num: int = 0
    field: str = ""
    """The option or keyword it was given as (``--x``, ``--box`` …), named by errors."""

    @classmethod
    def parse(cls, text: str, field: str, with_num: bool) -> Range:
        """``COORD:LO:HI`` (a box side) or ``COORD:LO:HI:N`` (a grid axis, ``with_num``)."""
        form = "COORD:LO:HI:N" if with_num else "COORD:LO:HI"
        parts = text.split(":")
        if len(parts) != (4 if with_num else 3) or not parts[0]:
            raise InputError(f"{field}: must be {form}, got {text!r}")
        low = _number(field, parts[1], "LO")
        high = _number(field, parts[2], "HI")
        num = 0
        if with_num:
            try:
                num = int(parts[3])
            except ValueError:
                raise InputError(f"{field}: N must be a whole number >= 1, got "
                                 f"{parts[3]!r}") from None
        made = cls(parts[0], low, high, num, field)
        made.check(field, with_num)
        return made

    def check(self, field: str, with_num: bool = False) -> None:
        """``InputError`` unless LO < HI (and, ``with_num``, N >= 1)."""
        if not self.low < self.high:
            raise InputError(f"{field}: LO must be < HI, got {self.coordinate}:{self.low:g}:"
                             f"{self.high:g}")
        if with_num and self.num < 1:
            raise InputError(f"{field}: N must be a whole number >= 1, got {self.num}")

    def check_state(self, system: System, field: str = "") -> int:
        """The coordinate's index in the System's state, or ``InputError`` naming ``field``
        (default: the field it was given as)."""
        field = self.field or field
        names = system.state_names
        if self.coordinate not in names:
            raise InputError(f"{field}: '{self.coordinate}' is not a state of model "
                             f"'{system.model.name}'; states: {', '.join(names)}")
        return names.index(self.coordinate)

    @property
    def points(self) -> np.ndarray:
        """The grid's ``num`` values, ends included (a single point: the middle)."""
        if self.num == 1:
            return np.array([(self.low + self.high) / 2])
        return np.linspace(self.low, self.high, self.num)


@dataclass(frozen=True)
class Box:
    """Sides of a box of initial states; other coordinates at the System's state."""

    sides: tuple[Range, ...]

    @classmethod
    def parse(cls, texts: Sequence[str], field: str = "box") -> Box:
        sides = tuple(Range.parse(t, field, with_num=False) for t in texts)
        if not sides:
            raise InputError(f"{field}: give at least one COORD:LO:HI")
        names = [s.coordinate for s in sides]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise InputError(f"{field}: coordinate {', '.join(twice)} given twice")
        return cls(sides)

    @property
    def text(self) -> str:
        """The sides as the command line gives them, space-separated."""
        return " ".join(f"{s.coordinate}:{s.low!r}:{s.high!r}" for s in self.sides)

    def check(self, system: System) -> None:
        """``InputError`` unless every side names a state of ``system``."""
        for side in self.sides:
            side.check_state(system, "box")

    def sample(self, system: System, count: int, rng: np.random.Generator) -> np.ndarray:
        """``count`` states (count × n, SI units), each named coordinate uniform in its
        side."""
        self.check(system)
        states = np.repeat(system.state[None, :], count, axis=0)
        for side in self.sides:
            i = system.state_names.index(side.coordinate)
            states[:, i] = rng.uniform(side.low, side.high, count)
        return states


def check_pair(system: System, x: Range, y: Range) -> tuple[int, int]:
    """The state indices of a grid's two coordinates, or ``InputError`` when either is not
    a state or both are the same (nothing allocated: checked before any work)."""
    ix, iy = x.check_state(system, "x"), y.check_state(system, "y")
    if ix == iy:
        raise InputError(f"{y.field or 'y'}: must be another coordinate than "
                         f"{x.field or 'x'}'s, got {y.coordinate!r} twice")
    return ix, iy


def grid_states(system: System, x: Range, y: Range) -> np.ndarray:
    """The states of a grid over two coordinates (y.num × x.num rows, x fastest, SI
    units); the others at the System's state."""
    ix, iy = check_pair(system, x, y)
    gx, gy = np.meshgrid(x.points, y.points)
    states = np.repeat(system.state[None, :], gx.size, axis=0)
    states[:, ix], states[:, iy] = gx.ravel(), gy.ravel()
    return states
