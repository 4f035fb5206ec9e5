"""Attractor studies at scale: their blocks of initial states on an executor, each block
stored as it finishes, so an interrupted study resumes.

Each study is a plan (``plan_basins``, ``plan_fractions``, ``plan_continuation``: an
``analysis.integrate.study.StudyPlan`` that checks every input once, the device judged once
and the study at each value made once) run by the one runner
(``analysis.sweeps.runner.run_study``); ``basins_to_file``, ``fractions_to_file`` and
``continuation_to_file`` make and run one. A plan runs the studies of
``analysis.stability.attractors.studies`` with a ``StoredRunner``: the parent computes the
study's cell scale once (``AttractorStudy.settled_scale``) and hands it, with the System and
the mapper's settings (``StudyRef``), to every worker, so every block cuts the section into
the same cells; a worker maps its block with a fresh mapper (``AttractorStudy.map_block``)
and returns it as arrays; the parent stores it (``analysis.sweeps.store.PointStore``, in
``OUTPUT.parts``, key ``CALL-BLOCK``: CALL is the parameter value's index in a
continuation, 0 otherwise), then merges the blocks' attractors and describes each once
(``AttractorStudy.merge``). So the file does not depend on the executor or the number of
workers, and a run interrupted at any point, then re-run with the same arguments, gives the
file an uninterrupted run gives.

As sweeps: one process per output (a lock); a stored block that cannot be read is reported
(``on_damaged``) and mapped again; a re-run with another definition is refused while blocks
of the first are stored; a block whose integration fails is stored as failed (its states
``FAILED``, the message in the file's ``failed_blocks``); the folder is removed once the file
is written, and a study refused before its first block leaves nothing behind.
"""

from __future__ import annotations

import functools
import time
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

from analysis import errors
from analysis.errors import InputError, check_count
from analysis.integrate.cost import (
    COMPILED,
    KERNELS,
    CostEstimate,
    estimate_cost,
    process_seconds,
)
from analysis.integrate.kernels.placement import Placement
from analysis.integrate.study import Executor, Progress
from analysis.model import System, load_model
from analysis.stability.attractors.continuation import MATCH_DISTANCE, check_threshold
from analysis.stability.attractors.featurizing import FeatureOptions
from analysis.stability.attractors.label import LabelOptions
from analysis.stability.attractors.mapper import MapperOptions, Scale
from analysis.stability.attractors.sampling import Box, Range, check_pair
from analysis.stability.attractors.studies import basin_fractions, basins, global_continuation
from analysis.stability.attractors.study import AttractorStudy, Block, make_study
from analysis.sweeps.executors import SerialExecutor, run_with_progress
from analysis.sweeps.runner import run_study
from analysis.sweeps.store import PointStore
from analysis.sweeps.worker_counts import WorkerCounts


@dataclass(frozen=True)
class StudyRef:
    """What a worker needs to rebuild a study's map and mapper (picklable, hashable): the
    System by its model's name or spec path, balls, parameters and state; the period, the
    largest step, the mapper's settings and the parent's cell scale."""

    model: str
    structure: tuple[int, ...]
    parameters: tuple[tuple[str, float], ...]
    state: tuple[float, ...]
    period: str
    dt: float | None
    options: MapperOptions
    scale: tuple[float, ...]
    compiled: bool

    @classmethod
    def of(cls, study: AttractorStudy) -> StudyRef:
        system, model = study.system, study.system.model
        spec = model.spec_path
        source = spec if spec and Path(spec).is_absolute() and Path(spec).exists() \
            else model.name
        return cls(source, tuple(system.structure),
                   tuple((k, float(v)) for k, v in system.parameters.items()),
                   tuple(float(v) for v in system.state), str(study.period), study.dt,
                   study.options, tuple(float(v) for v in study.scale.size),
                   study.map.compiled)

    def study(self) -> AttractorStudy:
        model = load_model(self.model)
        system = System(model, self.structure, model.parameters(dict(self.parameters)),
                        np.array(self.state))
        return AttractorStudy(system, self.period, self.dt, self.options,
                              scale=Scale(np.array(self.scale)), compiled=self.compiled)


@functools.lru_cache(maxsize=4)
def study_of(ref: StudyRef) -> AttractorStudy:
    """The study of ``ref``, built once per worker process."""
    return ref.study()


def map_block_task(task: tuple) -> tuple[str, dict]:
    """A worker's task: (ref, key, states[, counts file, slot]) -> (key, the mapped block as
    arrays); with a counts file (``WorkerCounts``) the block's states mapped so far are
    written to its slot as the mapper goes."""
    ref, key, states, *where = task
    report = WorkerCounts.writer(*where) if where else None
    return key, study_of(ref).map_block(states, report).arrays()


class StoredRunner:
    """A ``study.Runner`` that maps the pending blocks on ``executor`` and stores each in
    ``store``; stored blocks of the same states are read back instead (one that cannot be
    read is reported to the store's ``on_damaged`` and mapped again). Its n-th call (a
    continuation's n-th value) keys its blocks ``n-BLOCK``. One pending block, or a serial
    executor: the blocks are mapped in this process (no worker to start)."""

    def __init__(self, store: PointStore, executor: Executor | None = None):
        self.store, self.executor = store, executor or SerialExecutor()
        self.calls = 0

    def stored(self, key: str, states: np.ndarray, done: set[str]) -> Block | None:
        """The stored block ``key`` of ``states``, or None (absent, damaged or of other
        states: mapped again)."""
        if key not in done:
            return None
        try:
            data = self.store.load(key)
            block = Block.from_arrays(data)
            same = np.array_equal(data["states"], states)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            (self.store.folder / f"{key}.npz").unlink(missing_ok=True)
            if self.store.on_damaged:
                self.store.on_damaged(key)
            return None
        return block if same else None

    def save(self, key: str, states: np.ndarray, arrays: dict) -> None:
        self.store.save(key, {**arrays, "states": states})

    def __call__(self, study: AttractorStudy, blocks: list[np.ndarray],
                 progress: Progress | None = None) -> list[Block]:
        call, self.calls = self.calls, self.calls + 1
        keys = [f"{call:04d}-{j:05d}" for j in range(len(blocks))]
        there = self.store.done()
        found = {k: self.stored(k, states, there)
                 for k, states in zip(keys, blocks, strict=True)}
        pending = [j for j, k in enumerate(keys) if found[k] is None]
        total = sum(len(b) for b in blocks)
        done = [total - sum(len(blocks[j]) for j in pending)]
        if len(pending) == 1 or isinstance(self.executor, SerialExecutor) \
                or study.in_process:  # the member kernel takes every core (or the GPU)
            for j in pending:
                def report(k: int, _: int, before: int = done[0]) -> None:
                    progress(before + k, total)

                block = study.map_block(blocks[j], report if progress else None)
                self.save(keys[j], blocks[j], block.arrays())
                found[keys[j]] = block
                done[0] += len(blocks[j])
        elif pending:
            self.on_workers(study, keys, blocks, pending, found, done, total, progress)
        return [found[k] for k in keys]

    def on_workers(self, study: AttractorStudy, keys: list[str], blocks: list[np.ndarray],
                   pending: list[int], found: dict, done: list[int], total: int,
                   progress: Progress | None) -> None:
        """The pending blocks on the executor's workers, each stored as it arrives; the
        counter moves as the workers label states (``WorkerCounts``)."""
        ref = StudyRef.of(study)  # the scale: computed here, once, for every worker
        slot = {keys[j]: i for i, j in enumerate(pending)}
        with WorkerCounts(self.store.folder, len(pending), total) as counts:
            def stored(task, result) -> None:
                key, states = task[1], task[2]
                self.save(key, states, result[1])
                with counts.lock:
                    found[key] = Block.from_arrays(result[1])
                    done[0] += len(states)
                    counts.finish(slot[key])

            tasks = [(ref, keys[j], blocks[j], *(counts.where(slot[keys[j]]) if progress
                                                  else ())) for j in pending]
            run_with_progress(self.executor, map_block_task, tasks,
                              lambda: counts.count(lambda: done[0]), total, progress, stored)


MAX_SEED = 2**63 - 1
"""The largest seed of the random initial states (a 64-bit signed integer, as the result
file stores it)."""


MAX_VALUES = 100_000
"""The most parameter values of a global continuation (``--param NAME:LO:HI:N``)."""


def check_value_count(field: str, count: int) -> int:
    """``count`` values of a continued parameter, bounded by ``MAX_VALUES`` before any
    value is made (``InputError`` naming ``field`` otherwise)."""
    return errors.check_count(field, count, 1, MAX_VALUES, " (values of the parameter)")


def check_branch_of(system: System, branch: xr.Dataset, parameter: str, field: str) -> None:
    """``InputError`` (naming ``field``) unless ``branch``, a continuation branch drawn
    beside a global continuation, is of ``system``'s model (its spec's SHA-256) and of the
    continued ``parameter``."""
    model = system.model
    name = branch.attrs.get("model")
    sha = branch.attrs.get("spec_sha256")
    if name != model.name or (sha is not None and sha != model.spec_sha256):
        other = f"model '{name}'" if name != model.name else "another spec of this model"
        raise InputError(f"{field}: the branch is of {other}; give a branch of model "
                         f"'{model.name}' (spec sha256 {model.spec_sha256[:12]})")
    if branch.attrs.get("param") != parameter:
        raise InputError(f"{field}: the branch is continued in '{branch.attrs.get('param')}'; "
                         f"give one continued in '{parameter}' (the --param)")


def check_sides(system: System, sides: Sequence[Range], field: str) -> None:
    """``InputError`` (naming ``field``) when a side of initial states reaches beyond the
    bounds of an initial state of ``system`` (``integrate.checks.check_start_range``: a
    displacement beyond the blow-up limit, a velocity beyond the velocity bound): such a
    state has blown up before its first steps (±1e300 m was mapped as 'diverged')."""
    from analysis.integrate.checks import check_start_range, start_limits

    limits = start_limits(system)
    for side in sides:
        side.check_state(system, field)
        check_start_range(system, side.coordinate, side.low, side.high, side.field or field,
                          limits)


PROBE_BLOCKS = (2, 8)
"""Initial states of the two timed blocks of the recurrence mapper's probe (after one
untimed state): their difference gives the cost of one more state of a block, the rest the
cost of a block's start (finding its attractors)."""
PROBE_WIDE_PERIODS = 2
"""Periods the probe runs a block as wide as the study's (the member kernel's time per
member and period at the width the study runs it)."""
PROBE_LIMIT = 20.0
"""The most the probe may cost (s) were its states to run their bound: above, no probe."""


def study_cost(system: System, members: int, *, workers: int | None = None,
               period: str | None = None, dt: float | None = None,
               options: MapperOptions | None = None, block: int | None = None,
               mapper: str = "auto", device: str = "auto",
               feature_options: FeatureOptions | None = None,
               sides: Sequence[Range] | None = None, **_: object) -> CostEstimate:
    """The cost of mapping ``members`` initial states (``analysis.integrate.cost``), said before
    the work: the featurizing mapper runs every member its transient and section periods;
    the recurrence mapper at most ``max_periods`` (most stop far earlier: a bound), and,
    given the ``sides`` of the states' box or grid, an expectation from a timed probe that
    maps a few states drawn in them (``recurrence_probe``). Takes the settings of the
    ``*_to_file`` functions (others, such as ``seed``, ignored). Both mappers step their
    states on the member kernels (``featurizing``, ``StroboscopicMap.advance``): the probe
    times those (``estimate_cost`` on ``KERNELS``; the compiled blocks where the study's map
    is not compiled)."""
    study = check_study(system, members, period, dt, options, None, block, mapper, device,
                        feature_options)
    return cost_of(study, members, workers=workers, block=block, sides=sides)


def cost_of(study: AttractorStudy, members: int, *, workers: int | None = None,
            block: int | None = None, sides: Sequence[Range] | None = None) -> CostEstimate:
    """``study_cost`` of a study already made (a plan's): ``members`` states in blocks of
    ``block`` (None: the study's default) on ``workers`` workers."""
    if study.mapper_kind == "features":
        periods, bound = study.feature_options.transient + study.feature_options.sections, False
    else:
        periods, bound = study.options.max_periods, True
    cost = estimate_cost(study.system, members, periods * study.map.steps, dt=study.map.dt,
                         workers=workers, what="initial states", bound=bound,
                         path=KERNELS if study.map.compiled else COMPILED,
                         compiled=study.map.compiled)
    block = block or study.default_block
    per_state = cost.steps * cost.step_seconds
    width = min(block, members)
    wide = width * PROBE_WIDE_PERIODS * study.map.steps * cost.step_seconds
    if bound and sides and (1 + sum(PROBE_BLOCKS)) * per_state + wide <= PROBE_LIMIT:
        expected, note = recurrence_probe(study, Box(tuple(sides)), members, block,
                                          cost.workers)
        cost = replace(cost, expected_seconds=expected, probe_note=note,
                       spent=process_seconds() if cost.spent else 0.0)  # the probe's too
    return cost


class TimedAdvance:
    """A stroboscopic map's ``advance`` that sums its wall time (s) and the member-periods
    it ran (the cost probe's split of a mapper's time into the member kernel's and the
    host's)."""

    def __init__(self, advance: Callable[[np.ndarray, int], np.ndarray]):
        self.advance, self.seconds, self.member_periods = advance, 0.0, 0

    def __call__(self, s: np.ndarray, n_periods: int) -> np.ndarray:
        start = time.perf_counter()
        try:
            return self.advance(s, n_periods)
        finally:
            self.seconds += time.perf_counter() - start
            self.member_periods += len(s) * int(n_periods)


def recurrence_probe(study: AttractorStudy, box: Box, members: int, block: int,
                     workers: int) -> tuple[float, str]:
    """The expected wall time (s) of mapping ``members`` states in blocks of ``block`` on
    ``workers`` workers, and the probe in words.

    One untimed state, then blocks of ``PROBE_BLOCKS`` states drawn uniformly in ``box`` (a
    fixed seed), each by a fresh mapper as the study's blocks are, their member kernel's
    time and member-periods counted apart from the host's walk (``TimedAdvance``). A block
    of k states costs ``start + k · each`` in member-periods and in host seconds (the two
    blocks' difference and rest). The kernel runs narrow blocks slower per member than the
    study's (0.44 s a state at 2–8 states, 0.18 s at 96, measured on vakharia2015), so the
    member-periods are priced by a run of ``PROBE_WIDE_PERIODS`` periods of a block as wide
    as the study's (``min(block, members)`` states; the member kernel runs on every core
    itself, so its time is not divided among the workers; the host's is)."""
    from analysis.integrate.simulate import SimulationError

    rng = np.random.default_rng(0)
    study.map_block(box.sample(study.system, 1, rng))  # the scale, the library: untimed
    host, periods, walls = [], [], 0.0
    for count in PROBE_BLOCKS:
        timed = TimedAdvance(study.map.advance)
        start = time.perf_counter()
        try:
            study.mapper(timed).map(box.sample(study.system, count, rng))
        except SimulationError:  # a failed block costs what it ran
            pass
        wall = time.perf_counter() - start
        host.append(max(wall - timed.seconds, 0.0))
        periods.append(timed.member_periods)
        walls += wall
    width = min(block, members)
    rows = np.column_stack([box.sample(study.system, width, rng), np.zeros(width)])
    start = time.perf_counter()
    study.map.advance(rows, PROBE_WIDE_PERIODS)
    wide = time.perf_counter() - start
    per_member_period = wide / (width * PROBE_WIDE_PERIODS)
    blocks = -(-members // block)

    def spread(values: list[float]) -> float:
        (k1, k2), (v1, v2) = PROBE_BLOCKS, values
        each = max((v2 - v1) / (k2 - k1), 0.0) or v2 / k2
        return blocks * max(v1 - k1 * each, 0.0) + members * each

    kernel = spread([float(p) for p in periods]) * per_member_period
    seconds = kernel + spread(host) / max(1, min(workers, blocks))
    return seconds, (f"a probe mapped {sum(PROBE_BLOCKS)} states and ran {width} for "
                     f"{PROBE_WIDE_PERIODS} periods in {walls + wide:.2g} s")


def system_definition(system: System) -> dict:
    """The System as a store's definition records it."""
    model = system.model
    return {"model": model.name, "spec_file": model.spec_file,
            "spec_sha256": model.spec_sha256, "structure": list(system.structure),
            "parameters": {k: float(v) for k, v in system.parameters.items()},
            "state": [float(v) for v in system.state]}


def check_study(system: System, members: int, period: str | None, dt: float | None,
                options: MapperOptions | None, label_options: LabelOptions | None,
                block: int | None, mapper: str = "auto", device: str | Placement = "auto",
                feature_options: FeatureOptions | None = None) -> AttractorStudy:
    """Every setting of a study of ``members`` states checked (``InputError``), before any
    work: the block size, the period and its section, the step, the memory, the mapper and
    the device (``study.make_study``). Returns the study (its scale not computed)."""
    return make_study(system, members, period=period, dt=dt, options=options,
                      label_options=label_options, mapper=mapper, device=device,
                      feature_options=feature_options, block=block)


def study_definition(study: AttractorStudy, kind: str, block: int | None, **extra) -> dict:
    """A store's definition: what makes its blocks (the mapper and, for the featurizing
    one, its settings and device: a block from the GPU equals the CPU's to round-off, not
    bit for bit)."""
    mapper = {} if study.mapper_kind == "recurrence" else {
        "mapper": study.mapper_kind, "device": study.device,
        "feature_options": asdict(study.feature_options)}
    return {"kind": kind, "system": system_definition(study.system),
            "period": str(study.period), "dt": study.dt, "compiled": study.map.compiled,
            "options": asdict(study.options), "label_options": asdict(study.label_options),
            "block": block or study.default_block, **mapper, **extra}


@dataclass(frozen=True)
class AttractorPlan:
    """A basins, fractions or global-continuation study, checked whole
    (``plan_basins``, ``plan_fractions``, ``plan_continuation``): an
    ``analysis.integrate.study.StudyPlan``. ``studies``: the checked study (at each
    parameter value of a continuation), each made once and run as it is; ``work``: the
    study function (``studies.basins`` …) with its arguments bound, called with the
    ``runner`` that stores its blocks and the ``progress``; ``sides``: the sides of the
    states' box or grid (the recurrence mapper's cost probe draws in them)."""

    kind: str
    output: Path
    definition: dict
    studies: tuple[AttractorStudy, ...]
    total: int
    """Initial states mapped (a continuation: ``samples + 16`` per value, a bound)."""
    sides: tuple[Range, ...]
    block: int | None
    work: Callable[..., xr.Dataset]
    lines: bool = False
    """The study reports its progress as lines (a continuation's values), not a counter."""
    unit: str = "states"

    @property
    def placement(self) -> Placement:
        """Where the featurizing mapper's members run, judged once (the first study's)."""
        return self.studies[0].placement

    def cost(self, workers: int) -> CostEstimate:
        """The cost of mapping ``total`` states on ``workers`` workers (``study_cost``)."""
        return cost_of(self.studies[0], self.total, workers=workers, block=self.block,
                       sides=self.sides)

    def run(self, store: PointStore, executor: Executor, progress: Progress | None,
            say: Callable[[str], None] | None) -> xr.Dataset:
        """The study's blocks on ``executor``, each stored as it finishes."""
        return self.work(runner=StoredRunner(store, executor),
                         progress=say if self.lines else progress)

    def stopped(self, store: PointStore, exc: BaseException) -> None:
        """The note of a study stopped part way: the blocks kept, counted in states."""
        kept = stored_states(store)
        store.stopped(exc, what=f"blocks ({kept:,} initial states)" if kept else
                      "blocks of initial states")


def grid_study(system: System, x: Range, y: Range, study: Callable[[int], AttractorStudy]
               ) -> AttractorStudy:
    """``study(members)`` of the ``x`` × ``y`` grid, its memory refusal worded for the
    grid's axes (no grid allocated)."""
    try:
        return study(x.num * y.num)
    except InputError as exc:  # the memory check counts states: name the grid's axes
        text = str(exc)
        head = f"samples: {x.num * y.num} initial states"
        if not text.startswith(head):
            raise
        raise InputError(f"x, y: a {x.num} x {y.num} grid: {x.num * y.num} initial states"
                         + text[len(head):].replace("use fewer", "use fewer grid values")
                         ) from None


def plan_basins(system: System, x: Range, y: Range, output: str | Path, *,
                period: str | None = None, dt: float | None = None,
                options: MapperOptions | None = None,
                label_options: LabelOptions | None = None, block: int | None = None,
                mapper: str = "auto", device: str | Placement = "auto",
                feature_options: FeatureOptions | None = None) -> AttractorPlan:
    """Every input of a basins study checked once, before any work (the grid, its sides,
    the study: ``check_study``, the device judged there once): its plan."""
    check_count("x", x.num)
    check_count("y", y.num)
    check_pair(system, x, y)
    check_sides(system, (x, y), "x, y")
    settings = dict(period=period, dt=dt, options=options, label_options=label_options)
    study = grid_study(system, x, y, lambda members: check_study(
        system, members, **settings, block=block, mapper=mapper, device=device,
        feature_options=feature_options))
    work = functools.partial(basins, system, x, y, **settings, block=block, study=study)
    return AttractorPlan("basins", Path(output),
                         study_definition(study, "basins", block, x=asdict(x), y=asdict(y)),
                         (study,), x.num * y.num, (x, y), block, work)


def plan_fractions(system: System, box: Box, samples: int, output: str | Path, *,
                   seed: int = 0, period: str | None = None, dt: float | None = None,
                   options: MapperOptions | None = None,
                   label_options: LabelOptions | None = None, block: int | None = None,
                   mapper: str = "auto", device: str | Placement = "auto",
                   feature_options: FeatureOptions | None = None) -> AttractorPlan:
    """Every input of a basin-fractions study checked once, before any work: its plan
    (``plan_basins``)."""
    check_count("samples", samples)
    errors.check_count("seed", seed, 0, MAX_SEED)
    box.check(system)
    check_sides(system, box.sides, "box")
    settings = dict(period=period, dt=dt, options=options, label_options=label_options)
    study = check_study(system, samples, **settings, block=block, mapper=mapper,
                        device=device, feature_options=feature_options)
    work = functools.partial(basin_fractions, system, box, samples, seed=seed, **settings,
                             block=block, study=study)
    return AttractorPlan("attractors", Path(output), study_definition(
        study, "attractors", block, box=box.text, samples=samples, seed=seed), (study,),
        samples, box.sides, block, work)


def plan_continuation(system: System, parameter: str, values: Sequence[float], box: Box,
                      samples: int, output: str | Path, *, seed: int = 0,
                      period: str | None = None, dt: float | None = None,
                      options: MapperOptions | None = None,
                      label_options: LabelOptions | None = None,
                      match_distance: float = MATCH_DISTANCE, block: int | None = None,
                      mapper: str = "auto", device: str | Placement = "auto",
                      feature_options: FeatureOptions | None = None) -> AttractorPlan:
    """Every input of a global continuation checked once, before any work: the study at
    each value made once (for ``samples`` + 16 states: the random ones and a bound on the
    previous value's attractors), on the placement of the first, and kept for the run."""
    if parameter not in system.model.parameter_names:
        raise InputError(f"param: '{parameter}' is not a parameter of model "
                         f"'{system.model.name}'; parameters: "
                         f"{', '.join(system.model.parameter_names)}", field="param")
    check_count("samples", samples)
    errors.check_count("seed", seed, 0, MAX_SEED)
    check_value_count("param", len(values))
    check_threshold(match_distance)
    box.check(system)
    check_sides(system, box.sides, "box")
    settings = dict(period=period, dt=dt, options=options, label_options=label_options)
    first = check_study(system.replace(**{parameter: float(values[0])}), samples + 16,
                        **settings, block=block, mapper=mapper, device=device,
                        feature_options=feature_options)
    studies = (first, *(check_study(system.replace(**{parameter: float(value)}),
                                    samples + 16, **settings, block=block, mapper=mapper,
                                    device=first.placement, feature_options=feature_options)
                        for value in values[1:]))
    work = functools.partial(global_continuation, system, parameter, values, box, samples,
                             seed=seed, **settings, match_distance=match_distance,
                             block=block, studies=studies)
    definition = study_definition(first, "attractor-continuation", block, param=parameter,
                                  values=[float(v) for v in values], box=box.text,
                                  samples=samples, seed=seed, match_distance=match_distance)
    definition["system"] = system_definition(system)  # the system continued, as given
    return AttractorPlan("attractor-continuation", Path(output), definition, studies,
                         (samples + 16) * len(values), box.sides, block, work, lines=True)


def stored_states(store: PointStore) -> int:
    """Initial states in the blocks ``store`` holds (an interrupted study's note counts
    them); a block that cannot be read counts none."""
    count = 0
    for key in store.done():
        try:
            with np.load(store.folder / f"{key}.npz", allow_pickle=False) as data:
                count += len(data["states"])
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            continue
    return count


def basins_to_file(system: System, x: Range, y: Range, output: str | Path, *,
                   period: str | None = None, dt: float | None = None,
                   options: MapperOptions | None = None,
                   label_options: LabelOptions | None = None, block: int | None = None,
                   executor: Executor | None = None, progress: Progress | None = None,
                   on_damaged: Callable[[str], None] | None = None, mapper: str = "auto",
                   device: str | Placement = "auto",
                   feature_options: FeatureOptions | None = None) -> xr.Dataset:
    """``studies.basins`` with its blocks on ``executor`` (default: serial; the featurizing
    mapper's blocks in this process, on the member kernel) and stored under ``output``;
    writes the netCDF file ``output`` and returns its Dataset (``plan_basins`` run by
    ``runner.run_study``)."""
    plan = plan_basins(system, x, y, output, period=period, dt=dt, options=options,
                       label_options=label_options, block=block, mapper=mapper,
                       device=device, feature_options=feature_options)
    return run_study(plan, executor, progress=progress, on_damaged=on_damaged)


def fractions_to_file(system: System, box: Box, samples: int, output: str | Path, *,
                      seed: int = 0, period: str | None = None, dt: float | None = None,
                      options: MapperOptions | None = None,
                      label_options: LabelOptions | None = None, block: int | None = None,
                      executor: Executor | None = None, progress: Progress | None = None,
                      on_damaged: Callable[[str], None] | None = None,
                      mapper: str = "auto", device: str | Placement = "auto",
                      feature_options: FeatureOptions | None = None) -> xr.Dataset:
    """``studies.basin_fractions`` with its blocks on ``executor``, stored under
    ``output``; writes ``output`` (``plan_fractions``)."""
    plan = plan_fractions(system, box, samples, output, seed=seed, period=period, dt=dt,
                          options=options, label_options=label_options, block=block,
                          mapper=mapper, device=device, feature_options=feature_options)
    return run_study(plan, executor, progress=progress, on_damaged=on_damaged)


def continuation_to_file(system: System, parameter: str, values: Sequence[float], box: Box,
                         samples: int, output: str | Path, *, seed: int = 0,
                         period: str | None = None, dt: float | None = None,
                         options: MapperOptions | None = None,
                         label_options: LabelOptions | None = None,
                         match_distance: float = MATCH_DISTANCE, block: int | None = None,
                         executor: Executor | None = None,
                         progress: Callable[[str], None] | None = None,
                         on_damaged: Callable[[str], None] | None = None,
                         mapper: str = "auto", device: str | Placement = "auto",
                         feature_options: FeatureOptions | None = None) -> xr.Dataset:
    """``studies.global_continuation`` with the blocks of each value on ``executor`` (the
    values one after the other: each is seeded from the previous one), stored under
    ``output``; writes ``output`` (``plan_continuation``). On a re-run the stored values'
    attractors are described again (in this process) to seed the next value."""
    plan = plan_continuation(system, parameter, values, box, samples, output, seed=seed,
                             period=period, dt=dt, options=options,
                             label_options=label_options, match_distance=match_distance,
                             block=block, mapper=mapper, device=device,
                             feature_options=feature_options)
    return run_study(plan, executor, say=progress, cost=False, on_damaged=on_damaged)
