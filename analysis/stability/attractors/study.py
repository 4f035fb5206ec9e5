"""Every attractor of a System: found from many initial states, described, counted.

``AttractorStudy`` binds a System, the stroboscopic map of one forcing period and a
``RecurrenceMapper``; ``find`` labels initial states and describes every attractor met
(``label.describe``). Its scale comes from a settled run of the System's own initial state
(the orbit size per coordinate, ``Scale.of_ranges``), so the cells are a fixed fraction of
the motion whatever the model's units.

Labels: attractor ids from 1 in the order they were first met, ``DIVERGED`` (−1) for states
whose motion blew up and ``UNDECIDED`` (−2) for states still searching after
``max_periods`` periods.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from analysis.errors import InputError
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.flow import Period
from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.stability.attractors.label import Attractor, LabelOptions, describe
from analysis.stability.attractors.mapper import (
    DIVERGED,
    SPECIAL_LABELS,
    UNDECIDED,
    MapperOptions,
    RecurrenceMapper,
    Scale,
)
from analysis.stability.classify import forcing_case
from analysis.stability.periodic import as_period

MEMORY_BUDGET = 4 * 2**30
"""Most bytes a study may hold (labels, the states in flight and their cells)."""
SCALE_PERIODS = 200
"""Periods of the settled run whose ranges set the cell size."""


def one_forcing(system: System, period: Period) -> bool:
    """Whether the map over ``period`` is the same map every period: the System has one
    forcing frequency and ``period`` is its period (or a ratio made exact). Not so for an
    unbalanced rotor in a bearing (X and VC) or several bearings (a VC each)."""
    model, values = system.model, dict(system.parameters)
    if period.kind == "ratio":
        return True
    unbalanced = (model.role_value("unbalance_force", values, 0.0) or 0.0) != 0.0
    forcing = bool(model.role("forcing_period"))
    case = forcing_case(len(system.structure), unbalanced, forcing)
    return {"one bearing, no unbalance": period.kind == "vc",
            "no bearings": period.kind == "shaft",
            "no bearings, forcing_period": period.kind == "param"}.get(case, False)


def section_name(period: Period) -> str:
    """The Poincaré section (``analysis.signal.poincare``) sampled once per ``period``."""
    if period.kind == "ratio" or period.count != 1 or period.divisor != 1:
        raise InputError(f"period: {period}: give one forcing period (vc, shaft, "
                         "vc[BEARING] or param:NAME)")
    return str(period)


def check_memory(members: int, n_state: int, options: MapperOptions) -> None:
    """``InputError`` before any work when ``members`` initial states would need more than
    ``MEMORY_BUDGET``: their labels and states, a chunk of section points each and, per
    member, up to ``revisits`` + ``record`` cells of ``n_state`` indices."""
    per_member = 8 * (3 * (n_state + 1) + options.chunk * n_state
                      + (options.revisits + options.record) * (n_state + 8))
    need = members * per_member
    if need > MEMORY_BUDGET:
        most = MEMORY_BUDGET // per_member
        raise InputError(f"samples: {members} initial states would need about "
                         f"{need / 2**30:.3g} GiB; at most {MEMORY_BUDGET / 2**30:g} GiB "
                         f"({most} states with these settings): use fewer")


@dataclass
class Result:
    """Labels of initial states and the attractors they reach."""

    labels: np.ndarray
    """(K,) attractor id per initial state, ``DIVERGED`` or ``UNDECIDED``."""
    attractors: list[Attractor]
    periods: int
    """Periods integrated in all (the cost)."""
    mapper_labels: np.ndarray | None = None
    """The mapper's own labels (ids of ``RecurrenceMapper.found``; ``labels`` numbers the
    attractors met 1, 2, … in the order of those ids)."""

    def fractions(self, mask: np.ndarray | None = None) -> dict[int, tuple[float, float]]:
        """id -> (fraction of the labels, its standard error √(f(1−f)/K)) for every
        attractor and for ``DIVERGED``/``UNDECIDED`` when they occur; ``mask`` selects the
        labels counted (default: all)."""
        labels = self.labels if mask is None else self.labels[mask]
        total = max(len(labels), 1)
        ids = [a.id for a in self.attractors] + [k for k in SPECIAL_LABELS if np.any(labels == k)]
        out = {}
        for k in ids:
            f = float(np.count_nonzero(labels == k)) / total
            out[k] = (f, float(np.sqrt(f * (1 - f) / total)))
        return out


class AttractorStudy:
    """The attractors of ``system``'s map over ``period`` (None: the model's default,
    ``stability.periodic.default_period``), with RK4 steps of at most ``dt`` s (None: the
    spec's)."""

    def __init__(self, system: System, period: str | Period | None = None,
                 dt: float | None = None, options: MapperOptions | None = None,
                 label_options: LabelOptions | None = None, scale: Scale | None = None,
                 compiled: bool = True):
        self.system = system
        self.period = as_period(system.model, period)
        self.section = section_name(self.period)
        self.options = options or MapperOptions()
        self.label_options = label_options or LabelOptions()
        self.map = StroboscopicMap.make(system, self.period, dt, compiled)
        self.autonomous = one_forcing(system, self.period)
        self.scale = scale or self.settled_scale()
        self.mapper = RecurrenceMapper(self.map.advance, self.map.diverged, self.scale,
                                       self.options, self.autonomous)
        self._described: dict[int, Attractor] = {}

    def settled_scale(self) -> Scale:
        """The cell scale from ``SCALE_PERIODS`` periods of the System's own motion after
        the spec's transient (at least 100 periods)."""
        smap, model = self.map, self.system.model
        settle = max(float(model.simulation_defaults.get("transient", 0.0)),
                     100 * smap.period_s)
        periods = int(np.ceil(settle / smap.period_s))
        run = simulate(self.system, duration=(periods + SCALE_PERIODS) * smap.period_s,
                       transient=periods * smap.period_s, dt=smap.dt)
        ranges = np.array([float(np.ptp(run[name].values)) for name in model.state_names])
        units = tuple(model.state_units[name] for name in model.state_names)
        return Scale.of_ranges(ranges, model.state_names, units, 2 * np.pi / smap.period_s)

    def find(self, states: np.ndarray,
             progress: Callable[[int, int], None] | None = None) -> Result:
        """Label the initial states ``states`` (K × n, SI units, at t = 0) and describe
        every attractor met (in this call or before)."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        check_memory(len(states), self.system.n_state, self.options)
        before = self.mapper.periods
        raw = self.mapper.map(states, progress=progress)
        found = sorted(int(k) for k in np.unique(raw) if k > 0)
        dense = {label: i for i, label in enumerate(found, 1)}
        labels = np.array([dense.get(int(k), int(k)) for k in raw], dtype=np.int64)
        attractors = [replace(self.described(label), id=dense[label]) for label in found]
        return Result(labels, attractors, self.mapper.periods - before, raw)

    def described(self, label: int) -> Attractor:
        """The mapper's attractor ``label`` described (once: memoised)."""
        if label not in self._described:
            self._described[label] = describe(
                self.system, self.mapper.attractor(label), label, self.section,
                self.map.period_s, self.map.dt, self.label_options)
        return self._described[label]


def special_name(label: int) -> str:
    """``diverged`` or ``undecided``: the class of a label that is not an attractor."""
    return SPECIAL_LABELS[label]


__all__ = ["DIVERGED", "UNDECIDED", "AttractorStudy", "Result", "one_forcing"]
