"""Attractors of a stroboscopic map found by recurrences on a sparse grid of cells.

The method of Datseris & Wagemakers (Chaos 32, 023104, 2022; Attractors.jl's
``AttractorsViaRecurrences``), on the section points of an ensemble
(``analysis.integrate.ensemble.StroboscopicMap``): the state space is cut into cells (a
cell is ``1/resolution`` of the orbit size along each coordinate, velocities divided by the
section's angular frequency, see ``Scale``); the grid is sparse (only visited cells are
stored), so it has no edges and no memory that grows with its volume. Each trajectory runs
this state machine on its section points, one per forcing period:

- **search**: a point in a cell this trajectory has visited before counts a revisit, a new
  cell resets the count. ``revisits`` consecutive revisits: the trajectory is on an
  attractor not known yet; it is **recorded**.
- **record**: the cells of the next ``record`` points are the new attractor's cells, and
  its points its section points; then the trajectory is labelled with it. A recorded point
  in a cell of a known attractor means the two are one: the trajectory is labelled with the
  known one, and its cells are added to it.
- **hit**: ``hits`` consecutive points in the cells of a known attractor label the
  trajectory with it at once (early stopping: a settled trajectory is never integrated to a
  fixed end time).
- **basin** (maps of one forcing period only): every point of a trajectory labelled k lies
  in k's basin; its cells are stored as k's basin cells, and ``basin_hits`` consecutive
  points in them label a later trajectory at once. With two incommensurate forcings (an
  unbalanced rotor's X and VC on the shaft section) the map changes from one period to the
  next (the ball set's phase turns), a state's future depends on when it is reached, and
  basin cells are not used; attractor cells are (the attractor is a closed curve or a cloud
  of the section, which a finite set of cells covers).
- a trajectory that leaves the blow-up bound, or whose state is not finite, is
  ``DIVERGED``; one still searching after ``max_periods`` periods is ``UNDECIDED``. Neither
  is ever dropped (nor are the states of a block whose integration failed: ``FAILED``).

Trajectories are advanced ``chunk`` periods per ensemble call and processed in a fixed
order, so a result depends only on the states, the settings and the chunk.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields

import numpy as np

from analysis.errors import InputError

DIVERGED = -1
"""Label of a trajectory that blew up (non-finite, or beyond the model's blow-up bound)."""
UNDECIDED = -2
"""Label of a trajectory still searching after ``max_periods`` periods."""
FAILED = -3
"""Label of the states of a block whose mapping raised a ``SimulationError`` (recorded,
never dropped; see ``study.AttractorStudy.map_block``)."""
SPECIAL_LABELS = {DIVERGED: "diverged", UNDECIDED: "undecided", FAILED: "failed"}
"""The class names of the labels that are not attractors."""


@dataclass(frozen=True)
class MapperOptions:
    """The settings of the recurrence mapper (counts are in section points, one per forcing
    period). Defaults follow Attractors.jl's ``AttractorsViaRecurrences`` where they
    exist."""

    resolution: int = 40
    """Cells per orbit size along each coordinate (see ``Scale``). Too coarse merges close
    attractors into one; too fine costs periods before the revisits accumulate."""
    revisits: int = 30
    """Consecutive revisits of a trajectory's own cells that mark an attractor."""
    record: int = 100
    """Points recorded as the cells of a new attractor."""
    hits: int = 5
    """Consecutive points in a known attractor's cells that label a trajectory."""
    basin_hits: int = 10
    """Consecutive points in a known basin's cells that label a trajectory (maps of one
    forcing only)."""
    max_periods: int = 3000
    """Periods after which a trajectory still searching is ``UNDECIDED``."""
    chunk: int = 10
    """Periods per ensemble call."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"{f.name}: must be a whole number >= 1, got {value!r}")
        if self.revisits >= self.max_periods:
            raise InputError(f"max_periods: must exceed revisits ({self.revisits}), got "
                             f"{self.max_periods}")


@dataclass(frozen=True)
class Scale:
    """The normalisation of section points before they are cut into cells: coordinate i is
    divided by ``size[i]`` (its own unit: m, rad, m/s …), so one cell is ``1/resolution``
    of it. ``Scale.of_run`` takes the sizes from a settled run."""

    size: np.ndarray

    @classmethod
    def of_ranges(cls, ranges: np.ndarray, names: tuple[str, ...], units: tuple[str, ...],
                  omega: float) -> Scale:
        """Sizes from the peak-to-peak ``ranges`` of every state (SI units) over a settled
        run of angular section frequency ``omega`` (rad/s): every position of one unit gets
        the largest range of its unit, every velocity that size times ``omega`` (at least
        its own unit's largest range), so a circular orbit is as many cells wide in x as in
        vx. A unit whose range is 0 (a coordinate at rest) takes the largest position
        range."""
        ranges = np.abs(np.asarray(ranges, dtype=float))
        half = len(names) // 2
        size = np.empty(len(names))
        biggest = max(float(ranges[:half].max(initial=0.0)), 1e-300)
        for unit in set(units[:half]):
            group = [i for i in range(half) if units[i] == unit]
            scale = float(ranges[group].max()) or biggest
            size[group] = scale
            vel = [i + half for i in group]
            size[vel] = max(scale * omega, float(ranges[vel].max()))
        return cls(size)


@dataclass
class Found:
    """An attractor as the mapper found it: its cells, section points and the trajectory
    that recorded it."""

    label: int
    cells: set = field(default_factory=set)
    basin: set = field(default_factory=set)
    points: list = field(default_factory=list)
    """Section points recorded (SI units), in the order met."""
    finder: int = -1
    """Index of the trajectory (in its ``map`` call) that recorded it."""
    finder_state: np.ndarray | None = None
    """That trajectory's initial state and step counter ``[z, k]``."""
    found_step: int = 0
    """Step counter of the finder at the end of the chunk in which it recognised the
    attractor (time = k·h)."""
    last_state: np.ndarray | None = None
    """The finder's ``[z, k]`` at the end of the chunk of its last recorded point (a state
    on the attractor)."""

    @property
    def representative(self) -> np.ndarray:
        """A state on the attractor (SI units; at step counter ``last_state[-1]``)."""
        return self.last_state[:-1]


def cells_array(cells: set, n: int) -> np.ndarray:
    """The mapper's cell keys (``RecurrenceMapper.cell_keys``) of an n-state map as an
    (m, n) int64 array of cell indices, sorted (the exact inverse of ``cells_set``)."""
    return np.frombuffer(b"".join(sorted(cells)), dtype=np.int64).reshape(-1, n).copy()


def cells_set(cells: np.ndarray) -> set:
    """An (m, n) int64 array of cell indices as the mapper's cell keys (``bytes`` rows)."""
    return {row.tobytes() for row in np.ascontiguousarray(cells, dtype=np.int64)}


class _Trace:
    """The search state of one trajectory."""

    __slots__ = ("basin_run", "cells", "hit_label", "hit_run", "record_left", "recording",
                 "revisits")

    def __init__(self) -> None:
        self.cells: set = set()
        self.revisits = 0
        self.hit_label, self.hit_run, self.basin_run = 0, 0, 0
        self.recording: Found | None = None
        self.record_left = 0


class RecurrenceMapper:
    """Labels initial states with the attractor their trajectory reaches.

    ``advance(s, n)`` is a stroboscopic map (``StroboscopicMap.advance``: rows ``[z, k]``
    changed in place, returns the n section points of each), ``diverged(points)`` its
    blow-up test; ``scale`` normalises points; ``autonomous``: the map is the same every
    period (one forcing), so basin cells may be used. The attractors found accumulate over
    calls of ``map`` (a later call labels states that reach a known one at once)."""

    def __init__(self, advance: Callable[[np.ndarray, int], np.ndarray],
                 diverged: Callable[[np.ndarray], np.ndarray], scale: Scale,
                 options: MapperOptions | None = None, autonomous: bool = True):
        self.advance, self.is_diverged = advance, diverged
        self.scale, self.options = scale, options or MapperOptions()
        self.autonomous = autonomous
        self.found: dict[int, Found] = {}
        """The attractors by label (labels from 1; one merged into another leaves a gap)."""
        self._next = 0
        self._owner: dict[bytes, int] = {}  # attractor cell -> label
        self._basin: dict[bytes, int] = {}  # basin cell -> label (autonomous maps only)
        self._merged: dict[int, int] = {}  # a label merged away -> the label it joined
        self.periods = 0
        """Periods integrated, summed over trajectories (the cost of the mapping)."""
        self.spent = np.zeros(0, dtype=np.int64)
        """Periods integrated per initial state in the last ``map`` call (the time each
        trajectory needed to be labelled)."""

    # -- cells ------------------------------------------------------------------------------
    def cell_keys(self, points: np.ndarray) -> list[list[bytes]]:
        """The cell of every point ((K, m, n) SI) as hashable keys, per trajectory."""
        index = np.floor(points / self.scale.size * self.options.resolution)
        index = np.nan_to_num(index, nan=0.0, posinf=0.0, neginf=0.0).astype(np.int64)
        return [[row.tobytes() for row in member] for member in index]

    def attractor(self, label: int) -> Found:
        return self.found[self.resolve(label)]

    def resolve(self, label: int) -> int:
        """The label an attractor now has: one recorded by a trajectory and found to be a
        known attractor was merged into it, and states labelled with it before then are
        that attractor's."""
        while label in self._merged:
            label = self._merged[label]
        return label

    # -- the state machine ------------------------------------------------------------------
    def map(self, states: np.ndarray, steps: np.ndarray | None = None,
            progress: Callable[[int, int], None] | None = None) -> np.ndarray:
        """Labels (K,) of the initial states ``states`` (K, n; SI) started at step counters
        ``steps`` (K,; default 0): attractor labels from 1, ``DIVERGED`` or ``UNDECIDED``.
        ``progress(done, total)`` after each chunk: ``done`` counts the labelled states
        and, for each state still searching, the share of ``max_periods`` it has run (a
        bound on its work: most settle far sooner), so the counter moves with every chunk,
        not only when states settle."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        count = len(states)
        start = np.zeros(count) if steps is None else np.asarray(steps, dtype=float)
        s = np.ascontiguousarray(np.column_stack([states, start]))
        initial = s.copy()
        labels = np.zeros(count, dtype=np.int64)
        self.spent = np.zeros(count, dtype=np.int64)
        traces = [_Trace() for _ in range(count)]
        active = np.arange(count)
        opts, done_periods = self.options, 0
        while active.size:
            chunk = min(opts.chunk, opts.max_periods - done_periods)
            block = np.ascontiguousarray(s[active])
            points = self.advance(block, chunk)
            s[active] = block
            self.periods += chunk * active.size
            self.spent[active] += chunk
            done_periods += chunk
            bad = self.is_diverged(points)
            keys = self.cell_keys(points)
            still = []
            for j, i in enumerate(active):
                if bad[j]:
                    labels[i] = DIVERGED
                    continue
                label = self._walk(traces[i], keys[j], points[j], i, initial[i], block[j])
                if label:
                    labels[i] = label
                    self._mark_basin(traces[i], label)
                    traces[i] = None
                else:
                    still.append(i)
            active = np.array(still, dtype=np.int64)
            if done_periods >= opts.max_periods:
                labels[active] = UNDECIDED
                active = active[:0]
            if progress is not None:
                searching = self.spent[active].sum() / opts.max_periods
                progress(int(np.count_nonzero(labels) + searching), count)
        return np.array([self.resolve(int(k)) for k in labels], dtype=np.int64)

    def _walk(self, trace: _Trace, keys: list[bytes], points: np.ndarray, index: int,
              initial: np.ndarray, last: np.ndarray) -> int:
        """Run the state machine of one trajectory over one chunk's points; its label, or 0
        while it searches."""
        opts = self.options
        for m, key in enumerate(keys):
            owner = self._owner.get(key, 0)
            if trace.recording is not None:
                rec = trace.recording
                if owner and owner != rec.label:  # the new attractor is a known one
                    known = self.attractor(owner)
                    for cell in rec.cells:
                        self._owner[cell] = owner
                    known.cells |= rec.cells
                    known.points += rec.points
                    del self.found[rec.label]
                    self._merged[rec.label] = owner
                    return owner
                if not owner:
                    self._owner[key] = rec.label
                    rec.cells.add(key)
                rec.points.append(points[m].copy())
                trace.record_left -= 1
                if trace.record_left == 0:  # the chunk's end state is on it too
                    rec.last_state = last.copy()
                    return rec.label
                continue
            if owner:
                trace.hit_run = trace.hit_run + 1 if trace.hit_label == owner else 1
                trace.hit_label = owner
                if trace.hit_run >= opts.hits:
                    return owner
            else:
                trace.hit_run, trace.hit_label = 0, 0
            if self.autonomous:
                basin = self.resolve(self._basin.get(key, 0))
                trace.basin_run = trace.basin_run + 1 if basin else 0
                if basin and trace.basin_run >= opts.basin_hits:
                    return basin
            if key in trace.cells:
                trace.revisits += 1
            else:
                trace.cells.add(key)
                trace.revisits = 0
            if trace.revisits >= opts.revisits:
                self._next += 1
                rec = Found(label=self._next, finder=index, finder_state=initial.copy(),
                            found_step=int(last[-1]))
                self.found[rec.label] = rec
                trace.recording, trace.record_left = rec, opts.record
        return 0

    def _mark_basin(self, trace: _Trace, label: int) -> None:
        """The cells a labelled trajectory crossed belong to its attractor's basin."""
        if not self.autonomous or trace.cells is None:
            return
        for cell in trace.cells:
            if cell not in self._owner:
                self._basin.setdefault(cell, label)
