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
``BLOCK``, in order). Each block is mapped by a fresh mapper with the study's scale and
options (``RecurrenceMapper``, or ``featurizing.FeaturizingMapper`` with
``mapper="features"``, whose blocks' clusters are merged when their feature cells touch;
on a GPU its sections are reduced on the device and only features come back, a few
members run again for their section points: see ``featurizing``;
``map_block``, a ``Block``: what a worker computes and a store keeps);
then ``merge`` joins the attractors of all blocks whose cell sets overlap (union–find; the
attractor of the lowest-numbered block, then the lowest label, is kept as the
representative), numbers them in the order of their representatives and describes each
once. A result depends on the states, the settings and the block size only: not on where,
in which order or by how many workers the blocks were mapped. ``Blocks.runner`` maps them
(default: in this process, one after the other); ``analysis.sweeps.attractor_blocks`` gives
one that runs them on an executor and stores each. ``continuation.continue_attractors``
takes the same ``Blocks``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

import analysis.stability.attractors.featurizing as featurizing
from analysis.budgets import STUDY_MEMORY
from analysis.errors import InputError, SimulationError
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.flow import Period
from analysis.integrate.kernels.placement import Placement, on_gpu
from analysis.integrate.simulate import simulate
from analysis.model import System
from analysis.stability.attractors.featurizing import (
    FEATURE_BLOCK,
    FeatureOptions,
    FeaturizingMapper,
    Recorder,
    choose,
    merge_groups,
    recorder,
    resolve,
)
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


def check_memory(members: int, n_state: int, options: MapperOptions,
                 features: FeatureOptions | None = None, block: int = BLOCK,
                 device_features: bool = False) -> None:
    """``InputError`` before any work when ``members`` initial states would need more than
    ``STUDY_MEMORY``. Recurrence mapper: their labels and states, a chunk of section points
    each and, per member, up to ``revisits`` + ``record`` cells of ``n_state`` indices.
    Featurizing mapper (``features`` given): per member its state, label and periods, and
    per block of ``block`` members their recorded section points, features and cells (only
    features leave a block, so the sections of one block at a time); with
    ``device_features`` (a GPU's reduction, ``featurizing.DEVICE_FEATURES``) the block's
    sections never reach the host: 2n features per member instead of K × n points (the
    few members run again for their points, at most ``PERIOD_SAMPLE`` per cluster, are
    not counted)."""
    if features is None:
        per_member = 8 * (3 * (n_state + 1) + options.chunk * n_state
                          + (options.revisits + options.record) * (n_state + 8))
        fixed = 0
    else:
        per_member = 8 * (n_state + 3)
        kept = 2 if device_features else features.sections
        fixed = 8 * min(block, members) * ((kept + 2) * n_state + 6 * n_state)
    need = members * per_member + fixed
    if need > STUDY_MEMORY:
        most = max((STUDY_MEMORY - fixed) // per_member, 0)
        raise InputError(f"samples: {members} initial states would need about "
                         f"{need / 2**30:.3g} GiB; at most {STUDY_MEMORY / 2**30:g} GiB "
                         f"({most} states with these settings): use fewer"
                         + (" or a smaller --block" if features is not None else ""))


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
    cell_width: int = 0
    """Indices per cell of ``found``'s cells (0: ``n_state``, the recurrence mapper's state
    cells; 2n: the featurizing mapper's feature cells)."""

    @property
    def width(self) -> int:
        return self.cell_width or self.n_state

    @classmethod
    def failure(cls, count: int, n_state: int, message: str) -> Block:
        return cls(np.full(count, FAILED, dtype=np.int64), np.zeros(count, dtype=np.int64),
                   [], n_state, message or "failed")

    def arrays(self) -> dict[str, np.ndarray]:
        n, found = self.n_state, self.found

        def rows(values, width):
            return np.array(values, dtype=float).reshape(-1, width)

        cells = [cells_array(f.cells, self.width) for f in found]
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
            "cell_width": np.array(self.cell_width),
            "cells": np.concatenate(cells) if cells else np.zeros((0, self.width),
                                                                  dtype=np.int64),
            "point_count": np.array([len(p) for p in points], dtype=np.int64),
            "points": np.concatenate(points) if points else np.zeros((0, n)),
        }

    @classmethod
    def from_arrays(cls, data) -> Block:
        """The block of ``arrays`` (``KeyError``/``ValueError`` when they are not one)."""
        n = int(data["n_state"])
        width = int(data["cell_width"]) if "cell_width" in data else 0
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
        return cls(labels, spent, found, n, str(data["failed"]), width)


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


class AttractorStudy:
    """The attractors of ``system``'s map over ``period`` (None: the model's default,
    ``stability.periodic.default_period``), with RK4 steps of at most ``dt`` s (None: the
    spec's). ``mapper``: ``recurrence`` or ``features`` (``featurizing.choose`` resolves
    ``auto``), the latter with ``feature_options`` on ``device`` (a ``Placement``, judged
    once: ``featurizing.resolve`` in ``make_study``; or ``cpu`` or ``gpu``)."""

    def __init__(self, system: System, period: str | Period | None = None,
                 dt: float | None = None, options: MapperOptions | None = None,
                 label_options: LabelOptions | None = None, scale: Scale | None = None,
                 compiled: bool = True, mapper: str = "recurrence",
                 feature_options: FeatureOptions | None = None,
                 device: str | Placement = "cpu"):
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
        if mapper not in ("recurrence", "features"):
            raise InputError(f"mapper: must be recurrence or features, got {mapper!r}")
        self.mapper_kind = mapper
        self.feature_options = feature_options or FeatureOptions()
        self.placement: str | Placement = device
        """Where the featurizing mapper's members run (every block takes it as it is)."""
        self._record: Recorder | None = None

    @property
    def device(self) -> str:
        """The device's name, ``cpu`` or ``gpu`` (the results' attr ``device``)."""
        return str(self.placement)

    def prepare(self, block: int) -> None:
        """Check, before any work, that blocks of ``block`` states fit the device and that
        the member kernel builds (``featurizing.recorder``; featurizing mapper only)."""
        if self.mapper_kind == "features":
            self._record = recorder(self.map, self.placement, block, self.feature_options)

    def check_memory(self, members: int, block: int) -> None:
        """``check_memory`` of ``members`` states in blocks of ``block`` by this mapper
        (on a GPU with ``featurizing.DEVICE_FEATURES``: the device's features)."""
        feature = self.mapper_kind == "features"
        check_memory(members, self.system.n_state, self.options,
                     self.feature_options if feature else None, block,
                     feature and on_gpu(self.placement) and featurizing.DEVICE_FEATURES)

    @property
    def default_block(self) -> int:
        """States per block when none is given: ``BLOCK`` for the recurrence mapper, the
        device's ``featurizing.FEATURE_BLOCK`` for the featurizing one."""
        return FEATURE_BLOCK[self.device] if self.mapper_kind == "features" else BLOCK

    @property
    def in_process(self) -> bool:
        """Whether blocks run in this process only: the featurizing mapper's member kernel
        uses every core (or the GPU) itself, so workers would only compete for them."""
        return self.mapper_kind == "features"

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

    def mapper(self, advance: Callable[[np.ndarray, int], np.ndarray] | None = None
               ) -> RecurrenceMapper:
        """A fresh recurrence mapper of this study's map, scale and options; ``advance``
        stands in for the map's ``advance`` (the cost probe's timed one)."""
        return RecurrenceMapper(advance or self.map.advance, self.map.diverged, self.scale,
                                self.options, self.autonomous)

    def map_block(self, states: np.ndarray,
                  progress: Callable[[int, int], None] | None = None) -> Block:
        """One block of initial states (K × n, SI, t = 0) mapped by a fresh mapper; a
        ``SimulationError`` makes it a failed block (its states ``FAILED``, recorded)."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        if self.mapper_kind == "features":
            return self.feature_block(states, progress)
        mapper = self.mapper()
        try:
            labels = mapper.map(states, progress=progress)
        except SimulationError as exc:
            return Block.failure(len(states), self.system.n_state, str(exc))
        used = sorted({int(k) for k in labels if k > 0})
        return Block(labels, mapper.spent.copy(), [mapper.attractor(k) for k in used],
                     self.system.n_state)

    def feature_block(self, states: np.ndarray,
                      progress: Callable[[int, int], None] | None = None) -> Block:
        """``map_block`` by a fresh ``FeaturizingMapper`` (its clusters' cells are feature
        cells, 2n indices wide)."""
        if self._record is None:
            self.prepare(len(states))
        mapper = FeaturizingMapper(self.map, self.scale, self.feature_options, self._record)
        try:
            labels = mapper.map(states, progress)
        except SimulationError as exc:
            return Block.failure(len(states), self.system.n_state, str(exc))
        return Block(labels, mapper.spent.copy(), list(mapper.found.values()),
                     self.system.n_state, cell_width=2 * self.system.n_state)

    def find(self, states: np.ndarray,
             progress: Callable[[int, int], None] | None = None,
             blocks: Blocks | None = None) -> Result:
        """Label the initial states ``states`` (K × n, SI units, at t = 0) and describe
        every attractor met: the states cut into blocks and mapped by ``blocks`` (default:
        ``Blocks()``), the blocks' attractors merged (see the module)."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        how = blocks or Blocks(self.default_block)
        self.check_memory(len(states), how.size)
        parts = [states[i:i + how.size] for i in range(0, len(states), how.size)]
        mapped = (how.runner or map_blocks)(self, parts, progress)
        return self.merge(mapped)

    def merge(self, blocks: Sequence[Block]) -> Result:
        """One ``Result`` of the blocks (in block order): attractors whose cells overlap
        (featurizing mapper: touch) are one (the lowest (block, label) is the
        representative), numbered 1, 2, … in the order of their representatives, each
        described once."""
        nodes = [(b, f) for b, block in enumerate(blocks) for f in block.found]
        if self.mapper_kind == "features":
            width = 2 * self.system.n_state
            group = merge_groups([cells_array(f.cells, width) for _, f in nodes])
            first = {int(g): i for i, g in reversed(list(enumerate(group)))}
            return self.merged(blocks, nodes, [first[int(g)] for g in group])
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
        return self.merged(blocks, nodes, [root(i) for i in range(len(nodes))])

    def merged(self, blocks: Sequence[Block], nodes: list[tuple[int, Found]],
               roots: list[int]) -> Result:
        """The ``Result`` of ``merge``: ``roots[i]`` is the lowest node of node i's
        group."""
        ids: dict[int, int] = {}
        for i in range(len(nodes)):  # a group's root is its lowest node: met first
            ids.setdefault(roots[i], len(ids) + 1)
        index = {(b, f.label): ids[roots[i]] for i, (b, f) in enumerate(nodes)}
        parts = []
        for b, block in enumerate(blocks):  # a block's few labels, each once
            part = np.array(block.labels, dtype=np.int64)
            for k in np.unique(part[part > 0]):
                part[block.labels == k] = index[b, int(k)]
            parts.append(part)
        labels = np.concatenate(parts or [np.zeros(0, dtype=np.int64)])
        attractors = [describe(self.system, nodes[r][1], i, self.section, self.map.period_s,
                               self.map.dt, self.label_options) for r, i in ids.items()]
        spent = np.concatenate([b.spent for b in blocks] or [np.zeros(0, dtype=np.int64)])
        raw = np.concatenate([b.labels for b in blocks] or [np.zeros(0, dtype=np.int64)])
        return Result(labels, attractors, int(spent.sum()), raw, spent,
                      {b: block.failed for b, block in enumerate(blocks) if block.failed})


def make_study(system: System, members: int, *, period: str | Period | None = None,
               dt: float | None = None, options: MapperOptions | None = None,
               label_options: LabelOptions | None = None, mapper: str = "auto",
               device: str | Placement = "auto",
               feature_options: FeatureOptions | None = None,
               block: int | None = None, scale: Scale | None = None,
               compiled: bool = True) -> AttractorStudy:
    """An ``AttractorStudy`` for ``members`` initial states in blocks of ``block`` (None:
    its ``default_block``), its device judged once (``featurizing.resolve``: ``cpu``,
    ``gpu`` or ``auto``, or a ``Placement`` kept; the study's ``placement``, which its
    blocks take) and its mapper chosen (``featurizing.choose``: ``auto``, ``recurrence``
    or ``features``), every input checked before any work (``InputError``): the period,
    step, memory, and for the featurizing mapper the device's room and the kernel's
    build."""
    study = AttractorStudy(system, period, dt, options, label_options, scale, compiled,
                           feature_options=feature_options)
    resolved = resolve(device, members, study.map, study.feature_options)
    study.mapper_kind, study.placement = choose(mapper, resolved, members), resolved
    size = study.default_block if block is None else Blocks(block).size
    study.check_memory(members, size)
    study.prepare(min(size, members))
    return study


def special_name(label: int) -> str:
    """``diverged`` or ``undecided``: the class of a label that is not an attractor."""
    return SPECIAL_LABELS[label]


__all__ = ["BLOCK", "DIVERGED", "FAILED", "UNDECIDED", "AttractorStudy", "Block", "Blocks",
           "Result", "make_study", "map_blocks", "one_forcing"]
