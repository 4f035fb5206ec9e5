"""``run_members``: M members of one model and balls through the member kernels.

Each member has its own initial state, parameter vector, step h (s), start time t0 (s) and
step counter k0 (step k runs from ``t0 + k·h``), and follows one ``Schedule``: a transient of
whole RK4 steps, then K sections every ``steps_per_section`` steps, recorded (or only reduced:
the final state, the blow-up step, the extremes, the tangent's λ1). Members run in blocks
(``block`` members per call; memory on the device is bounded by the block), on the CPU build
(``cpu.py``, every core) or the CUDA build (``cuda.py``), from one C text (``source.py``).
A member whose state is not finite or whose centre displacement leaves its blow-up limit
(``simulate.blow_up_limit``, the predicate of ``simulate.bad_states``) stops there: its
``diverged_at`` is that step, its later sections and logs NaN; its neighbours are unaffected.

The state variant on the CPU is the compiled path's RK4 (``simulate``, ``ensemble``) bit for
bit; the CUDA build agrees with it to the last bits of CUDA's libm.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np

from analysis.errors import InputError, SimulationError
from analysis.integrate.compiled import test_state
from analysis.integrate.kernels.cpu import cores, cpu_library
from analysis.integrate.kernels.devices import DeviceError
from analysis.integrate.kernels.placement import Placement, on_gpu, place
from analysis.integrate.simulate import blow_up_limit, check_bounded
from analysis.model import System

HOST_BUDGET = 8 * 2**30
"""Bytes of results a call may hold in host memory (as ``plan.MEMORY_BUDGET``)."""
CPU_BLOCK = 1 << 16
"""Members per call of the CPU build by default (progress is reported per call)."""
PROGRESS_SECONDS = 0.5
"""With a ``progress`` callback and no ``block`` on the CPU: the members of a call run in
sub-chunks of about this much work each, so the counter moves every half second or so
(each member runs alone: the results are those of one call, bit for bit)."""
CHUNK_PER_THREAD = 4
"""Least members per thread in such a sub-chunk (OpenMP still fills every core)."""
GPU_BLOCK_SHARE = 0.5
"""Share of the GPU's free memory one block of members may take."""
SELF_TEST_TOL = 1e-12
"""Relative agreement of the tangent variant with its stage RK4 in CasADi (self-test)."""
GPU_SELF_TEST_TOL = 1e-10
"""Relative agreement of the CUDA build with the CPU build over the self-test's steps (CUDA's
libm differs from glibc's in the last bits)."""


def section_step(period_s: float, dt: float) -> tuple[float, int]:
    """(h, N): the largest RK4 step h <= ``dt`` (s) that divides the section period
    ``period_s`` (s) into N whole steps, N = ceil(T/dt − 1e-9), h = T/N: sections then fall
    on steps (no interpolation between samples). A period of whole steps of ``dt`` (to
    1e-9 of a step) keeps h = ``dt`` exactly."""
    if not (math.isfinite(period_s) and period_s > 0):
        raise InputError(f"period_s: a finite period > 0 s, got {period_s!r}")
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"dt: a finite step > 0 s, got {dt!r}")
    steps = max(1, math.ceil(period_s / dt - 1e-9))
    if abs(period_s / dt - steps) <= 1e-9:  # already whole steps: keep dt itself (bit for
        return float(dt), steps             # bit the run of h = dt; T/N may round off it)
    return period_s / steps, steps


@dataclass(frozen=True)
class Schedule:
    """What every member runs and records (steps are RK4 steps of the member's h). The four
    counts are whole numbers, one for every member or one per member (1-D sequences of
    length M: a chart's points differ in section period and record length)."""

    transient_steps: int | Sequence[int]
    """RK4 steps before the first recorded section interval (>= 0)."""
    steps_per_section: int | Sequence[int]
    """RK4 steps between recorded sections (>= 1); section j is the state after
    ``transient_steps + (j + 1)·steps_per_section`` steps."""
    n_sections: int | Sequence[int]
    """K sections recorded per member (>= 1)."""
    tangent: bool = False
    """Also carry one tangent vector (from e1 at the end of the transient), renormalised at
    each section."""
    lyapunov_skip: int | Sequence[int] = 0
    """Sections whose logs are not averaged into λ1 (< n_sections); the extremes are taken
    from the end of these sections on (the record)."""
    keep_sections: bool = True
    """False: only reduced results leave the device (no (M, K, n) sections)."""
    extremes_from: int | Sequence[int] | None = None
    """First step of the extremes (``low``, ``high``); None: ``transient_steps +
    lyapunov_skip · steps_per_section``."""
    extremes_to: int | Sequence[int] | None = None
    """Last step of the extremes; None: the last section's. A member runs on to it when it
    is later (a record that ends between sections)."""

    def __post_init__(self) -> None:
        for name, low in (("transient_steps", 0), ("steps_per_section", 1),
                          ("n_sections", 1), ("lyapunov_skip", 0)):
            self.counts(name, low)
        for name in ("extremes_from", "extremes_to"):
            if getattr(self, name) is not None:
                self.counts(name, 0)
        if np.any(self.counts("lyapunov_skip") >= self.counts("n_sections")):
            raise InputError(f"lyapunov_skip: fewer than n_sections ({self.n_sections}), got "
                             f"{self.lyapunov_skip}")

    def counts(self, name: str, low: int = 0) -> np.ndarray:
        """The field ``name`` as int64 (0-d or 1-d), checked: whole numbers >= ``low``."""
        value = getattr(self, name)
        arr = np.asarray(value)
        if arr.ndim > 1 or arr.size == 0 or arr.dtype == bool \
                or not np.issubdtype(arr.dtype, np.number) \
                or not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)) \
                or np.any(arr < low):
            raise InputError(f"{name}: a whole number >= {low} (or one per member), got "
                             f"{value!r}")
        return arr.astype(np.int64)

    def per_member(self, m: int) -> list[np.ndarray]:
        """transient, steps per section, sections, skip, extremes from and to: (m,) int64
        each (``InputError`` when a per-member field's length is not m)."""
        out = []
        for name in ("transient_steps", "steps_per_section", "n_sections", "lyapunov_skip",
                     "extremes_from", "extremes_to"):
            if getattr(self, name) is None:
                tr, ev, ns, skip = out[:4]
                arr = tr + skip * ev if name == "extremes_from" else tr + ev * ns
            else:
                arr = self.counts(name)
            if arr.ndim == 1 and len(arr) != m:
                raise InputError(f"{name}: one number or one per member ({m}), got {len(arr)}")
            out.append(np.ascontiguousarray(np.broadcast_to(arr, (m,)), dtype=np.int64))
        return out

    @property
    def total_steps(self) -> int:
        """RK4 steps of the longest member that does not blow up."""
        last = self.counts("transient_steps") + self.counts("steps_per_section") \
            * self.counts("n_sections")
        if self.extremes_to is not None:
            last = np.maximum(last, self.counts("extremes_to"))
        return int(np.max(last))

    @property
    def max_sections(self) -> int:
        """K: the most sections of a member (the second axis of the results)."""
        return int(np.max(self.counts("n_sections")))


@dataclass
class MemberResult:
    """What ``run_members`` returns (SI units; M members, K sections, n states)."""

    sections: np.ndarray | None
    """(M, K, n) states at the K sections, NaN after a blow-up (None: ``keep_sections``
    False)."""
    logs: np.ndarray | None
    """(M, K) log growth of the tangent over each section interval (None without the
    tangent); NaN after a blow-up."""
    lambda1: np.ndarray | None
    """(M,) 1/s: mean of the logs after ``lyapunov_skip`` divided by the section interval
    (``steps_per_section · h``); None without the tangent, NaN after a blow-up."""
    diverged_at: np.ndarray
    """(M,) int64: the step counter k of the first state beyond the blow-up bound (its time
    is ``t0 + k·h``), -1 if never."""
    final: np.ndarray
    """(M, n) the last state (after the last step, or the first bad state)."""
    low: np.ndarray
    """(M, n) smallest value of every state over the steps ``Schedule.extremes_from`` …
    ``extremes_to`` (default: from the end of the skipped sections to the last section;
    up to a blow-up)."""
    high: np.ndarray
    """(M, n) largest value, likewise."""
    device: str
    """``"cpu"`` or ``"gpu"`` (``Placement.kind``)."""


def _per_member(name: str, value: np.ndarray | float, m: int, positive: bool) -> np.ndarray:
    out = np.asarray(value, dtype=float)
    if out.ndim == 0:
        out = np.full(m, float(out))
    if out.shape != (m,):
        raise InputError(f"{name}: one number or one per member ({m}), got shape {out.shape}")
    if not np.all(np.isfinite(out)) or (positive and np.any(out <= 0)):
        raise InputError(f"{name}: finite{' and > 0' if positive else ''} values, got "
                         f"{out[~np.isfinite(out) | (out <= 0 if positive else False)][0]!r}")
    return np.ascontiguousarray(out)


def _bytes_per_member(schedule: Schedule, n: int, n_par: int) -> int:
    """Bytes of one member's inputs and outputs in a call."""
    k = schedule.max_sections
    kept = k * n if schedule.keep_sections else 0
    return 8 * (n + 1 + n_par + 3 + kept + (k if schedule.tangent else 0) + 3 * n + 1)


def check_fits(device: str | Placement, members: int, schedule: Schedule, n: int,
               n_par: int = 0) -> None:
    """``InputError`` before anything is allocated when the results of ``members``
    members do not fit the host's budget (``HOST_BUDGET``; the device streams blocks, so
    only the kept results count), or when one member does not fit the GPU's free memory
    (``device``: a ``Placement``, or a resolved name ``"cpu"`` or ``"gpu"``)."""
    per = _bytes_per_member(schedule, n, n_par)
    kept = members * per
    if kept > HOST_BUDGET:
        raise InputError(f"members: {members} members with {schedule.max_sections} sections "
                         f"of {n} states need {kept / 2**30:.3g} GiB of results; at most "
                         f"{HOST_BUDGET / 2**30:g} GiB: give fewer initial states or grid points, "
                         "or record fewer sections per member")
    if on_gpu(device):
        from analysis.integrate.kernels.cuda import free_memory

        free, _ = free_memory()
        if per > GPU_BLOCK_SHARE * free:
            raise InputError(f"members: one member needs {per} bytes on the GPU, "
                             f"{free} bytes free: record fewer sections per member")


def _block_size(placed: Placement, members: int, per: int, block: int | None) -> int:
    if block is not None:
        if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
            raise InputError(f"block: a whole number >= 1, got {block!r}")
        return int(block)
    if not placed.gpu:
        return min(members, CPU_BLOCK)
    from analysis.integrate.kernels.cuda import free_memory

    free, _ = free_memory()
    return max(1, min(members, int(GPU_BLOCK_SHARE * free) // per))


def cpu_kernel(system: System, tangent: bool):
    """The CPU build of ``system``'s member kernel (``cpu.CpuLibrary``), self-tested (the
    kernel builder of ``placement.TABLE["cpu"]``)."""
    _self_test(system.model, system.structure, tangent)
    return cpu_library(system.model, system.structure, tangent)


def gpu_kernel(system: System, tangent: bool):
    """The CUDA build of ``system``'s member kernel (``cuda.CudaKernel``), self-tested
    against the CPU build (the kernel builder of ``placement.TABLE["gpu"]``)."""
    from analysis.integrate.kernels.cuda import cuda_kernel

    _self_test_gpu(system.model, system.structure, tangent)
    return cuda_kernel(system.model, system.structure, tangent)


def _kernel(system: System, tangent: bool, device: str | Placement):
    """``cpu_kernel`` or ``gpu_kernel`` by ``device`` (kept for
    ``benchmarks/bench_ensemble.py``'s first-use timing; runs take ``Placement.row.kernel``)."""
    return (gpu_kernel if on_gpu(device) else cpu_kernel)(system, tangent)


def run_members(system: System, states: np.ndarray, parameters: np.ndarray | None,
                h: np.ndarray | float, schedule: Schedule, *,
                t0: np.ndarray | float = 0.0, k0: np.ndarray | int = 0,
                device: str | Placement = "cpu", block: int | None = None,
                progress: Callable[[int, int], None] | None = None,
                threads: int | None = None) -> MemberResult:
    """Run M members of ``system``'s model and balls by ``schedule``.

    ``states`` (M, n): initial states (SI units; a state that is not finite diverges at
    the first step); ``parameters`` (M, n_par): each member's
    full parameter vector (``Model.parameter_vector``; speed in rpm), or None for
    ``system.p`` for all; ``h`` (s; one or per member): the RK4 step; ``t0`` (s) and ``k0``
    (step counters, whole numbers; one or per member): step k runs from ``t0 + k·h``, the
    first from k0. ``device``: a ``Placement`` (``placement.place``, judged once by the
    run that calls), or ``cpu``, ``gpu`` or ``auto``, placed here for these members;
    ``block``: members per call (default: ``CPU_BLOCK`` on the CPU, half the GPU's free
    memory on the GPU); ``progress(done, total)`` after each block (members: on the CPU
without ``block``, after each sub-chunk of about ``PROGRESS_SECONDS`` of work, at least
``CHUNK_PER_THREAD`` members per thread, sized from the chunks before); ``threads``:
    CPU threads (None: the placement's ``threads``, else ``cpu.cores()``, every core; a
    worker process of a pool of W takes cores / W).

    Each member's blow-up limit is ``simulate.blow_up_limit`` of its parameters. Bad input
    raises ``InputError`` before anything runs; a model whose kernel cannot be written or
    built raises ``source.Unsupported`` or ``compiled.CompileError``."""
    model = system.model
    n, n_par = model.n_state, len(model.parameter_names)
    z0 = np.asarray(states, dtype=float)
    if z0.ndim != 2 or z0.shape[1] != n or len(z0) < 1:
        raise InputError(f"states: an array of shape (members, {n}), got shape {z0.shape}")
    m = len(z0)
    if parameters is None:
        p = np.repeat(system.p[None, :], m, axis=0)
    else:
        p = np.asarray(parameters, dtype=float)
        if p.shape != (m, n_par):
            raise InputError(f"parameters: an array of shape ({m}, {n_par}) (full parameter "
                             f"vectors), got shape {p.shape}")
    hs = _per_member("h", h, m, positive=True)
    t0s = _per_member("t0", t0, m, positive=False)
    k0s = _per_member("k0", k0, m, positive=False)
    if np.any(k0s != np.round(k0s)):
        raise InputError("k0: whole numbers")
    placed = device if isinstance(device, Placement) else \
        place(device, m, steps=schedule.total_steps)
    threads = threads or placed.threads
    check_fits(placed, m, schedule, n, n_par)
    limits = _limits(system, p, parameters is None)
    kern = placed.row.kernel(system, schedule.tangent)
    counts = schedule.per_member(m)
    k = schedule.max_sections
    sections = np.full((m, k, n), np.nan) if schedule.keep_sections else None
    logs = np.full((m, k), np.nan) if schedule.tangent else None
    final, low, high = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    diverged = np.empty(m, dtype=np.int64)
    size = _block_size(placed, m, _bytes_per_member(schedule, n, n_par), block)
    z0, p = np.ascontiguousarray(z0), np.ascontiguousarray(p)
    width = min(threads or cores(), m)
    chunks = _Chunks(size, width if progress is not None and not placed.gpu
                     and block is None else None)
    start = 0
    while start < m:
        part = slice(start, min(m, start + chunks.size))
        count = part.stop - start
        began = time.perf_counter()
        outs = [np.empty((count, k, n)) if sections is not None else np.empty((1, 1, n)),
                np.empty((count, k)) if logs is not None else np.empty((1, 1)),
                np.empty((count, n)), np.empty(count, dtype=np.int64),
                np.empty((count, n)), np.empty((count, n))]
        ins = [np.ascontiguousarray(a[part]) for a in (z0, k0s, p, hs, t0s, limits, *counts)]
        if placed.gpu:
            kern.run(count, ins, k, schedule.keep_sections, outs)
        else:
            kern.run(count, min(threads or cores(), count), ins, k, schedule.keep_sections,
                     outs)
        if sections is not None:
            sections[part] = outs[0]
        if logs is not None:
            logs[part] = outs[1]
        final[part], diverged[part], low[part], high[part] = outs[2:]
        chunks.took(count, time.perf_counter() - began)
        start = part.stop
        if progress is not None:
            progress(part.stop, m)
    lambda1 = None
    if logs is not None:
        skip, n_sec, every = counts[3], counts[2], counts[1]
        used = (np.arange(k)[None, :] >= skip[:, None]) & (np.arange(k)[None, :] < n_sec[:, None])
        with np.errstate(invalid="ignore"):
            lambda1 = np.where(used, logs, 0.0).sum(axis=1) / (n_sec - skip) / (every * hs)
    return MemberResult(sections, logs, lambda1, diverged, final, low, high, placed.kind)


class _Chunks:
    """Members per call of ``run_members``: ``block`` (one size), or with ``width`` threads
    sub-chunks of about ``PROGRESS_SECONDS`` each (a whole number of ``CHUNK_PER_THREAD``
    × ``width`` members, at most ``block``), sized by the rate of the chunks before."""

    def __init__(self, block: int, width: int | None):
        self.block, self.width = block, width
        self.least = CHUNK_PER_THREAD * width if width else block
        self.size = min(block, self.least)

    def took(self, count: int, seconds: float) -> None:
        if not self.width:
            return
        rate = count / seconds if seconds > 0 else math.inf
        want = rate * PROGRESS_SECONDS
        size = self.least * max(1, int(min(want, self.block) // self.least))
        self.size = min(self.block, size)


def blow_up_error(system: System, step: int, h: float, state: np.ndarray) -> SimulationError:
    """The ``SimulationError`` ``simulate`` raises for a member of ``system`` whose
    ``state`` after RK4 step ``step`` (of h s, from t = 0) is its first bad one (the message
    of ``simulate.check_bounded``)."""
    model = system.model
    try:
        check_bounded(np.asarray(state, dtype=float)[:, None], np.array([step * h]),
                      blow_up_limit(model, dict(system.parameters)), model.centre_indices())
    except SimulationError as exc:
        return exc
    return SimulationError(f"the motion blew up at t = {step * h:.6g} s")


def _limits(system: System, p: np.ndarray, shared: bool) -> np.ndarray:
    """Each member's blow-up limit (m), ``simulate.blow_up_limit`` of its parameters."""
    model = system.model
    if shared:
        return np.full(len(p), blow_up_limit(model, dict(system.parameters)))
    names = model.parameter_names
    unique, inverse = np.unique(p, axis=0, return_inverse=True)
    values = [blow_up_limit(model, dict(zip(names, row.tolist(), strict=True)))
              for row in unique]
    return np.ascontiguousarray(np.asarray(values, dtype=float)[np.ravel(inverse)])


def _reference_stage(model, structure: tuple[int, ...]):
    """``(t, z, p, v) -> (f, Jv)`` straight from the model's rhs (sin and cos at every
    stage's own time): the self-test's reference for the tangent variant's stages."""
    import casadi as ca

    rhs = model.functions(structure).rhs
    n, n_par = rhs.size1_in(1), rhs.size1_in(2)
    t, z, p, v = ca.SX.sym("t"), ca.SX.sym("z", n), ca.SX.sym("p", n_par), ca.SX.sym("v", n)
    f = rhs(t, z, p)
    return ca.Function("reference_stage", [t, z, p, v], [f, ca.jtimes(f, z, v)])


@cache
def _self_test(model, structure: tuple[int, ...], tangent: bool) -> None:
    """Check the CPU build against CasADi on a few steps of two members (different states,
    counters, parameters, steps and start times): the state variant bit for bit against
    the step it is written from, the tangent variant to ``SELF_TEST_TOL`` against the
    stage RK4 of the model's rhs and ``jtimes`` evaluated by CasADi. ``CompileError`` when
    it disagrees. Once per process."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels.source import state_functions

    step, constants = state_functions(model, structure)
    n = model.n_state
    z0, k0s, p, hs, t0s, _ = _self_test_inputs(model, n)
    sched = Schedule(1, 2, 2).per_member(2)
    outs = [np.empty((2, 2, n)), np.empty((2, 2)), np.empty((2, n)),
            np.empty(2, dtype=np.int64), np.empty((2, n)), np.empty((2, n))]
    lib = cpu_library(model, structure, tangent)
    lib.run(2, 1, [z0, k0s, p, hs, t0s, np.full(2, np.inf), *sched], 2, True, outs)
    stage = _reference_stage(model, structure) if tangent else None
    for j in range(2):
        c = constants(p[j], hs[j], t0s[j])
        s = np.append(z0[j], k0s[j])
        s = np.asarray(step(s, p[j], hs[j], t0s[j], c)).ravel()  # the transient step
        want, logs = [], []
        if not tangent:
            for _ in range(4):
                s = np.asarray(step(s, p[j], hs[j], t0s[j], c)).ravel()
                want.append(s[:n])
            ok = np.array_equal(np.array(want[1::2]), outs[0][j])
        else:
            fn = stage
            z, k, v = s[:n], s[n], np.eye(n)[0]
            h, half = hs[j], hs[j] / 2
            for i in range(4):
                t = t0s[j] + k * h
                a = [np.asarray(x).ravel() for x in fn(t, z, p[j], v)]
                b = [np.asarray(x).ravel() for x in fn(t + half, z + half * a[0], p[j],
                                                       v + half * a[1])]
                c3 = [np.asarray(x).ravel() for x in fn(t + half, z + half * b[0], p[j],
                                                        v + half * b[1])]
                e = [np.asarray(x).ravel() for x in fn(t + h, z + h * c3[0], p[j],
                                                       v + h * c3[1])]
                z = z + h / 6 * (a[0] + 2 * b[0] + 2 * c3[0] + e[0])
                v = v + h / 6 * (a[1] + 2 * b[1] + 2 * c3[1] + e[1])
                k += 1
                if i % 2 == 1:
                    norm = np.linalg.norm(v)
                    logs.append(np.log(norm))
                    v = v / norm
                    want.append(z)
            scale = np.abs(np.array(want)).max(axis=0) + 1e-300
            ok = np.all(np.abs(np.array(want) - outs[0][j]) <= SELF_TEST_TOL * scale) \
                and np.allclose(logs, outs[1][j], rtol=SELF_TEST_TOL, atol=1e-14)
        if not ok:
            raise CompileError(f"the member kernel of {model.name} does not reproduce "
                               "CasADi (check BEARINGDYN_CFLAGS: no fast-math)")


def _self_test_inputs(model, n: int) -> list[np.ndarray]:
    """The self-test's two members: z0, k0, p, h, t0, limit."""
    p0 = model.parameter_vector(model.defaults)
    h0 = float(model.simulation_defaults["dt"])
    return [np.stack([test_state(n) * (1 + 0.1 * j) for j in range(2)]),
            np.array([3.0, 4.0]), np.stack([p0 * (1 + 0.01 * j) for j in range(2)]),
            h0 * np.array([1.0, 1.05]), np.array([0.0, 0.1]), np.full(2, np.inf)]


@cache
def _self_test_gpu(model, structure: tuple[int, ...], tangent: bool) -> None:
    """The CUDA build against the CPU build (itself checked against CasADi) on the
    self-test's members over 20 steps: sections and logs to ``GPU_SELF_TEST_TOL``.
    ``CompileError`` when they disagree. Once per process."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels.cuda import cuda_kernel

    _self_test(model, structure, tangent)
    n = model.n_state
    inputs = [np.ascontiguousarray(a) for a in _self_test_inputs(model, n)]
    inputs += Schedule(2, 6, 3).per_member(2)
    results = []
    for device in ("cpu", "gpu"):
        outs = [np.empty((2, 3, n)), np.empty((2, 3)), np.empty((2, n)),
                np.empty(2, dtype=np.int64), np.empty((2, n)), np.empty((2, n))]
        if device == "cpu":
            cpu_library(model, structure, tangent).run(2, 1, inputs, 3, True, outs)
        else:
            cuda_kernel(model, structure, tangent).run(2, inputs, 3, True, outs)
        results.append(outs)
    (cpu, gpu) = results
    scale = np.abs(cpu[0]).max(axis=(0, 1)) + 1e-300
    ok = np.all(np.abs(gpu[0] - cpu[0]) <= GPU_SELF_TEST_TOL * scale) \
        and np.array_equal(gpu[3], cpu[3])
    if tangent:
        ok = ok and np.allclose(gpu[1], cpu[1], rtol=GPU_SELF_TEST_TOL, atol=1e-12)
    if not ok:
        raise CompileError(f"the CUDA member kernel of {model.name} does not reproduce the "
                           "CPU build (NVRTC options: see kernels/cuda.py)")


def check_kernels(systems: Iterable[System], device: str | Placement,
                  tangent: bool = False) -> None:
    """Build, or load from the cache, and self-test the member kernel (the state variant,
    or the tangent variant with ``tangent``) of each model and balls among ``systems``
    (``System``s) on ``device`` (a ``Placement``, or ``"cpu"`` or ``"gpu"``), before a run's
    work: ``placement.place`` with these systems (a run that places its device itself
    builds them there). ``DeviceError``, one line naming ``device``, the model and its balls
    and the reason, when the kernel cannot be written, built or loaded, or when no GPU can
    be used."""
    place(device, 1, list(systems), "tangent" if tangent else "state")


def unbuildable(system: System, device: str, exc: Exception) -> DeviceError:
    """The one line of a member kernel of ``system`` that cannot be written or built on
    ``device`` (``exc``: why; a compiler's lines joined by ``;``)."""
    reason = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    balls = ", ".join(str(n) for n in system.structure)
    return DeviceError(str(device), f"the member kernel of model '{system.model.name}' with "
                                    f"N_b {balls} cannot be built: {reason}")
