"""Stability-chart points in one pass: the states and the tangent of λ1 integrated together.

``chart_points`` (the chart's) runs the points of one model and balls with λ1 as members of
one call of the member kernels (``analysis.integrate.kernels``, the tangent variant, on every
core or the GPU: ``kernel_points``): each point's step is the largest h <= dt dividing its
section period (``kernels.section_step``), so its section points are states at steps, its
tangent is renormalised once per section, and only the sections, the logs and the extremes
leave the kernel. Non-chaotic points keep their class and λ1 within its interval against
``one_pass`` (``tests/integrate/test_kernel_chart.py``).

``one_pass`` (``chart_point``) is the former point, kept as the reference and for points
without λ1, with the same signature and result as the two-pass point of
``analysis.sweeps.chart``. One run covers the setting's transient and record:

1. the states alone (the model's compiled RK4 blocks, ``compiled.library``) up to the start
   of the tangent transient;
2. the states with one tangent vector, renormalised every ``RENORM_EVERY`` steps, in
   compiled blocks (``lyapunov.tangent_block`` with its states, one library per model and
   balls in the cache of ``analysis.integrate.compiled``); the logs of the first
   ``lyapunov.default_lengths`` tangent transient (a tenth of the spec's transient) are
   discarded, those of the record averaged (λ1 and its batch-means interval as in
   ``lyapunov``).

As the blocks come back, the record's extremes (amplitudes, orbit size) are updated and the
few states around each section time kept: the section points are then those of
``poincare_section`` on the full record (the same samples and interpolation). The steps
are the same RK4 steps at the same times k·dt as ``simulate``'s, so the states are the
two-pass run's bit for bit and non-chaotic points classify alike.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import cache

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.forcing import run_unbalance
from analysis.integrate.compiled import (
    CompileError,
    Runner,
    compiled_functions,
    library,
    test_state,
)
from analysis.integrate.kernels import (
    Schedule,
    Unsupported,
    blow_up_error,
    run_members,
    section_step,
)
from analysis.integrate.kernels.members import check_kernels
from analysis.integrate.kernels.placement import Placement, place
from analysis.integrate.plan import RunPlan, check_times
from analysis.integrate.simulate import (
    blow_up_limit,
    check_bounded,
    extremes,
)
from analysis.model import Model, Structure, System
from analysis.provenance import (
    completed_attrs,
    displacement_names,
    run_attrs,
    state_variable_attrs,
    to_dataset,
)
from analysis.signal.poincare import parse_section, period_of, poincare_section
from analysis.stability.classify import (
    Classification,
    classify_section,
    default_section,
    exponents_of_run,
    nature_code,
)
from analysis.stability.lyapunov import (
    BLOCKS,
    batch_ci95,
    default_lengths,
    running_mean,
    tangent_block,
)
from analysis.sweeps.classes import class_codes
from analysis.sweeps.grid import Axis, Setting, axis_bearing
from analysis.sweeps.store import stacked

RENORM_EVERY = 100
"""RK4 steps between renormalisations of the tangent vector (as ``lyapunov``'s default)."""
RENORMS_PER_CALL = (100, 10, 1)
"""Renormalisations per call of the compiled blocks, largest first (10⁴, 10³, 10² steps)."""
ANGLE_ADDITION = False
"""Whether the tangent part takes the step of ``tangent.Carry.angle_addition`` (the shaft
angle of an RK4 step's later stages by angle addition: two sin/cos pairs fewer per step,
in the lanes and the scalar blocks alike). Off: it changes quasi-periodic points of the
benchmark chart by up to 1e-7 relative in λ1 (1.6e-3 at a point of λ1 ≈ 20 ± 11 1/s below
the chaos floor), beyond the 1e-12 that a speed-up may change a non-chaotic result
(docs/performance.md, "Two points per vector register")."""
@cache
def chart_blocks(model: Model, structure: Structure,
                 compiled: bool = True) -> dict[int, ca.Function]:
    """The blocks of ``RENORMS_PER_CALL`` renormalisations, ``(s, p, h, t0) -> (s', logs,
    Z)`` with ``s = [z; k; v]`` (v the tangent vector) and Z ``[z; k]`` after every step
    (``lyapunov.tangent_block``), compiled into one library of the cache, or in the VM."""
    fns = [tangent_block(model, structure, 1, RENORM_EVERY, size, with_states=True,
                         angle_addition=ANGLE_ADDITION) for size in RENORMS_PER_CALL]
    n = model.n_state
    s = np.concatenate([test_state(n), [3.0], np.eye(n)[:, 0]])
    args = (s, model.parameter_vector(model.defaults),
            float(model.simulation_defaults["dt"]), 0.1)
    built = compiled_functions(fns, [args if size == 1 else None for size in RENORMS_PER_CALL],
                               compiled)
    return dict(zip(RENORMS_PER_CALL, built, strict=True))


class _Caller:
    """Calls one block through preallocated buffers (no conversion per call)."""

    def __init__(self, fn: ca.Function, s: np.ndarray, p: np.ndarray, h: float):
        self.s, self.args = s, (s, p, np.array([h]), np.zeros(1))
        self.buf, self._call = fn.buffer()
        self.s_out = np.empty(fn.size1_out(0))
        self.logs = np.empty(fn.size2_out(1))
        self.states = np.empty((fn.size2_out(2), fn.size1_out(2)))  # column-major (n+1) × m
        for i, arr in enumerate(self.args):
            self.buf.set_arg(i, memoryview(arr))
        for i, arr in enumerate((self.s_out, self.logs, self.states)):
            self.buf.set_res(i, memoryview(arr))

    def __call__(self) -> None:
        self._call()
        self.s[:] = self.s_out


@dataclass
class _Record:
    """What a chart point keeps of its run as the blocks come back: the extremes of every
    state variable from step ``first`` on, the states at the ``needed`` steps, and the
    blow-up check of ``simulate``."""

    first: int
    needed: np.ndarray
    dt: float
    limit: float
    pairs: list
    low: np.ndarray
    high: np.ndarray
    samples: dict[int, np.ndarray] = field(default_factory=dict)

    def take(self, rows: np.ndarray) -> None:
        """``rows[j] = [z…, k]``: the state (SI units) after step k."""
        n = len(self.low)
        k = rows[:, n].astype(np.int64)
        bounds = extremes(rows, n)
        check_bounded(rows[:, :n].T, k * self.dt, self.limit, self.pairs, bounds)  # every step
        if k[0] < self.first:  # the block starts before the record
            kept = rows[np.searchsorted(k, self.first):, :n]
            bounds = extremes(kept, n) if len(kept) else None
        if bounds is not None:
            self.low = np.minimum(self.low, bounds[0])
            self.high = np.maximum(self.high, bounds[1])
        lo, hi = np.searchsorted(self.needed, (k[0], k[-1] + 1))
        for step in self.needed[lo:hi]:
            self.samples[int(step)] = rows[step - k[0], :n].copy()


@dataclass(frozen=True)
class _Schedule:
    """Steps of one chart point: the record from ``first`` to ``last`` (the samples of the
    two-pass run), the tangent from ``start`` over ``renorms`` renormalisations of which
    the last ``averaged`` are averaged, and the states alone after that up to ``last``."""

    first: int
    last: int
    start: int
    renorms: int
    averaged: int


def _schedule(run: RunPlan, tangent_transient: float) -> _Schedule:
    """The steps of a planned run whose transient is dropped (the samples ``simulate``
    keeps: ``run.first`` to ``run.n_steps``), λ1 averaged over the whole renormalisations of
    the record after ``tangent_transient`` s of discarded ones."""
    dt, last, first = run.dt, run.n_steps, run.first
    averaged = (last - first) // RENORM_EVERY
    averaged -= averaged % BLOCKS
    if averaged < BLOCKS:
        raise InputError(f"chart point: the record ({(last - first) * dt:.3g} s) is shorter "
                         f"than {BLOCKS} renormalisations of the tangent "
                         f"({BLOCKS * RENORM_EVERY * dt:.3g} s)")
    discarded = math.ceil(tangent_transient / (RENORM_EVERY * dt) - 1e-9)
    renorms = min(averaged + discarded, last // RENORM_EVERY)
    start = last - renorms * RENORM_EVERY
    return _Schedule(first, last, start, renorms, averaged)


def _section_steps(plan: _Schedule, dt: float, period: float) -> np.ndarray:
    """The record's steps whose states ``poincare_section`` reads for the section of
    ``period`` s: the samples i − 1 … i + 2 around each section time (t_i ≤ t_k < t_i+1,
    the derivatives of the interpolation included) and the record's ends."""
    k = np.arange(math.floor(plan.first * dt / period) - 1,
                  math.ceil(plan.last * dt / period) + 2)
    t_k = k * period
    i = np.floor(t_k / dt).astype(np.int64)
    i += (i + 1) * dt <= t_k
    i -= i * dt > t_k
    steps = np.concatenate([(i[:, None] + np.arange(-1, 3)).ravel(), [plan.first, plan.last]])
    return np.unique(np.clip(steps, plan.first, plan.last))


def _run_tangent(blocks: dict[int, ca.Function], p: np.ndarray, z0: np.ndarray,
                 dt: float, plan: _Schedule, record: _Record) -> np.ndarray:
    """The states with one tangent vector from step ``plan.start`` over ``plan.renorms``
    renormalisations, fed to ``record``; returns the logs of every renormalisation."""
    n = len(z0)
    s = np.concatenate([z0, [plan.start], np.eye(n)[:, 0]])
    callers = {size: _Caller(fn, s, p, dt) for size, fn in blocks.items()}
    logs, left = [], plan.renorms
    for size, caller in callers.items():
        count, left = divmod(left, size)
        for _ in range(count):
            caller()
            record.take(caller.states)
            logs.append(caller.logs.copy())
    return np.concatenate(logs) if logs else np.empty(0)


@dataclass(frozen=True)
class PointResult:
    """A chart point's verdict and measures."""

    classification: Classification
    lyapunov: float
    """λ1 of the record, 1/s (NaN when not computed)."""
    ci95: float
    """Its 95 % half-width (batch means), 1/s."""
    ptp: dict[str, float]
    """Peak-to-peak of every state variable over the record (SI units)."""
    displacements: tuple[str, ...]
    """The first body's translations (``analysis.provenance.displacement_names``)."""
    points: xr.Dataset
    """The Poincaré points of the classification (``poincare_section`` of the record)."""


@dataclass
class _Point:
    """A chart point under way: its run's attributes, plan and record, and the state after
    the states-alone part (at step ``plan.start``)."""

    system: System
    attrs: dict
    section: str
    schedule: _Schedule
    record: _Record
    z: np.ndarray
    tangent: bool


def _prepare(system: System, duration: float, transient: float, dt: float,
             section: str | None, tangent: bool, compiled: bool,
             states_alone: bool = True) -> _Point:
    """Check the run (``RunPlan.make``; a coarse step was reported by the grid's check),
    schedule it and, with ``states_alone``, integrate the states alone up to the tangent's
    start (or to the end without ``tangent``); else ``z`` is the initial state, at step 0
    (``_run_states_lanes`` does that part)."""
    model, structure, values = system.model, system.structure, dict(system.parameters)
    run = RunPlan.make(system, duration=duration, transient=transient, dt=dt,
                       warn=lambda message: None)
    attrs = completed_attrs(system, **run.settings())
    section = section or default_section(attrs)
    plan = _schedule(run, default_lengths(model)[2] if tangent else 0.0)
    n = model.n_state
    record = _Record(plan.first, _section_steps(plan, dt, period_of(attrs, section)), dt,
                     blow_up_limit(model, values), model.centre_indices(), np.full(n, np.inf),
                     np.full(n, -np.inf))
    lib, z = library(model, structure, compiled), np.asarray(system.state, float)
    start = plan.start if tangent else plan.last
    if start > 0 and states_alone:
        for _, rows in Runner(lib, system.p, dt).blocks(z, start):  # k counted from step 0
            record.take(rows)
        z = rows[-1, :n].copy()
    return _Point(system, attrs, section, plan, record, z, tangent)


def _finish(point: _Point, logs: np.ndarray | None) -> PointResult:
    """The point's verdict from its record and, with a tangent, the logs of its
    renormalisations (λ1 and its interval from the last ``plan.averaged``)."""
    model, record, plan = point.system.model, point.record, point.schedule
    dt = point.attrs["dt"]
    lam = ci = np.nan
    if point.tangent:
        averaged, interval = logs[None, -plan.averaged:], RENORM_EVERY * dt
        lam = float(running_mean(averaged, interval)[0, -1])
        ci = float(batch_ci95(averaged, interval)[0])
    steps = np.array(sorted(record.samples))
    run = to_dataset(steps * dt, np.stack([record.samples[k] for k in steps], axis=1),
                     point.attrs, model)

    def largest() -> tuple[float, float]:
        if point.tangent:
            return lam, ci
        found = exponents_of_run(run, None)
        return float(found.exponents[0]), float(found.ci95[0])

    ptp = dict(zip(model.state_names, (record.high - record.low).tolist(), strict=True))
    points = poincare_section(run, point.section)
    return PointResult(classify_section(points, ptp, largest), lam, ci, ptp,
                       displacement_names(run), points)


def one_pass(system: System, duration: float, transient: float, dt: float,
             section: str | None, tangent: bool = True, compiled: bool = True) -> PointResult:
    """Classify ``system``'s motion on ``section`` (None: ``default_section``) after
    ``transient`` s of a ``duration`` s run (RK4 step ``dt`` s) in one pass; with
    ``tangent``, λ1 and its interval from the same pass, else λ1 only when the section
    points cannot decide (``classify``'s own, from the final state)."""
    point = _prepare(system, duration, transient, dt, section, tangent, compiled)
    return _finish(point, _scalar_tangent(point, compiled) if tangent else None)


def _scalar_tangent(point: _Point, compiled: bool) -> np.ndarray:
    """The tangent part of one point in the scalar blocks (``chart_blocks``): the logs of
    every renormalisation, its states fed to the point's record."""
    system = point.system
    return _run_tangent(chart_blocks(system.model, system.structure, compiled), system.p,
                        point.z, point.attrs["dt"], point.schedule, point.record)


@dataclass(frozen=True)
class _KernelPoint:
    """A chart point's run on the member kernels: its attrs, section and period T (s),
    step h = T/N (s, ``kernels.section_step``), the record's ``count`` sections from
    ``first`` (t = k·T), the tangent's ``skip`` sections before them and the ``averaged``
    last logs of λ1 (a multiple of ``BLOCKS``)."""

    system: System
    attrs: dict
    section: str
    period: float
    h: float
    every: int
    first: int
    count: int
    skip: int
    averaged: int
    steps: tuple[int, int]
    """The record's first and last step (its extremes: the amplitudes)."""


def _kernel_point(system: System, duration: float, transient: float, dt: float,
                  section: str | None, full_check: bool = True) -> _KernelPoint:
    """Plan one point on the kernels: the run checked with the step ``dt`` (``RunPlan.make``;
    without ``full_check`` only its times, as a grid's inner points after ``check_grid``
    checked its corners: the RK4 stability check costs 50 ms a point), then its step made
    the largest h <= dt dividing the section period, so the section points fall on steps;
    the record's sections are those of t = k·T in [transient, duration], the tangent's
    transient (``lyapunov.default_lengths``) whole sections before them."""
    model = system.model
    if full_check:
        checked = RunPlan.make(system, duration=duration, transient=transient, dt=dt,
                               warn=lambda message: None)
    else:  # times only: the grid's corners had the whole check (``grid.check_grid``)
        check_times(duration, transient, dt)
        checked = RunPlan(system, dt, duration, transient)
        checked.check_kept()
    attrs = completed_attrs(system, **checked.settings())
    section = section or default_section(attrs)
    period = period_of(attrs, section)
    h, every = section_step(period, dt)
    run = replace(checked, dt=h)  # h <= dt passes the checks dt passed (none repeated)
    attrs["dt"] = h
    first = -(-run.first // every)
    count = run.n_steps // every - first + 1
    averaged = count - count % BLOCKS
    if averaged < BLOCKS:
        raise InputError(f"chart point: the record ({(run.n_steps - run.first) * h:.3g} s) "
                         f"holds fewer than {BLOCKS} sections of {period:.3g} s")
    skip = min(math.ceil(default_lengths(model)[2] / period - 1e-9), first - 1)
    return _KernelPoint(system, attrs, section, period, h, every, first, count, max(skip, 0),
                        averaged, (run.first, run.n_steps))


def grid_balls(setting: Setting, axes: Sequence[Axis]) -> list[System]:
    """One System per model and balls of the grid over ``axes``: every value of its
    structure axes (``n_balls``, ``n_balls[BEARING]``), a parameter axis at its first value
    (a member kernel is one per model and balls)."""
    choices = [[(a.name, v) for v in (a.values if axis_bearing(a.name) is not None
                                      else a.values[:1])] for a in axes]
    systems: dict[tuple, System] = {}
    for coords in itertools.product(*choices):
        system = setting.system_at(**dict(coords))
        systems.setdefault((id(system.model), system.structure), system)
    return list(systems.values())


def check_grid_kernels(setting: Setting, axes: Sequence[Axis], device: str | Placement,
                       tangent: bool = False) -> None:
    """Build (or load) the member kernels of every balls of the grid on ``device`` (a
    ``Placement``, or ``"cpu"`` or ``"gpu"``) before any work:
    ``kernels.members.check_kernels``, one ``InputError`` naming the model and the reason
    when one cannot be built."""
    check_kernels(grid_balls(setting, axes), device, tangent)


def grid_device(setting: Setting, axes: Sequence[Axis], device: str | Placement,
                members: int, *, tangent: bool = False, kernels: bool = True,
                fallback: bool = False) -> Placement:
    """Where a grid's ``members`` members run, judged once, before the estimate, any
    executor, store or work: ``kernels.placement.place`` with the steps of the setting's
    transient. With ``kernels`` the member kernels of its balls (``grid_balls``; the
    tangent variant with ``tangent``) are built and checked too; a kernel that cannot be
    built on ``device`` ``cpu`` or ``gpu`` is one ``InputError``. With ``fallback`` (a
    chart: ``kernel_points`` runs points one by one where the cores have no build),
    ``auto`` is never refused: a GPU that cannot build them leaves the grid to the cores,
    whose builds are not judged here. A ``Placement`` given is kept (only kernels it has not
    built yet are built). The ``Placement`` returned is what the grid's points take."""
    variant = ("tangent" if tangent else "state") if kernels else ()
    return place(device, members, lambda: grid_balls(setting, axes), variant,
                 max(1, round(setting.transient / setting.step())), fallback=fallback)


def kernel_points(systems: list[System], durations: list[float], transient: float,
                  dt: float, section: str | None, device: str | Placement = "cpu",
                  threads: int | None = None, datasets: bool = True) -> list:
    """Chart points with λ1 on the member kernels (``analysis.integrate.kernels``, the
    tangent variant): the points of each model and balls in one ``run_members`` call on
    ``device`` (a ``Placement``, the grid's, kept; or ``cpu``: every core; ``gpu``;
    ``auto``: placed once per model and balls). Each point's step is the largest
    h <= ``dt`` dividing its section period (``section_step``), so its section points are
    states at steps; its amplitudes are the extremes over the record's steps, λ1 and its
    interval the batch means of the last ``averaged`` section logs (renormalised once per
    section). Per system its ``PointResult`` or the ``SimulationError`` of its blow-up.

    Against ``one_pass`` (interpolated sections, h = dt, renormalised every
    ``RENORM_EVERY`` steps) non-chaotic points keep their class, and λ1 stays within its
    interval (``tests/integrate/test_kernel_chart.py``). The first and last point get the
    whole run check (``RunPlan.make``), the others their times only (a chart's grid is
    checked at its corners first, ``grid.check_grid``). Without a CPU build (an operation
    the writer does not know, no compiler) the points run one by one (``one_pass``); on the
    GPU that is an error (``Unsupported``, ``CompileError``; a chart judges its kernels
    before any point, ``grid_device``: only ``--device auto`` on the cores gets here).
    Without ``datasets`` a point's result is its chart row (``chart_row``'s fields) instead
    of a ``PointResult``, the points of equal section counts classified together
    (``_batch_rows``: no Dataset, the class with numpy over the points; identical rows,
    ``tests/sweeps/test_chart_host.py``)."""
    results: list = [None] * len(systems)
    groups: dict[tuple, list[tuple[int, _KernelPoint]]] = {}
    for i, (system, duration) in enumerate(zip(systems, durations, strict=True)):
        point = _kernel_point(system, duration, transient, dt, section,
                              full_check=i in (0, len(systems) - 1))
        groups.setdefault((id(system.model), system.structure), []).append((i, point))
    for group in groups.values():
        points = [point for _, point in group]
        batch = _Batch.of(points)
        out = _run_batch(batch, device, threads)
        if out is None:  # no CPU build: the scalar blocks, point by point
            for i, _ in group:
                results[i] = _scalar_point(systems[i], durations[i], transient, dt, section)
            continue
        if not datasets:
            for (i, _), row in zip(group, _batch_rows(batch, out), strict=True):
                results[i] = row
            continue
        for j, (i, point) in enumerate(group):
            if out.diverged_at[j] >= 0:
                results[i] = blow_up_error(point.system, int(out.diverged_at[j]), point.h,
                                           out.final[j])
            else:
                total = point.skip + point.count
                results[i] = _kernel_result(point, out.sections[j, point.skip:total],
                                            out.logs[j, total - point.averaged:total],
                                            out.high[j] - out.low[j])
    return results


@dataclass(frozen=True)
class _Batch:
    """The kernel points of one model and balls as arrays, one row per member (what
    ``_KernelPoint`` holds per point): the first member's ``system`` (model, balls, initial
    state), the parameter vectors ``p`` (M × parameters), each member's section period and
    step h (s), its steps per section, first section, sections, skipped sections, averaged
    logs and the record's first and last step; ``graph``: whether its graph ratio is judged
    (forced at X and VC, shaft section), ``vc_hz`` its VC frequency (Hz); ``shown``: the
    displacements of its amplitudes; ``member(j)``: member j's System (made only for a
    blow-up's message)."""

    system: System
    p: np.ndarray
    period: np.ndarray
    h: np.ndarray
    every: np.ndarray
    first: np.ndarray
    count: np.ndarray
    skip: np.ndarray
    averaged: np.ndarray
    steps_from: np.ndarray
    steps_to: np.ndarray
    graph: np.ndarray
    vc_hz: np.ndarray
    shown: tuple[str, ...]
    member: Callable[[int], System] = field(compare=False)

    @classmethod
    def of(cls, points: list[_KernelPoint]) -> _Batch:
        """The batch of kernel points planned one by one (``_kernel_point``)."""
        attrs = [p.attrs for p in points]

        def ints(name: str) -> np.ndarray:
            return np.array([getattr(p, name) for p in points], dtype=np.int64)

        return cls(points[0].system, np.array([p.system.p for p in points]),
                   np.array([p.period for p in points]), np.array([p.h for p in points]),
                   ints("every"), ints("first"), ints("count"), ints("skip"),
                   ints("averaged"), np.array([p.steps[0] for p in points], dtype=np.int64),
                   np.array([p.steps[1] for p in points], dtype=np.int64),
                   np.array([run_unbalance(a) > 0 and a.get("vc_hz", 0) > 0
                             and str(p.section) == "shaft"
                             for a, p in zip(attrs, points, strict=True)], dtype=bool),
                   np.array([float(a.get("vc_hz", 0)) for a in attrs]),
                   displacement_names(attrs[0]), lambda j: points[j].system)

    def schedule(self) -> Schedule:
        """The members' ``Schedule``: the tangent from the start of the skipped sections,
        the extremes over the record's steps."""
        return Schedule((self.first - self.skip - 1) * self.every, self.every,
                        self.skip + self.count, tangent=True, lyapunov_skip=self.skip,
                        extremes_from=self.steps_from, extremes_to=self.steps_to)


def _run_batch(batch: _Batch, device: str | Placement, threads: int | None):
    """The batch's one ``run_members`` call on ``device`` (placed for its members and
    steps); None where the cores have no build of its kernel (``Unsupported``,
    ``CompileError``: the points then run one by one), an error on the GPU."""
    schedule = batch.schedule()
    placed = place(device, len(batch.p), steps=schedule.total_steps)
    state = np.asarray(batch.system.state, float)
    try:
        return run_members(batch.system, np.tile(state, (len(batch.p), 1)), batch.p,
                           batch.h, schedule, device=placed, threads=threads)
    except (Unsupported, CompileError):
        if placed.gpu:
            raise
        return None


def _batch_rows(batch: _Batch, out) -> list[dict | SimulationError]:
    """Each member's chart row (``chart_row``'s fields) from the kernel result ``out``, or
    the ``SimulationError`` of its blow-up: ``_batch_columns`` split into rows."""
    columns, failed = _batch_columns(batch, out)
    return _rows_of(columns, failed, len(batch.p))


def _rows_of(columns: dict[str, np.ndarray], failed: dict[int, SimulationError],
             m: int) -> list[dict | SimulationError]:
    """The m rows of ``columns`` (Python values, the fields in the columns' order), the
    ``SimulationError`` of each member of ``failed``."""
    names = list(columns)
    rows: list = [dict(zip(names, row, strict=True))
                  for row in zip(*(c.tolist() for c in columns.values()), strict=True)]
    if not names:
        rows = [None] * m
    for j, exc in failed.items():
        rows[j] = exc
    return rows


def _columns_of(rows: list[dict | SimulationError]
                ) -> tuple[dict[str, np.ndarray], dict[int, SimulationError]]:
    """Rows as ``_batch_columns`` gives them: each field stacked over the points
    (``store.stacked``: the arrays ``PointStore.save_block`` stores), a failed point's row
    a placeholder (another point's), and the failures by index."""
    failed = {j: row for j, row in enumerate(rows) if isinstance(row, SimulationError)}
    good = next((row for row in rows if not isinstance(row, SimulationError)), None)
    if good is None:
        return {}, failed
    return stacked([good if j in failed else row for j, row in enumerate(rows)]), failed


def _batch_columns(batch: _Batch, out
                   ) -> tuple[dict[str, np.ndarray], dict[int, SimulationError]]:
    """The members' chart rows as columns (``chart_row``'s fields in its order, each the
    array ``PointStore.save_block`` would stack from the rows: the same dtypes and bits)
    from the kernel result ``out``, and the ``SimulationError`` of each member that blew up
    (its place in the columns a placeholder): the members holding the same number of
    section points classified together (``_count_columns``), no dict per point."""
    m = len(batch.p)
    diverged = out.diverged_at >= 0
    failed = {int(j): blow_up_error(batch.member(int(j)), int(out.diverged_at[j]),
                                    float(batch.h[j]), out.final[j])
              for j in np.flatnonzero(diverged)}
    natures = np.full(m, "", dtype=object)
    columns = {"nature": natures, "nature_code": np.zeros(m, dtype=np.int64),
               "period": np.zeros(m, dtype=np.int64),
               **{name: np.full(m, np.nan) for name in ("lyapunov", "ci95", "graph_ratio")},
               **{f"amplitude_{v}": np.full(m, np.nan) for v in batch.shown}}
    kept = np.flatnonzero(~diverged)
    counts = batch.count[kept]
    for count in dict.fromkeys(counts.tolist()):
        _count_columns(batch, out, kept[counts == count], count, columns)
    columns["nature"] = np.array(natures.tolist()) if m else np.array([], dtype=str)
    return columns, failed


def _count_columns(batch: _Batch, out, rows: np.ndarray, count: int,
                   columns: dict[str, np.ndarray]) -> None:
    """The chart rows of the members ``rows`` of ``batch``, each holding ``count`` section
    points, written at ``rows`` of ``columns`` (``_batch_columns``'): λ1, its interval
    (``lyapunov.running_mean``, ``batch_ci95``, one interval per row) and the class
    (``classes.class_codes``) with numpy over the members."""
    model = batch.system.model
    skip, span = batch.skip[rows], np.arange(count)
    averaged = int(batch.averaged[rows[0]])  # count − count % BLOCKS: one per count
    if np.all(skip == skip[0]):  # the usual case: slices, not an index per element
        start = int(skip[0])
        members = slice(int(rows[0]), int(rows[-1]) + 1) \
            if rows[-1] - rows[0] + 1 == len(rows) else rows  # consecutive: views
        sections = out.sections[members, start:start + count]
        logs = out.logs[members, start + count - averaged:start + count]
    else:  # the members ordered by skip: each run of equal skips copied as whole rows
        rows = rows[np.argsort(skip, kind="stable")]
        skip = batch.skip[rows]
        sections = np.empty((len(rows), count, *out.sections.shape[2:]),
                            dtype=out.sections.dtype)
        logs = np.empty((len(rows), averaged), dtype=out.logs.dtype)
        edges = np.flatnonzero(np.diff(skip)) + 1
        for a, b in zip([0, *edges.tolist()], [*edges.tolist(), len(rows)], strict=True):
            s = int(skip[a])
            sections[a:b] = out.sections[rows[a:b], s:s + count]
            logs[a:b] = out.logs[rows[a:b], s + count - averaged:s + count]
    ptp = out.high[rows] - out.low[rows]
    interval = (batch.every[rows] * batch.h[rows])[:, None]
    # running_mean's last column alone: the same sum over the same product (k · interval)
    lam = np.cumsum(logs, axis=1)[:, -1] / (interval[:, 0] * logs.shape[1])
    ci = batch_ci95(logs, interval)
    period = batch.period[rows]
    times = (batch.first[rows][:, None] + span) * period[:, None]  # k·T, k cast exactly
    classes, code, periods, ratios = class_codes(sections, ptp, model.state_names,
                                                 _units(model), period, times,
                                                 batch.graph[rows], batch.vc_hz[rows], lam, ci)
    columns["nature"][rows] = classes[code]
    columns["nature_code"][rows] = np.array([nature_code(c) for c in classes],
                                            dtype=np.int64)[code]
    columns["period"][rows] = periods
    columns["lyapunov"][rows], columns["ci95"][rows] = lam, ci
    columns["graph_ratio"][rows] = np.where(ratios == 0, np.nan, ratios)  # `ratio or nan`
    for v, i in zip(batch.shown, (model.state_names.index(v) for v in batch.shown),
                    strict=True):
        columns[f"amplitude_{v}"][rows] = ptp[:, i] / 2


def _scalar_point(system: System, duration: float, transient: float, dt: float,
                  section: str | None) -> PointResult | SimulationError:
    """``one_pass`` with its tangent, or the ``SimulationError`` of its blow-up."""
    try:
        return one_pass(system, duration, transient, dt, section)
    except SimulationError as exc:
        return exc


def _section_dataset(point: _KernelPoint, sections: np.ndarray) -> xr.Dataset:
    """The Poincaré points of a kernel point as ``poincare_section`` returns them (the states
    at t_k = k·T are samples, taken exactly): dimension k, coordinates k and t (s), the
    state variables with their attrs, the run's attrs with ``section``,
    ``section_period_s`` and ``phase`` 0; built directly (20 ms a point less)."""
    model = point.system.model
    k = np.arange(point.first, point.first + point.count)
    attrs = {**point.attrs, "section": str(point.section), "section_period_s": point.period,
             "phase": 0.0}
    data = {name: ("k", sections[:, i], {key: str(value) for key, value
                                         in state_variable_attrs(model, name).items()})
            for i, name in enumerate(model.state_names)}
    return xr.Dataset(data, coords={"k": ("k", k),
                                    "t": ("k", (0.0 + k) * point.period, {"units": "s"})},
                      attrs=attrs)


def _units(model: Model) -> dict[str, str]:
    """The unit of every state variable (their section points' ``units`` attr)."""
    return {name: str(state_variable_attrs(model, name)["units"])
            for name in model.state_names}


def _kernel_result(point: _KernelPoint, sections: np.ndarray, logs: np.ndarray,
                   ptp_values: np.ndarray) -> PointResult:
    """A kernel point's verdict: its section points (states at t = k·T), amplitudes and
    λ1 from the section logs."""
    model = point.system.model
    interval = point.every * point.h
    lam = float(running_mean(logs[None, :], interval)[0, -1])
    ci = float(batch_ci95(logs[None, :], interval)[0])
    ptp = dict(zip(model.state_names, ptp_values.tolist(), strict=True))
    points = _section_dataset(point, sections)
    return PointResult(classify_section(points, ptp, lambda: (lam, ci)), lam, ci, ptp,
                       displacement_names(point.attrs), points)


def chart_row(out: PointResult) -> dict:
    """The chart's fields of a point: class, its code and period, λ1 and its interval
    (1/s), the graph ratio and the amplitudes (half peak-to-peak, SI units)."""
    result = out.classification
    return {"nature": result.nature, "nature_code": nature_code(result.nature),
            "period": result.period or 0, "lyapunov": out.lyapunov, "ci95": out.ci95,
            "graph_ratio": result.graph_ratio or np.nan,
            **{f"amplitude_{v}": out.ptp[v] / 2 for v in out.displacements}}


def chart_point(setting: Setting, system: System) -> dict:
    """Class, period, largest Lyapunov exponent (1/s) and amplitudes (m) at one point
    (``setting.system_at``), in one pass (see the module docstring), classified on
    ``setting.section`` (None: the model's own, ``default_section``);
    ``chart.chart_point_two_pass`` is the same in two."""
    return chart_row(one_pass(system, setting.seconds(system), setting.transient,
                                  setting.step(), setting.section, tangent=setting.lyapunov))


def chart_points(setting: Setting, systems: list[System], device: str | Placement = "cpu",
                 threads: int | None = None) -> list[dict | SimulationError]:
    """Chart points of one model and balls: with λ1 (``setting.lyapunov``) all in one call
    of the member kernels on ``device`` (``kernel_points``: sections on steps, see there),
    else one by one (``one_pass`` without a tangent, bit for bit ``chart_point``'s); per
    point its result or the ``SimulationError`` of its blow-up. ``threads``: CPU threads
    of the kernel call (None: every core)."""
    durations = [setting.seconds(system) for system in systems]
    dt = setting.step()
    if not setting.lyapunov:
        outs: list = []
        for system, duration in zip(systems, durations, strict=True):
            try:
                outs.append(one_pass(system, duration, setting.transient, dt,
                                     setting.section, tangent=False))
            except SimulationError as exc:
                outs.append(exc)
    else:
        outs = kernel_points(systems, durations, setting.transient, dt, setting.section,
                             device, threads, datasets=False)
    return [out if isinstance(out, SimulationError | dict) else chart_row(out)
            for out in outs]


FIT_PARAMETERS = ("ball_diameter", "pitch_diameter", "inner_race_diameter",
                  "outer_race_diameter")
"""Parameters (and their ``<name>_<bearing>`` forms) that decide how many balls fit a
bearing (``model.balls_that_fit``): an axis over one of them is planned point by point."""


def chart_grid_points(setting: Setting, names: Sequence[str], values: Sequence[Sequence[float]],
                      device: str | Placement = "cpu", threads: int | None = None, *,
                      columns: bool = False
                      ) -> list[dict | SimulationError] | tuple[dict[str, np.ndarray],
                                                                dict[int, SimulationError]]:
    """``chart_points`` of the grid points of one model and balls at ``values`` (one row of
    values per point, one per axis of ``names``), without a System per point where it can:
    with λ1 the points are planned as arrays (``_grid_batch``: one parameter matrix, one
    evaluation of the frequencies, the run checks and schedules with numpy) and run in one
    call of the member kernels; where the arrays cannot plan them (no λ1, an axis over the
    balls' fit, a model whose frequencies take no column of values, a point a check would
    refuse) the points are made one by one (``setting.system_at``, ``chart_points``), so
    any refusal is the one ``chart_points`` gives. The rows are ``chart_points``' bit for
    bit (``tests/sweeps/test_chart_host_batched.py``). With ``columns`` the same rows as
    columns and failures (``_batch_columns``: each field an array over the points, what
    ``PointStore.save_block`` would stack from the rows; a failed point's
    ``SimulationError`` by its index), no dict per point."""
    batch = _grid_batch(setting, tuple(names), values) if setting.lyapunov else None
    out = None if batch is None else _run_batch(batch, device, threads)
    if batch is not None and out is not None:
        return _batch_columns(batch, out) if columns else _batch_rows(batch, out)
    if batch is None:
        systems = [setting.system_at(**dict(zip(names, row, strict=True))) for row in values]
    else:  # no CPU build: the scalar blocks, point by point
        systems = [batch.member(j) for j in range(len(values))]
    rows = chart_points(setting, systems, device, threads)
    return _columns_of(rows) if columns else rows


def _frequency_columns(model: Model, structure: Structure,
                       p: np.ndarray) -> dict[str, np.ndarray] | None:
    """The shaft, cage and VC frequencies (Hz) of ``Model.frequencies`` for every row of
    ``p`` (M × parameters), keyed as its ``as_dict`` keys them (the fault frequencies left
    out: no section reads them); None where the model's functions do not take a column of
    values (a ``math`` function of a parameter)."""
    m, columns = len(p), p.T
    try:
        shaft = np.broadcast_to(np.asarray(model.module.shaft_speed(columns), dtype=float),
                                (m,)) / (2 * math.pi)
        cage = {b: np.broadcast_to(np.asarray(model.cage_speed(b, columns), dtype=float),
                                   (m,)) / (2 * math.pi) for b in model.bearing_names}
    except (TypeError, ValueError):
        return None
    vc = {b: n * cage[b] for b, n in zip(model.bearing_names, structure, strict=True)}
    out = {"shaft_hz": shaft}
    if len(vc) <= 1:
        out["cage_hz"] = next(iter(cage.values()), np.zeros(m))
        out["vc_hz"] = next(iter(vc.values()), np.zeros(m))
    else:
        for b in vc:
            out[f"cage_hz_{b}"], out[f"vc_hz_{b}"] = cage[b], vc[b]
    return out


def _period_column(section: str, columns: dict[str, np.ndarray], attrs: dict,
                   bearings: list[str]) -> np.ndarray | None:
    """The period (s) of ``section`` at every row of ``columns`` (``period_of``'s steps:
    1 / the frequency of its attr; a ``param:NAME`` section's frequency 1 / NAME), the
    values not in ``columns`` those of ``attrs``; None where a period is not a finite
    number > 0 or its attr is not known here."""
    kind, name = parse_section(str(section).strip())
    m = len(next(iter(columns.values())))
    if kind == "param":
        value = columns.get(name, np.full(m, float(attrs[name])) if name in attrs else None)
        frequency = None if value is None else 1.0 / value
    elif kind == "shaft":
        frequency = columns["shaft_hz"]
    else:
        keys = [f"{kind}_hz_{name}", f"{kind}_hz"] if name else \
            [f"{kind}_hz", *(f"{kind}_hz_{b}" for b in bearings[:1])]
        frequency = next((columns[k] for k in keys if k in columns), None)
    if frequency is None:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        if not np.all(np.isfinite(frequency) & (frequency > 0)):
            return None
        return 1.0 / frequency


def _first_kept(threshold: np.ndarray, step: np.ndarray) -> np.ndarray:
    """``plan.first_kept`` of every row (the same float products, so the same steps)."""
    k = np.maximum(0, np.ceil(threshold / step)).astype(np.int64)
    while (down := (k > 0) & ((k - 1).astype(float) * step >= threshold)).any():
        k[down] -= 1
    while (up := k.astype(float) * step < threshold).any():
        k[up] += 1
    return k


_UNSEEN = object()


class _Reads(dict):
    """A run's attrs that note which keys a judgement reads (``every``: it iterated them)."""

    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.read: set = set()
        self.every = False

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.read.add(key)
        return super().get(key, default)

    def __contains__(self, key) -> bool:
        self.read.add(key)
        return super().__contains__(key)

    def __iter__(self):
        self.every = True
        return super().__iter__()

    def keys(self):
        self.every = True
        return super().keys()

    def items(self):
        self.every = True
        return super().items()

    def values(self):
        self.every = True
        return super().values()


def _each_judged(judge: Callable[[dict], object], attrs: dict,
                 columns: dict[str, np.ndarray]) -> list:
    """``judge({**attrs, **row})`` of every row of ``columns`` (the attrs that differ from
    point to point), judged once per distinct values of the keys it reads: a judgement
    that read the same values takes the same path to the same verdict (``judge`` a pure
    function of the attrs, ``default_section`` or ``run_unbalance``), so a group whose
    points differ only in what it does not read is judged once."""
    keys = list(columns)
    values = [columns[k].tolist() for k in keys]
    m = len(values[0])
    paths: dict[tuple[int, ...], dict[tuple, object]] = {}
    found = []
    for j in range(m):
        for read, seen in paths.items():
            verdict = seen.get(tuple(values[i][j] for i in read), _UNSEEN)
            if verdict is not _UNSEEN:
                break
        else:
            mapping = _Reads({**attrs, **{k: v[j] for k, v in zip(keys, values,
                                                                 strict=True)}})
            verdict = judge(mapping)
            read = tuple(i for i, k in enumerate(keys) if mapping.every or k in mapping.read)
            if not read:  # it reads nothing that differs: every point's verdict
                return [verdict] * m
            paths.setdefault(read, {})[tuple(values[i][j] for i in read)] = verdict
        found.append(verdict)
    return found


def _grid_batch(setting: Setting, names: tuple[str, ...],
                values: Sequence[Sequence[float]]) -> _Batch | None:
    """The kernel points of grid points of one model and balls planned as arrays, each
    step that of ``setting.seconds`` and ``_kernel_point`` (the same float operations, so
    the same periods, steps and schedules): the first and last point are Systems with the
    whole run check (``RunPlan.make``) and their attrs, the others rows of one parameter
    matrix whose frequencies are evaluated once (``_frequency_columns``; checked equal to
    the first and last point's attrs) and whose times pass ``check_times`` and
    ``check_kept``. Where a point's section is the model's own (``default_section``) it is
    judged on the first point's attrs with the point's parameters, frequencies and duration.
    None where the arrays cannot plan the points or a check would refuse one: the caller
    then makes them one by one (the same refusal)."""
    m = len(values)
    grid = np.asarray(values, dtype=float).reshape(m, len(names))

    def member(j: int) -> System:
        return setting.system_at(**dict(zip(names, values[j], strict=True)))

    start = member(0)
    model, structure = start.model, start.structure
    params: dict[str, np.ndarray] = {}
    for name, column in zip(names, grid.T, strict=True):
        if axis_bearing(name) is not None:
            if np.any(column != column[0]):
                return None
            continue
        if name.startswith(FIT_PARAMETERS) or name not in model.module.RANGES:
            return None
        low, high, inclusive = model.module.RANGES[name]
        with np.errstate(invalid="ignore"):
            if not np.all(np.isfinite(column) & (column >= low if inclusive else column > low)
                          & (column <= high)):
                return None
        params[name] = column
    ends = [start, member(m - 1)]  # after the columns' checks: a refusal is the first's
    if ends[1].structure != structure:
        return None
    index = {name: i for i, name in enumerate(model.parameter_names)}
    p = np.tile(ends[0].p, (m, 1))
    for name, column in params.items():
        p[:, index[name]] = column
    columns = _frequency_columns(model, structure, p)
    if columns is None:
        return None
    run = [run_attrs(model, structure, dict(s.parameters)) for s in ends]
    if any(k not in a or columns[k][j] != a[k] for k in columns
           for j, a in ((0, run[0]), (m - 1, run[1]))):
        return None
    columns.update(params)
    dt, transient = setting.step(), setting.transient
    record = _period_column(setting.record_section, columns, run[0], model.bearing_names)
    if record is None or any(record[j] != period_of(a, setting.record_section)
                             for j, a in ((0, run[0]), (m - 1, run[1]))):
        return None
    duration = transient + (setting.samples + 0.5) * record
    if not (math.isfinite(dt) and dt > 0 and math.isfinite(transient) and transient >= 0):
        return None
    with np.errstate(invalid="ignore"):
        if not np.all(np.isfinite(duration) & (duration > 0) & (transient < duration)
                      & (dt <= duration)):
            return None
    kept = np.rint(duration / dt).astype(np.int64) \
        - _first_kept(transient - 1e-12 * duration, np.full(m, dt)) + 1
    if np.any(kept < 2):  # check_kept's refusal
        return None
    attrs = [completed_attrs(s, **RunPlan.make(s, duration=float(duration[j]),
                                               transient=transient, dt=dt,
                                               warn=lambda message: None).settings())
             for s, j in zip(ends, (0, m - 1), strict=True)]
    columns["duration"] = duration

    def attrs_of(j: int) -> dict:
        """The attrs the point's section and graph are judged on."""
        return {**attrs[0], **{k: v[j] for k, v in columns.items()}}

    if setting.section:
        sections = [setting.section] * m
    else:
        sections = _each_judged(default_section, attrs[0], columns)
        if sections[-1] != default_section(attrs[1]):
            return None
    section_of = np.array(sections, dtype=object)
    period = np.empty(m)
    for section in dict.fromkeys(sections):
        at = np.flatnonzero(section_of == section)
        column = _period_column(section, columns, attrs[0], model.bearing_names)
        if column is None or column[at[0]] != period_of(attrs_of(int(at[0])), section):
            return None
        period[at] = column[at]
    if period[-1] != period_of(attrs[1], sections[-1]):
        return None
    steps = np.maximum(1, np.ceil(period / dt - 1e-9)).astype(np.int64)  # section_step
    h = np.where(np.abs(period / dt - steps) <= 1e-9, float(dt), period / steps)
    first_step = _first_kept(transient - 1e-12 * duration, h)
    last_step = np.rint(duration / h).astype(np.int64)
    first = -(-first_step // steps)
    count = last_step // steps - first + 1
    averaged = count - count % BLOCKS
    if np.any(averaged < BLOCKS):
        return None
    skip = np.ceil(default_lengths(model)[2] / period - 1e-9).astype(np.int64)
    skip = np.maximum(np.minimum(skip, first - 1), 0)
    forced = np.array(_each_judged(lambda a: run_unbalance(a) > 0, attrs[0], columns),
                      dtype=bool)
    vc_hz = columns["vc_hz"] if "vc_hz" in attrs[0] and "vc_hz" in columns else np.zeros(m)
    graph = forced & (vc_hz > 0) & (section_of == "shaft")
    return _Batch(ends[0], p, period, h, steps, first, count, skip, averaged, first_step,
                  last_step, graph, np.asarray(vc_hz, dtype=float),
                  displacement_names(attrs[0]), member)
