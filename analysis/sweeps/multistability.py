"""Multistability in charts: how many attractors a grid point has, and of which classes.

A chart point classifies the one trajectory of the model's initial state. With ``Ics``
(``bearingdyn chart --ics K``) each point also maps K initial states as one ensemble on the
stroboscopic map of its section (``analysis.stability.attractors``): the model's initial
state and K − 1 states drawn in a box (seeded per point, so a chart is reproducible and a
resumed chart equal to an uninterrupted one). The point records the number of distinct
attractors met and the class code of each (``classify.NATURE_CODES``), the share of the K
states that diverged, and whether the point is multistable (two or more attractors).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from analysis.errors import InputError, ParameterError
from analysis.forcing import PERIOD
from analysis.model import System
from analysis.stability.attractors import DIVERGED, AttractorStudy, Box, MapperOptions, Range
from analysis.stability.classify import nature_code

MAX_ICS = 256
"""Most initial states per chart point."""


@dataclass(frozen=True)
class Ics:
    """K initial states per chart point (the model's own and K − 1 drawn in ``box``)."""

    count: int
    box: Box | None = None
    """Sides to draw in; None: every position within ± the radial clearance of its
    initial value (models with a clearance), velocities at their initial value."""
    seed: int = 0
    options: MapperOptions = field(default_factory=MapperOptions)

    def __post_init__(self) -> None:
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) \
                or not 1 <= self.count <= MAX_ICS:
            raise InputError(f"ics: must be a whole number in [1, {MAX_ICS}], got "
                             f"{self.count!r}")

    def box_of(self, system: System) -> Box:
        """The box of ``system``'s states (``InputError`` for a model without a clearance
        when none was given)."""
        if self.box is not None:
            self.box.check(system)
            return self.box
        clearance = system.model.role_value("clearance", dict(system.parameters))
        if not clearance:
            raise InputError(f"ics-box: model '{system.model.name}' has no radial clearance "
                             "to draw initial displacements within; give --ics-box "
                             "COORD:LO:HI")
        half = system.n_state // 2
        return Box(tuple(Range(name, float(z) - clearance, float(z) + clearance, 0, "ics-box")
                         for name, z in zip(system.state_names[:half], system.state[:half],
                                            strict=True)))

    def check(self, system: System) -> None:
        """``InputError`` before any point runs: the box fits ``system`` (``box_of``) and its
        sides lie within the bounds of an initial state (``integrate.checks``:
        ``check_start_range``, a displacement within the blow-up limit, a velocity within
        the velocity bound)."""
        from analysis.integrate.checks import check_start_range, start_limits

        limits = start_limits(system)
        for side in self.box_of(system).sides:
            check_start_range(system, side.coordinate, side.low, side.high,
                              side.field or "ics-box", limits)

    def states(self, system: System, point: int) -> np.ndarray:
        """The K initial states of grid point ``point`` (its index in the grid), SI units."""
        drawn = self.box_of(system).sample(system, self.count - 1,
                                           np.random.default_rng([self.seed, point]))
        return np.concatenate([system.state[None, :], drawn])


def section_period(section: str) -> str | None:
    """The map's period for a chart's classification ``section`` (None: the model's
    default, for a section that is not a period, e.g. the cage's)."""
    try:
        PERIOD.parse(section)
    except InputError:
        return None
    return section


def point_attractors(ics: Ics, system: System, section: str, point: int,
                     dt: float | None = None) -> dict:
    """``n_attractors``, ``attractor_codes`` (K slots: each attractor's class code, −1
    for unused slots), ``diverged_share`` and ``multistable`` of one chart point."""
    study = AttractorStudy(system, section_period(section), dt, ics.options)
    result = study.find(ics.states(system, point))
    codes = np.full(ics.count, -1, dtype=np.int64)
    for k, attractor in enumerate(result.attractors):
        codes[k] = nature_code(attractor.nature)
    return {"n_attractors": len(result.attractors), "attractor_codes": codes,
            "diverged_share": float(np.mean(result.labels == DIVERGED)),
            "multistable": int(len(result.attractors) >= 2)}


def parse_ics(count: int | None, box: Sequence[str] | None, seed: int) -> Ics | None:
    """The ``Ics`` of ``--ics K --ics-box … --ics-seed S`` (None without ``--ics``); a box
    without a count is refused naming ``ics_box`` (``errors.ParameterError``)."""
    if count is None:
        if box:
            raise ParameterError("ics_box", "{field}: draws the initial states of {ics}; "
                                 "give {ics} K", {"ics": ("ics", "--ics")})
        return None
    return Ics(count, Box.parse(box, "--ics-box") if box else None, seed)
