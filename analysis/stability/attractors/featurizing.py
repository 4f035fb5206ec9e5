"""Attractors of a stroboscopic map found by features of fixed-time runs, for ensembles of
10⁵–10⁷ initial states (Attractors.jl's ``AttractorsViaFeaturizing``; Stender & Hoffmann,
Nonlinear Dyn. 2021, bSTAB).

Where the recurrence mapper (``mapper``) walks every trajectory on the host one chunk of
periods at a time, this mapper integrates a whole block of initial states in one call of
the member kernel (``analysis.integrate.kernels.run_members``: every core, or the GPU),
for a fixed time: ``transient`` forcing periods dropped, then ``sections`` section points
recorded per member. Each member becomes a feature vector and the vectors are clustered on
the host. On the cores the section points are in host memory and reduced there
(``features``); on a GPU (``DEVICE_FEATURES``) they are reduced on the device
(``members.section_features``, the same operations in the same order, so the same
numbers) and only the 2n features per member come back, not its K × n points (48 sections
of 4 states: 64 bytes instead of 1536). The few members whose points are still needed,
the first of each cluster (its ``Found.points``) and up to ``PERIOD_SAMPLE`` per cluster
(``periods``), are run again alone with their sections kept: a member's run does not depend
on the other members of its launch, so those are its points exactly, for at most
``PERIOD_SAMPLE`` × clusters members more per block.

- **features** (each coordinate divided by the study's ``Scale``, so in orbit sizes): the
  centroid of the member's section points and their extent (max − min) along every state
  coordinate, 2n numbers. A periodic-p orbit has p distinct points, so period-1 and
  period-3 orbits differ in extent even when their centroids are close; the extent halved is
  the amplitude on the section. The **period** (the smallest p ≤ ``max_period`` with
  ``|z_{k+p} − z_k| ≤ tolerance`` for every recorded k, 0: none) is computed too and kept
  per cluster (its most common value), but it is not a clustering coordinate: a member
  still converging would otherwise make a cluster of its own.
- **clustering** without N² memory: the features are cut into cells of
  ``1/resolution`` orbit sizes; the distinct occupied cells (np.unique) are joined when
  they touch (Chebyshev distance ≤ 1 cell, a k-d tree's pairs), and every connected group
  of cells is one attractor (DBSCAN with one point per core and a cell-sized radius). Cost
  and memory grow with the members and the occupied cells, never with their square.
- a member whose state leaves the blow-up bound (``StroboscopicMap.diverged``, the rule of
  ``simulate.check_bounded``), or is not finite, is ``DIVERGED``: labelled, never dropped.

Blocks of a study (``study.AttractorStudy.find``) are merged by the same rule
(``touching_groups`` on the clusters' cells), so a result depends on the states, the
settings and the block size, not on where a block ran. Each attractor is then described
as the recurrence mapper's are (``label.describe``: simulate, classify, λ1) from the first
member of its cluster.

**When to use which.** The recurrence mapper stops each trajectory as soon as it is
labelled (a few dozen periods on a stable orbit) and needs no choice of run length; it is
the default for small ensembles. The featurizing mapper runs every member for the same
fixed time, which a vector of cores or a GPU does at once; ``choose`` picks it for
``FEATURES_FROM`` members or more, or when the device is a GPU.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from analysis.errors import InputError
from analysis.integrate.ensemble import StroboscopicMap
from analysis.integrate.kernels.placement import Placement, on_gpu, place
from analysis.stability.attractors.mapper import DIVERGED, Found, Scale

MAPPERS = ("auto", "recurrence", "features")
"""The mapper names of ``choose`` (and of ``--mapper``)."""
FEATURES_FROM = 100_000
"""Initial states from which ``choose("auto", …)`` takes the featurizing mapper: below it
the recurrence mapper's early stopping costs fewer periods than a fixed-time run on one
process, and its memory (a few kB of cells per state in flight, ``study.check_memory``'s
4 GiB budget) still fits; above it the member kernel's width wins."""
FEATURE_BLOCK = {"cpu": 1 << 16, "gpu": 1 << 20}
"""Initial states per block of the featurizing mapper by device: a block's sections are
what the host holds at once (2¹⁶ × 48 sections × 4 states: 100 MB); the GPU wants 10⁶
members in flight to reach its throughput."""
PERIOD_SAMPLE = 64
"""Members per cluster whose period is detected (the cluster's period is their most common
one; every member's would cost a pass over all section points per period tried)."""
FEATURE_CHUNK = 1 << 15
"""Members per thread's block in ``features``."""
DEVICE_FEATURES = True
"""Whether a featurizing run on a GPU reduces its sections to features on the device and
copies back only those (False: every section point comes back and is reduced on the host,
the path before; the tests run both)."""
TRANSIENT_CHUNK = 64
"""Periods per call of the map when no member kernel is at hand (the transient's points
are checked for blow-up chunk by chunk, then dropped)."""


@dataclass(frozen=True)
class FeatureOptions:
    """The settings of the featurizing mapper (periods are forcing periods of the map)."""

    transient: int = 200
    """Periods integrated and dropped before the section points are recorded."""
    sections: int = 48
    """Section points recorded per member (the features' sample)."""
    resolution: int = 20
    """Feature cells per orbit size: two members are one attractor when their features are
    joined by cells that touch. Coarser merges close attractors; finer splits one whose
    members have not all settled."""
    max_period: int = 12
    """Longest period looked for (at most ``sections // 2``)."""
    tolerance: float = 1e-4
    """Largest difference, in orbit sizes, of two points one period apart on a periodic
    orbit."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "tolerance":
                if not (isinstance(value, (int, float)) and 0 < value < 1):
                    raise InputError(f"tolerance: must be a number in (0, 1), got {value!r}")
                continue
            low = 0 if f.name == "transient" else 1
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                    or value < low:
                raise InputError(f"{f.name}: must be a whole number >= {low}, got {value!r}")
        if self.sections < 2 * self.max_period:
            raise InputError(f"sections: must be at least 2 × max_period "
                             f"({2 * self.max_period}), got {self.sections}")


def choose(mapper: str, device: str | Placement, members: int) -> str:
    """``recurrence`` or ``features``: ``mapper`` itself, or for ``auto`` the featurizing
    mapper when ``members`` >= ``FEATURES_FROM`` or ``device`` (a ``Placement``, or a
    resolved name) is a GPU. ``InputError`` for an unknown name, or for the recurrence
    mapper on a GPU (it walks each trajectory on the host)."""
    if mapper not in MAPPERS:
        raise InputError(f"mapper: must be one of {', '.join(MAPPERS)}, got {mapper!r}")
    gpu = on_gpu(device)
    if mapper == "auto":
        return "features" if gpu or members >= FEATURES_FROM else "recurrence"
    if mapper == "recurrence" and gpu:
        raise InputError("mapper: the recurrence mapper runs on the CPU; use --mapper "
                         "features (or auto) with --device gpu")
    return mapper


@dataclass
class Record:
    """What a block's fixed-time run returns: section points (M, K, n; SI units; None when
    only their features came back), a blow-up flag (M,), the final state (M, n) at step
    ``steps`` and, from a device's reduction, the features (M, 2n; SI units, not yet
    divided by the scale: ``members.section_features``)."""

    sections: np.ndarray | None
    diverged: np.ndarray
    final: np.ndarray
    steps: int
    features: np.ndarray | None = None


Recorder = Callable[..., Record]
"""``record(smap, states, options, progress=None, sections=False)``: a block's fixed-time
run; ``progress(done, total)`` (members) while it runs; ``sections``: the section points
are wanted (otherwise a recorder may return the features only)."""


def schedule_of(smap: StroboscopicMap, options: FeatureOptions):
    """The member kernel's ``Schedule`` of a block: ``transient`` periods, then
    ``sections`` section points one period apart (N steps of h = T/N, as
    ``StroboscopicMap.advance``)."""
    from analysis.integrate.kernels import Schedule

    return Schedule(options.transient * smap.steps, smap.steps, options.sections,
                    keep_sections=True)


def kernel_record(smap: StroboscopicMap, states: np.ndarray, options: FeatureOptions,
                  device: str | Placement = "cpu",
                  progress: Callable[[int, int], None] | None = None,
                  features: bool = False) -> Record:
    """The fixed-time run of ``states`` (M, n; t = 0) on the member kernel
    (``analysis.integrate.kernels.run_members`` on ``device``, a ``Placement`` taken as it
    is; on the CPU ``progress`` moves every ~0.5 s of work, ``members.PROGRESS_SECONDS``).
    ``features`` on a GPU: the sections reduced on the device, only the features come back
    (``Record.sections`` None); on the CPU ``features`` is ignored (the sections are on the
    host already: ``features`` reduces them there)."""
    from analysis.integrate.kernels import run_members

    reduce = features and on_gpu(device)
    out = run_members(smap.system, states, None, smap.dt, schedule_of(smap, options),
                      device=device, progress=progress, features=reduce)
    sections = None if reduce else np.asarray(out.sections, dtype=float)
    # the kernel checks every step by the blow-up predicate of simulate (its sections after
    # a blow-up are NaN): no pass over the sections here
    bad = np.asarray(out.diverged_at) >= 0
    steps = (options.transient + options.sections) * smap.steps
    return Record(sections, bad, np.asarray(out.final, dtype=float), steps, out.features)


def map_record(smap: StroboscopicMap, states: np.ndarray, options: FeatureOptions,
               progress: Callable[[int, int], None] | None = None,
               sections: bool = True) -> Record:
    """The same run through ``StroboscopicMap.advance`` (the lane kernel or the RK4 blocks,
    one process): the path of a model whose member kernel cannot be built on the CPU.
    Every member advances together: ``progress`` counts the members times the share of
    the periods run, after each ``TRANSIENT_CHUNK`` periods. Its section points always
    come back (``sections`` is the ``Recorder``'s keyword)."""
    s = np.ascontiguousarray(np.column_stack([states, np.zeros(len(states))]))
    bad = np.zeros(len(states), dtype=bool)
    left, periods = options.transient, options.transient + options.sections
    while left:
        chunk = min(left, TRANSIENT_CHUNK)
        bad |= smap.diverged(smap.advance(s, chunk))
        left -= chunk
        if progress is not None:
            progress(len(states) * (options.transient - left) // periods, len(states))
    points = smap.advance(s, options.sections)
    bad |= smap.diverged(points)
    return Record(points, bad, s[:, :-1].copy(), int(s[0, -1]) if len(s) else 0)


def resolve(device: str | Placement, members: int, smap: StroboscopicMap,
            options: FeatureOptions) -> Placement:
    """The ``Placement`` of a featurizing run of ``members`` states
    (``kernels.placement.place``, the study's one judgement of its device: ``DeviceError``
    for an unknown name or a missing GPU; a ``Placement`` is kept)."""
    return place(device, members, steps=(options.transient + options.sections) * smap.steps)


def recorder(smap: StroboscopicMap, device: str | Placement, block: int,
             options: FeatureOptions) -> Recorder:
    """The recorder of a placed ``device`` (a ``Placement``, or ``cpu`` or ``gpu``), checked
    before any work: ``block`` members' results must fit (``kernels.check_fits``,
    ``InputError``) and the model's member kernel must build (a one-step run). On the CPU a
    model whose kernel cannot be written or built falls back to ``map_record``; on the GPU
    that is an ``InputError`` with the reason (``members.unbuildable``). On a GPU with
    ``DEVICE_FEATURES`` the recorder returns the device's features only, unless asked for
    the sections (a few members run again: ``FeaturizingMapper.map``)."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels import Schedule, Unsupported, check_fits, run_members
    from analysis.integrate.kernels.members import unbuildable

    system = smap.system
    device = place(device, block)  # a Placement as it is; a name placed once, here
    reduce = device.gpu and DEVICE_FEATURES
    check_fits(device, block, schedule_of(smap, options), system.n_state,
               len(system.model.parameter_names), reduce)
    try:
        run_members(system, system.state[None, :], None, smap.dt, Schedule(0, 1, 1),
                    device=device)
    except (Unsupported, CompileError) as exc:
        if device.gpu:
            raise unbuildable(system, device.kind, exc) from None
        return map_record
    def record(smap: StroboscopicMap, states: np.ndarray, options: FeatureOptions,
               progress: Callable[[int, int], None] | None = None,
               sections: bool = False) -> Record:
        return kernel_record(smap, states, options, device, progress,
                             features=reduce and not sections)

    return record


def features(sections: np.ndarray, scale: Scale) -> np.ndarray:
    """(M, 2n) features of section points (M, K, n; SI): the centroid and the extent
    (max − min) of each coordinate, in orbit sizes (``scale``). Blocks of
    ``FEATURE_CHUNK`` members on every core (``kernels.cpu.cores``; NumPy's loops release
    the GIL): 10⁶ members × 24 sections took 1.8 s on one core of the H200's host."""
    from analysis.integrate.kernels.cpu import cores

    m, n = len(sections), sections.shape[2]
    if m <= FEATURE_CHUNK:
        return block_features(sections, scale)
    out = np.empty((m, 2 * n))

    def part(start: int) -> None:
        stop = min(m, start + FEATURE_CHUNK)
        out[start:stop] = block_features(sections[start:stop], scale)

    with ThreadPoolExecutor(max(1, min(cores(), -(-m // FEATURE_CHUNK)))) as pool:
        list(pool.map(part, range(0, m, FEATURE_CHUNK)))
    return out


def block_features(sections: np.ndarray, scale: Scale) -> np.ndarray:
    """``features`` of one block, in this thread: ``members.section_features`` (what a GPU
    computes on the device) divided by the scale (``scaled``)."""
    from analysis.integrate.kernels.members import section_features

    return scaled(section_features(np, sections), scale)


def scaled(reduced: np.ndarray, scale: Scale) -> np.ndarray:
    """Features (M, 2n; SI units, ``members.section_features``) in orbit sizes."""
    return reduced / np.concatenate([scale.size, scale.size])


def periods(sections: np.ndarray, scale: Scale, options: FeatureOptions) -> np.ndarray:
    """(M,) the smallest period p <= ``max_period`` with every recorded point within
    ``tolerance`` orbit sizes of the point p periods later; 0 where none is."""
    z = sections / scale.size
    out = np.zeros(len(z), dtype=np.int64)
    for p in range(1, options.max_period + 1):
        close = np.max(np.abs(z[:, p:] - z[:, :-p]), axis=(1, 2)) <= options.tolerance
        out[(out == 0) & close] = p
    return out


def touching_groups(cells: np.ndarray) -> np.ndarray:
    """Group of every row of ``cells`` (m, d int64): rows in cells that touch (Chebyshev
    distance <= 1), directly or through others, share a group; groups numbered 0, 1, … in
    the order of their first row. Memory: the distinct cells and their touching pairs."""
    if not len(cells):
        return np.zeros(0, dtype=np.int64)
    unique, inverse = distinct_rows(cells)
    pairs = cKDTree(unique).query_pairs(r=1.0, p=np.inf, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(unique), len(unique)))
    _, component = connected_components(graph, directed=False)
    return by_first(component[inverse])


def distinct_rows(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(cells, axis=0, return_inverse=True)`` (rows in lexicographic order), by
    one int64 key per row when the cells' box has fewer than 2⁶² cells (a 1-D sort: 10⁶
    rows in a tenth of a second, against seconds for the row-wise one)."""
    low = cells.min(axis=0)
    span = [int(v) for v in cells.max(axis=0) - low + 1]
    if np.prod(span, dtype=object) >= 2**62:  # exact (Python integers)
        unique, inverse = np.unique(cells, axis=0, return_inverse=True)
        return unique, inverse.ravel()
    weights = np.array([int(np.prod(span[i + 1:], dtype=object)) for i in range(len(span))],
                       dtype=np.int64)
    key = (cells - low) @ weights
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    return cells[first], inverse.ravel()


def by_first(groups: np.ndarray) -> np.ndarray:
    """``groups`` (any ids) renumbered 0, 1, … in the order of their first occurrence."""
    _, first, inverse = np.unique(groups, return_index=True, return_inverse=True)
    return np.argsort(np.argsort(first))[inverse.ravel()]


def feature_cells(values: np.ndarray, resolution: int) -> np.ndarray:
    """Feature vectors (m, d; orbit sizes) as int64 cell indices."""
    index = np.floor(values * resolution)
    return np.nan_to_num(index, nan=0.0, posinf=0.0, neginf=0.0).astype(np.int64)


class FeaturizingMapper:
    """Labels initial states by clustering features of fixed-time runs (see the module).
    ``record(smap, states, options)`` runs a block (``kernel_record``, ``map_record``)."""

    def __init__(self, smap: StroboscopicMap, scale: Scale, options: FeatureOptions | None = None,
                 record: Recorder = map_record):
        self.smap, self.scale = smap, scale
        self.options = options or FeatureOptions()
        self.record = record
        self.found: dict[int, Found] = {}
        self.period_of: dict[int, int] = {}
        """Label -> the most common detected period of its members (0: not periodic)."""
        self.spent = np.zeros(0, dtype=np.int64)
        """Periods integrated per initial state in the last ``map`` call."""
        self.rerun = 0
        """Members run again in the last ``map`` call for their section points (none when
        the block's run brought its sections back; ``points_of``)."""

    def map(self, states: np.ndarray,
            progress: Callable[[int, int], None] | None = None) -> np.ndarray:
        """Labels (M,) of the initial states ``states`` (M, n; SI, t = 0): attractor labels
        from 1 in the order of their first member, or ``DIVERGED``."""
        states = np.atleast_2d(np.asarray(states, dtype=float))
        opts = self.options
        total = len(states)
        running = None if progress is None else \
            (lambda done, _: progress(min(done, total - 1), total))  # labels come last
        run = self.record(self.smap, states, opts, running)
        labels = np.full(len(states), DIVERGED, dtype=np.int64)
        ok = np.flatnonzero(~run.diverged)
        if run.sections is None:  # the device's features: only the scale is applied here
            values = scaled(run.features[ok], self.scale)
        else:
            kept = run.sections if len(ok) == len(states) else run.sections[ok]  # no copy
            values = features(kept, self.scale)
        cells = feature_cells(values, opts.resolution)
        groups = touching_groups(cells)
        labels[ok] = groups + 1
        self.found, self.period_of = {}, {}
        order = np.argsort(groups, kind="stable")  # each group's members, in index order
        ends = np.cumsum(np.bincount(groups))
        clusters = [order[(ends[g - 1] if g else 0):end] for g, end in enumerate(ends)]
        samples = [ok[members[:PERIOD_SAMPLE]] for members in clusters]  # first one first
        points, at = self.points_of(states, run, samples)
        for g, (members, sample) in enumerate(zip(clusters, samples, strict=True)):
            i = int(sample[0])
            label = g + 1
            self.found[label] = Found(
                label=label, cells={row.tobytes() for row in distinct_rows(cells[members])[0]},
                points=list(points[at(i)]), finder=i,
                finder_state=np.append(states[i], 0.0), found_step=run.steps,
                last_state=np.append(run.final[i], float(run.steps)))
            detected = periods(points[at(sample)], self.scale, opts)
            self.period_of[label] = int(np.bincount(detected).argmax())
        self.spent = np.full(len(states), opts.transient + opts.sections, dtype=np.int64)
        if progress is not None:
            progress(len(states), len(states))
        return labels


    def points_of(self, states: np.ndarray, run: Record, samples: list[np.ndarray]):
        """(sections, at): section points of the members in ``samples`` (one index array
        per cluster) and their rows in it (``at(indices)``). A run that brought its
        sections back gives them all; one that brought only features (a GPU's reduction)
        runs just these members again with their sections kept: at most ``PERIOD_SAMPLE``
        × clusters members (``rerun`` counts them), exactly the points they had in the
        block's run (a member's run does not depend on the other members of its launch)."""
        if run.sections is not None:
            self.rerun = 0
            return run.sections, lambda i: i
        wanted = np.unique(np.concatenate(samples)) if samples else np.zeros(0, dtype=int)
        self.rerun = len(wanted)
        if not len(wanted):
            return np.zeros((0, self.options.sections, states.shape[1])), lambda i: i
        again = self.record(self.smap, states[wanted], self.options, sections=True)
        return again.sections, lambda i: np.searchsorted(wanted, i)


def merge_groups(cell_sets: Sequence[np.ndarray]) -> np.ndarray:
    """Group of every cluster given by its cells (a list of (m_i, d) int64 arrays, one per
    cluster, in block order): clusters whose cells touch are one; groups numbered in the
    order of their first cluster."""
    if not cell_sets:
        return np.zeros(0, dtype=np.int64)
    rows = touching_groups(np.concatenate(cell_sets))
    starts = np.concatenate([[0], np.cumsum([len(c) for c in cell_sets])[:-1]])
    # a cluster's cells are one group already (clustered by the same rule); none is empty
    return by_first(rows[starts])


__all__ = ["FEATURES_FROM", "FEATURE_BLOCK", "MAPPERS", "FeatureOptions", "FeaturizingMapper",
           "Record", "by_first", "choose", "features", "kernel_record", "map_record",
           "merge_groups", "periods", "recorder", "resolve", "schedule_of", "touching_groups"]
