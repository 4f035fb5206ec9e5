"""Every attractor of a System: found from many initial states, described, counted.

``AttractorStudy`` binds a System, the stroboscopic map of one forcing period and a
``RecurrenceMapper``; ``find`` labels initial states and describes every attractor met
(``label.describe``). Its scale comes from a settled run of the System's own initial state
(the orbit size per coordinate, ``Scale.of_ranges``), so the cells are a fixed fraction of
the motion whatever the model's units.

Labels: attractor ids from 1 in the order they were first met, ``DIVERGED`` (−1) for states
whose motion blew up, ``UNDECIDED`` (−2) for states still searching after ``max_periods``
periods and ``FAILED`` (−3) for the states of a block whose integration raised a
``SimulationError``.

**Blocks.** ``find`` cuts the initial states into blocks of ``Blocks.size`` states (default
``BLOCK``, in order). Each block is mapped by a fresh ``RecurrenceMapper`` with the study's
scale and options (``map_block``, a ``Block``: what a worker computes and a store keeps);
then ``merge`` joins the attractors of all blocks whose cell sets overlap (union–find; the
attractor of the lowest-numbered block, then the lowest label, is kept as the
representative), numbers them in the order of their representatives and describes each
once. A result depends on the states, the settings and the block size only: not on where,
in which order or by how many workers the blocks were mapped. ``Blocks.runner`` maps them
(default: in this process, one after the other); ``analysis.sweeps.attractor_blocks`` gives
one that runs them on an executor and stores each. ``use_blocks`` sets both for the studies
called inside it (``continuation.continue_attractors`` too).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

import numpy as np

from analysis.errors import InputError, SimulationError
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.flow import Period
from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.stability.attractors.label import Attractor, LabelOptions, describe
from analysis.stability.attractors.mapper import (
    DIVERGED,
    FAILED,
    SPECIAL_LABELS,
    UNDECIDED,
    Found,
    MapperOptions,
    RecurrenceMapper,
    Scale,
    cells_array,
    cells_set,
)
from analysis.stability.classify import forcing_case
from analysis.stability.periodic import as_period

MEMORY_BUDGET = 4 * 2**30
"""Most bytes a study may hold (labels, the states in flight and their cells)."""
SCALE_PERIODS = 200
"""Periods of the settled run whose ranges set the cell size."""
BLOCK = 256
"""Initial states per block (``Blocks``): each block is mapped by its own mapper, on any
worker."""


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
    """The labels each block's own mapper gave (ids of its ``RecurrenceMapper.found``;
    ``labels`` numbers the merged attractors 1, 2, … in the order of their
    representatives)."""
    spent: np.ndarray | None = None
    """(K,) periods integrated per initial state (the time it needed to be labelled)."""
    failed: dict[int, str] = field(default_factory=dict)
    """Block index -> message, for blocks whose integration failed (their states
    ``FAILED``)."""

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


@dataclass
class Block:
    """One block of initial states mapped by a fresh ``RecurrenceMapper``: its labels, the
    periods each state took, and the attractors that label its states (``Found``, in the
    order of their labels). ``arrays``/``from_arrays``: the same as plain arrays (a worker's
    reply, a stored part), exactly."""

    labels: np.ndarray
    spent: np.ndarray
    found: list[Found]
    n_state: int
    failed: str = ""
    """The ``SimulationError`` that stopped the block (its labels all ``FAILED``)."""

    @classmethod
    def failure(cls, count: int, n_state: int, message: str) -> Block:
        return cls(np.full(count, FAILED, dtype=np.int64), np.zeros(count, dtype=np.int64),
                   [], n_state, message or "failed")

    def arrays(self) -> dict[str, np.ndarray]:
        n, found = self.n_state, self.found

        def rows(values, width):
            return np.array(values, dtype=float).reshape(-1, width)

        cells = [cells_array(f.cells, n) for f in found]
        points = [rows(f.points, n) for f in found]
        missing = np.full(n + 1, np.nan)
        return {
            "labels": np.asarray(self.labels, dtype=np.int64),
            "spent": np.asarray(self.spent, dtype=np.int64),
            "n_state": np.array(n), "failed": np.array(self.failed),
            "found_label": np.array([f.label for f in found], dtype=np.int64),
            "found_step": np.array([f.found_step for f in found], dtype=np.int64),
            "finder": np.array([f.finder for f in found], dtype=np.int64),
            "finder_state": rows([f.finder_state for f in found], n + 1),
            "last_state": rows([missing if f.last_state is None else f.last_state
                                for f in found], n + 1),
            "cell_count": np.array([len(c) for c in cells], dtype=np.int64),
            "cells": np.concatenate(cells) if cells else np.zeros((0, n), dtype=np.int64),
            "point_count": np.array([len(p) for p in points], dtype=np.int64),
            "points": np.concatenate(points) if points else np.zeros((0, n)),
        }

    @classmethod
    def from_arrays(cls, data) -> Block:
        """The block of ``arrays`` (``KeyError``/``ValueError`` when they are not one)."""
        n = int(data["n_state"])
        cell_ends = np.cumsum(data["cell_count"])
        point_ends = np.cumsum(data["point_count"])
        found = []
        for j, label in enumerate(data["found_label"]):
            last = np.asarray(data["last_state"][j], dtype=float)
            found.append(Found(
                label=int(label),
                cells=cells_set(data["cells"][cell_ends[j] - data["cell_count"][j]:
                                              cell_ends[j]]),
                points=list(np.array(data["points"][point_ends[j] - data["point_count"][j]:
                                                    point_ends[j]], dtype=float)),
                finder=int(data["finder"][j]),
                finder_state=np.array(data["finder_state"][j], dtype=float),
                found_step=int(data["found_step"][j]),
                last_state=None if np.isnan(last).all() else last))
        labels = np.asarray(data["labels"], dtype=np.int64)
        spent = np.asarray(data["spent"], dtype=np.int64)
        if labels.shape != spent.shape:
            raise ValueError("labels and spent differ in length")
        return cls(labels, spent, found, n, str(data["failed"]))


Runner = Callable[["AttractorStudy", list[np.ndarray], Callable[[int, int], None] | None],
                  list[Block]]
"""``runner(study, blocks, progress)``: ``study.map_block`` of every block of initial
states, in block order (``progress(done, total)`` in states labelled)."""


def map_blocks(study: AttractorStudy, blocks: list[np.ndarray],
               progress: Callable[[int, int], None] | None = None) -> list[Block]:
    """The default runner: every block in this process, one after the other."""
    total, done, out = sum(len(b) for b in blocks), 0, []
    for states in blocks:
        def report(k: int, _: int, before: int = done) -> None:
            progress(before + k, total)

        out.append(study.map_block(states, report if progress is not None else None))
        done += len(states)
    return out


@dataclass(frozen=True)
class Blocks:
    """How ``AttractorStudy.find`` cuts and maps its initial states."""

    size: int = BLOCK
    """States per block."""
    runner: Runner | None = None
    """Who maps the blocks (None: ``map_blocks``, in this process)."""

    def __post_init__(self) -> None:
        size = self.size
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
            raise InputError(f"block: must be a whole number >= 1, got {size!r}")


_BLOCKS: ContextVar[Blocks | None] = ContextVar("attractor_blocks", default=None)


@contextmanager
def use_blocks(blocks: Blocks) -> Iterator[Blocks]:
    """Within the ``with``, ``AttractorStudy.find`` cuts and maps its states by
    ``blocks`` (unless given its own)."""
    token = _BLOCKS.set(blocks)
    try:
        yield blocks
    finally:
        _BLOCKS.reset(token)


def current_blocks() -> Blocks:
    """The ``Blocks`` in force (``use_blocks``; default ``Blocks()``)."""
    return _BLOCKS.get() or Blocks()


class AttractorStudy:
    """The attractors of ``system``'s map over ``period`` (None: the model's default,
    ``stability.periodic.default_period``), with RK4 steps of at most ``dt`` s (None: the
    spec's)."""

    def __init__(self, system: System, period: str | Period | None = None,
                 dt: float | None = None, options: MapperOptions | None = None,
                 label_options: LabelOptions | None = None, scale: Scale | None = None,
                 compiled: bool = True):
        self.system = system
        self.dt = dt
        """The largest RK4 step asked for, s (None: the spec's); the map's own is
        ``map.dt``."""
        self.period = as_period(system.model, period)
        self.section = section_name(self.period)
        self.options = options or MapperOptions()
        self.label_options = label_options or LabelOptions()
        self.map = StroboscopicMap.make(system, self.period, dt, compiled)
        self.autonomous = one_forcing(system, self.period)
        self._scale = scale

    @property
    def scale(self) -> Scale:
        """The cell scale (given, or ``settled_scale`` computed on first use)."""
        if self._scale is None:
            self._scale = self.settled_scale()
        return self._scale

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

    def mapper(self) -> RecurrenceMapper:
        """A fresh recurrence mapper of this study's map, scale and options."""
        return RecurrenceMapper(self.map.advance, self.map.diverged, self.scale,
                                self.options, self.autonomous)

    def map_block(self, states: np.ndarray,
                  progress: Callable[[int, int], None] | None = None) -> Block:
        """One block of initial states (K × n, SI, t = 0) mapped by a fresh mapper; a
        ``SimulationError`` makes it a failed block (its states ``FAILED``, recorded)."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        mapper = self.mapper()
        try:
            labels = mapper.map(states, progress=progress)
        except SimulationError as exc:
            return Block.failure(len(states), self.system.n_state, str(exc))
        used = sorted({int(k) for k in labels if k > 0})
        return Block(labels, mapper.spent.copy(), [mapper.attractor(k) for k in used],
                     self.system.n_state)

    def find(self, states: np.ndarray,
             progress: Callable[[int, int], None] | None = None,
             blocks: Blocks | None = None) -> Result:
        """Label the initial states ``states`` (K × n, SI units, at t = 0) and describe
        every attractor met: the states cut into blocks and mapped by ``blocks`` (default:
        ``current_blocks()``), the blocks' attractors merged (see the module)."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        check_memory(len(states), self.system.n_state, self.options)
        how = blocks or current_blocks()
        parts = [states[i:i + how.size] for i in range(0, len(states), how.size)]
        mapped = (how.runner or map_blocks)(self, parts, progress)
        return self.merge(mapped)

    def merge(self, blocks: Sequence[Block]) -> Result:
        """One ``Result`` of the blocks (in block order): attractors whose cells overlap
        are one (union–find; the lowest (block, label) is the representative), numbered
        1, 2, … in the order of their representatives, each described once."""
        nodes = [(b, f) for b, block in enumerate(blocks) for f in block.found]
        parent = list(range(len(nodes)))

        def root(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        owner: dict[bytes, int] = {}
        for i, (_, found) in enumerate(nodes):
            for cell in found.cells:
                j = owner.setdefault(cell, i)
                a, b = root(i), root(j)
                if a != b:
                    parent[max(a, b)] = min(a, b)
        ids: dict[int, int] = {}
        for i in range(len(nodes)):  # a group's root is its lowest node: met first
            ids.setdefault(root(i), len(ids) + 1)
        index = {(b, f.label): ids[root(i)] for i, (b, f) in enumerate(nodes)}
        labels = np.concatenate(
            [np.array([index[b, int(k)] if k > 0 else int(k) for k in block.labels],
                      dtype=np.int64) for b, block in enumerate(blocks)]
            or [np.zeros(0, dtype=np.int64)])
        attractors = [describe(self.system, nodes[r][1], i, self.section, self.map.period_s,
                               self.map.dt, self.label_options) for r, i in ids.items()]
        spent = np.concatenate([b.spent for b in blocks] or [np.zeros(0, dtype=np.int64)])
        raw = np.concatenate([b.labels for b in blocks] or [np.zeros(0, dtype=np.int64)])
        return Result(labels, attractors, int(spent.sum()), raw, spent,
                      {b: block.failed for b, block in enumerate(blocks) if block.failed})


def special_name(label: int) -> str:
    """``diverged`` or ``undecided``: the class of a label that is not an attractor."""
    return SPECIAL_LABELS[label]


__all__ = ["BLOCK", "DIVERGED", "FAILED", "UNDECIDED", "AttractorStudy", "Block", "Blocks",
           "Result", "map_blocks", "one_forcing", "use_blocks"]
