"""Costs said before they are paid: the RK4 steps a long command will take and about how
long they will run, from a timed probe of the path that will run them.

One module computes the estimate; every long command (chart, basins, attractors, sweep,
calibrate, torus, hb) calls ``estimate_cost`` with its members (grid points, initial
states, particles, harmonic-balance points) and the RK4 steps each takes, and prints
``CostEstimate.lines()`` to stderr before the work starts. The estimate is

    seconds = steps per member x members x (measured seconds per RK4 step) / workers,

the seconds per step measured on the path the command's steps take (``path``): the member
kernels (``KERNELS``: charts, no-follow sweeps, basins, attractors, calibrate, uncertainty)
are timed by ``probe_kernel``, a block of members on as many threads of the CPU build as the
command has workers (so that a loaded machine's share is measured, not guessed), sized to
about ``KERNEL_PROBE_SECONDS``, the best of two; a step that carries the tangent of λ1 is
counted by its measured cost (``tangent_step_factor``: 1.5–1.7 state steps in the scalar
build, 0.7–0.8 in the lanes build on the development machine; it was counted as 2). The
compiled RK4 blocks (``COMPILED``: ``simulate``, a followed
sweep, the runs of ``hb`` and ``torus``) are timed by ``probe_step_seconds``, sized to about
``COMPILED_PROBE_SECONDS``. The compiled probe of 400 steps (a millisecond: on a loaded
machine a burst of a whole core) stood in for the kernels before and was 1.5–5× off
(issue 39).

The probe measures the machine as it is: ``os.getloadavg`` and the CPU share the probe got
are recorded, and on a loaded machine the estimate says so in a line of its own (it assumes
that load) instead of being silently off. Where a coarser step (within the run plan's
checks: the RK4 stability limit and 20 steps per period of the fastest forcing) or fewer
members would bring a long estimate down, ``advice`` says so. Nothing here prints: the
command line renders.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from analysis.errors import InputError
from analysis.model import System

PROBE_STEPS = 400
"""RK4 steps of the compiled probe's first timed run (after one untimed warm-up block)."""
COMPILED_PROBE_SECONDS = 0.04
"""About how long (s) each timed run of the compiled probe lasts."""
RK4_STEPS = "RK4 steps"
"""The default unit of ``CostEstimate.steps``."""
LONG = 60.0
"""An estimate above this many seconds comes with advice (a coarser step, fewer members)."""
KERNELS = "kernels"
"""``estimate_cost``'s path: the member kernels (``analysis.integrate.kernels``)."""
COMPILED = "compiled"
"""``estimate_cost``'s path: the compiled RK4 blocks (``analysis.integrate.compiled``)."""
KERNEL_PROBE_SECONDS = 0.08
"""About how long (s) each timed run of the kernel probe lasts (one thread)."""
KERNEL_PROBE_MEMBERS = 32
"""Members of the kernel probe's block."""
BUSY = 0.8
"""A probe that got less than this share of a core (CPU s / wall s) competed for it."""


@dataclass(frozen=True)
class CostEstimate:
    """The cost of ``members`` runs of ``steps`` RK4 steps each (of ``dt`` s) on ``workers``
    workers, at ``step_seconds`` s per step of one member (measured). ``coarsest_dt``: the
    largest step the run plan accepts for this System (None: not known), ``what``: the
    members' name in the lines (``points``, ``initial states``); ``unit``: what ``steps``
    counts (RK4 steps by default)."""

    members: int
    steps: int
    workers: int
    step_seconds: float
    dt: float
    coarsest_dt: float | None = None
    what: str = "points"
    bound: bool = False
    """``steps`` is an upper bound (a member may stop early: the recurrence mapper)."""
    unit: str = RK4_STEPS
    """What ``steps`` counts: RK4 steps of ``dt`` s, or another unit of work (``Newton
    iterations`` of harmonic balance: ``dt`` unused, ``step_seconds`` per iteration)."""
    average: bool = False
    """``steps`` is the members' mean (a grid whose points record different times)."""
    expected_seconds: float | None = None
    """With ``bound``: the expected wall time (s) from a probe that ran whole members
    (``probe_note`` says which), where the bound alone would overstate it; None: the
    expectation is the bound. Not capped by the bound: the bound counts the steps alone,
    the probe the host's work between them too (the recurrence mapper's checks: basins
    took 3.6x the bound of their steps)."""
    probe_note: str = ""
    spent: float = 0.0
    """Seconds the command had run when the estimate was made: its start-up and the probes
    (``process_seconds``)."""
    also: tuple[tuple[str, float], ...] = ()
    """The rest of the command's work, each part named with its expected seconds (files,
    figures, error-estimate solves, λ1, the host's work)."""
    kernel_note: str = ""
    """What the probe timed (``member kernel probed``, ``member kernel probed, tangent
    x1.68 on 60% of the steps``); empty: the compiled RK4 blocks (``probed``)."""
    load: float | None = None
    """The 1-minute load average when the probe ran (None: not known)."""
    cores: int = 0
    """The cores this process may use (``analysis.threads.thread_count``)."""
    busy: float | None = None
    """The share of a core the probe got (CPU s / wall s; None: not measured)."""
    probe_threads: int = 1
    """Threads the probe ran on at once (the workers', ``probe_kernel``)."""
    balance: float = 1.0
    """The busiest worker's members over an even share (>= 1: blocks of members that do not
    deal evenly to the workers, ``busiest_share``); the steps take that much longer."""

    def load_lines(self) -> list[str]:
        """One line when the probe ran on a loaded machine (the load average above the
        cores, or a probe that got less than ``BUSY`` of a core), else none."""
        return load_lines(self.load, self.cores, self.busy, self.probe_threads)

    @property
    def whole_seconds(self) -> float:
        """The whole command's expected wall time, s: what was spent before the estimate,
        the steps (``seconds``) and every part of ``also``."""
        return self.spent + self.seconds + sum(s for _, s in self.also)

    def with_parts(self, *parts: tuple[str, float]) -> CostEstimate:
        """This estimate with more named parts of the command's work."""
        return replace(self, also=self.also + tuple((n, float(s)) for n, s in parts))

    def whole_line(self) -> str:
        """'in all about 6 s: 2.1 s start-up and probes so far, 1 s the file, …'."""
        parts = [(f"{self.spent:.2g} s start-up and probes so far", self.spent),
                 (f"{duration_text(self.seconds).removeprefix('about ')} the "
                  f"{self.unit if self.unit != RK4_STEPS else 'RK4 steps'}", self.seconds),
                 *((f"{duration_text(sec).removeprefix('about ')} {name}", sec)
                   for name, sec in self.also)]
        return (f"estimate: in all {duration_text(self.whole_seconds)} for the whole command ("
                + ", ".join(text for text, _ in parts) + ")")

    @property
    def total_steps(self) -> int:
        """RK4 steps of every member together."""
        return self.members * self.steps

    @property
    def bound_seconds(self) -> float:
        """Wall time (s) of every member running all its ``steps`` (the busiest worker's:
        ``balance``)."""
        return (self.total_steps * self.step_seconds * self.balance
                / max(1, min(self.workers, self.members)))

    @property
    def seconds(self) -> float:
        """Expected wall time, s: the probe's expectation where one ran whole members, else
        the steps' (their bound)."""
        if self.expected_seconds is not None:
            return self.expected_seconds
        return self.bound_seconds

    def lines(self) -> list[str]:
        """The estimate in words (one line), then the advice (none, one or two lines)."""
        steps = f"up to {self.steps:,}" if self.bound else f"{self.steps:,}"
        if self.average:
            steps = f"{steps} (mean)"
        if self.unit == RK4_STEPS:
            unit, total = f"RK4 steps (dt = {self.dt:.3g} s)", "steps"
            each = f"{self.step_seconds * 1e6:.3g} us per step"
        else:
            unit, total = self.unit, self.unit.split()[-1]
            each = f"{self.step_seconds:.3g} s per {total.removesuffix('s')}"
        workers: int | str = min(self.workers, self.members)
        if self.balance > 1.005:
            workers = f"{workers} (blocks uneven over them: x{self.balance:.2f})"
        if self.bound and self.expected_seconds is not None:
            expected = (f"expected {duration_text(self.seconds)} on {workers} worker(s) "
                        f"({self.probe_note}); the steps alone at most "
                        f"{duration_text(self.bound_seconds)} ({each}, "
                        f"{self.kernel_note or 'probed'})")
        else:
            expected = (f"expected {'at most ' if self.bound else ''}"
                        f"{duration_text(self.seconds)} on {workers} worker(s) ({each}, "
                        f"{self.kernel_note or 'probed'})")
        head = (f"estimate: {self.members:,} {self.what} x {steps} {unit} = "
                f"{self.total_steps:.3g} {total}; {expected}")
        whole = [self.whole_line()] if self.spent or self.also else []
        return [head, *self.load_lines(), *self.advice(), *whole]

    def advice(self) -> list[str]:
        """What would make a long run shorter: a coarser ``--dt`` the plan accepts, fewer
        members. Empty when the estimate is under ``LONG`` seconds."""
        if self.seconds <= LONG:
            return []
        found = []
        if self.coarsest_dt is not None and self.coarsest_dt > 1.5 * self.dt:
            gain = self.coarsest_dt / self.dt
            found.append(f"hint: --dt {nice_down(self.coarsest_dt):.3g} (within the run "
                         f"plan's checks) would take {duration_text(self.seconds / gain)}")
        if self.members >= 4:
            fewer = max(1, self.members // 4)
            found.append(f"hint: {fewer:,} {self.what} instead of {self.members:,} would take "
                         f"{duration_text(self.seconds * fewer / self.members)}")
        return found


def busiest_share(members: int, block: int, workers: int,
                  sizes: Sequence[int] | None = None) -> float:
    """How much longer than an even share the busiest of ``workers`` runs when ``members``
    go in blocks of ``block`` (the last one smaller; or blocks of the given ``sizes``), each
    block to the first free worker (an executor's queue, blocks of equal cost per member):
    its members over an even share of the workers that get a block; 1 for one worker."""
    if sizes is None:
        step = max(1, int(block))
        sizes = [min(step, int(members) - start) for start in range(0, int(members), step)]
    total = sum(sizes)
    if workers <= 1 or total <= 0:
        return 1.0
    loads = [0] * int(workers)
    for size in sizes:
        loads[loads.index(min(loads))] += int(size)
    return max(loads) * min(int(workers), len(sizes)) / total


def load_lines(load: float | None, cores: int, busy: float | None = None,
               threads: int = 1) -> list[str]:
    """``['note: the machine was loaded (load 3.1 on 2 cores): the estimate assumes that
    load']`` when the 1-minute ``load`` average was above ``cores`` or the probe's
    ``threads`` got less than ``BUSY`` of a core each (``busy``), else ``[]``."""
    over = load is not None and cores > 0 and load > cores
    competed = busy is not None and busy < BUSY
    if not (over or competed):
        return []
    seen = f"load {load:.1f} on {cores} core{'s' if cores != 1 else ''}" \
        if load is not None else f"{cores} cores"
    share = ""
    if competed:
        share = (f", the probe got {busy:.0%} of a core" if threads == 1 else
                 f", the probe's {threads} threads got {busy:.0%} of a core each")
    return [f"note: the machine was loaded ({seen}{share}): the estimate assumes that load"]


def machine_load() -> float | None:
    """The 1-minute load average (``os.getloadavg``); None where the system does not say."""
    try:
        return float(os.getloadavg()[0])
    except (OSError, AttributeError):
        return None


def with_load(estimate: CostEstimate, load: float | None = None,
              busy: float | None = None) -> CostEstimate:
    """``estimate`` with the machine's load seen now (``load``: given, else
    ``machine_load()``), the cores this process may use and the probe's share of a core."""
    from analysis.threads import thread_count

    seen = machine_load() if load is None else float(load)
    return replace(estimate, load=seen, cores=thread_count(),
                   busy=estimate.busy if busy is None else busy)


FILE_SECONDS = 1.0
"""Expected seconds to write a result file or a figure (the netCDF or matplotlib import
included: 0.5–1.6 s on the two-core development machine, more under load)."""


def process_seconds() -> float:
    """Wall seconds since this process started (its start-up, imports and probes so far);
    0 where the system does not say (Linux's /proc)."""
    try:
        with open("/proc/self/stat") as stat:
            ticks = int(stat.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as uptime:
            up = float(uptime.read().split()[0])
        return max(0.0, up - ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        return 0.0


def duration_text(seconds: float) -> str:
    """``under a second``, ``about 42 s``, ``about 3.5 min``, ``about 2.1 h``."""
    if seconds < 1:
        return "under a second"
    if seconds < 90:
        return f"about {seconds:.0f} s"
    if seconds < 5400:
        return f"about {seconds / 60:.1f} min"
    return f"about {seconds / 3600:.1f} h"


def nice_down(value: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above ``value`` (a step a user types)."""
    scale = 10.0 ** math.floor(math.log10(value))
    return max(m * scale for m in (1, 2, 5) if m * scale <= value * (1 + 1e-12))


def coarsest_step(system: System) -> float | None:
    """The largest RK4 step (s) the run plan accepts for ``system`` without a warning: below
    the RK4 stability limit and with at least ``RESOLUTION_WARN`` steps per period of the
    fastest forcing; None when it cannot be said."""
    from analysis.integrate.checks import RESOLUTION_WARN, fastest_forcing, stable_step
    from analysis.integrate.plan import RunPlan

    try:
        limit = stable_step(system)[0]
        freq = fastest_forcing(system)[1]
        if freq > 0:
            limit = min(limit, 1.0 / (RESOLUTION_WARN * freq))
        if not math.isfinite(limit) or limit <= 0:
            return None
        dt = nice_down(limit)
        RunPlan.step(system, dt, warn=lambda message: None)  # the plan's own checks
        return dt
    except (InputError, ValueError, ArithmeticError):
        return None


def probe_step_seconds(system: System, dt: float, steps: int = PROBE_STEPS,
                       compiled: bool = True,
                       seconds: float = COMPILED_PROBE_SECONDS) -> float:
    """Seconds one RK4 step of ``system`` takes on the compiled path (``compiled=False``: the
    CasADi VM), measured from its initial state after an untimed warm-up (which also builds
    or loads the library): ``steps`` steps, then, when they took less than ``seconds`` s,
    the best of two runs sized to about ``seconds`` (at most 2,000,000 steps)."""
    from analysis.integrate.compiled import library, run_rk4

    lib = library(system.model, system.structure, compiled)
    p = np.asarray(system.p, dtype=float)
    z0 = np.asarray(system.state, dtype=float)
    run_rk4(lib, p, z0, dt, 8)  # warm-up: the library loaded, the buffers made
    first = best_seconds(lambda: run_rk4(lib, p, z0, dt, steps), repeat=1)
    if first >= seconds:
        return first / steps
    count = int(min(2_000_000, max(steps, steps * seconds / max(first, 1e-6))))
    return best_seconds(lambda: run_rk4(lib, p, z0, dt, count)) / count


def best_seconds(run: Callable[[], object], repeat: int = 2) -> float:
    """The shortest wall time (s) of ``repeat`` calls of ``run`` (a probe's timing)."""
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


@dataclass(frozen=True)
class KernelProbe:
    """A timed probe of the member kernels of a System (``probe_kernel``)."""

    step_seconds: float
    """Seconds of one RK4 step of one member (state only) on one of the ``threads``
    threads of the CPU build, all of them running: members x steps x this / threads is
    the wall time of a run."""
    tangent_factor: float | None = None
    """State steps one step with its tangent costs (measured, not clamped: the CPU build in
    blocks of lanes ran the tangent variant at 0.81x a state step; None: not probed)."""
    busy: float = 1.0
    """The share of a core each thread of the timed runs got (CPU s / wall s / threads)."""
    threads: int = 1
    """Threads the timed runs ran on at once."""


def probe_kernel(system: System, dt: float, *, tangent: bool = False,
                 members: int = KERNEL_PROBE_MEMBERS, seconds: float = KERNEL_PROBE_SECONDS,
                 steps: int | None = None, repeat: int = 2,
                 threads: int = 1) -> KernelProbe | None:
    """Time the member kernel of ``system`` (and, with ``tangent``, its tangent variant: one
    tangent vector, renormalised at six sections) as the commands run it: ``members``
    members per thread from the System's state on ``threads`` threads of the CPU build at
    once (the command's workers: on a loaded machine they share what it gives, which one
    thread alone does not show: a process got 0.69 of a core with one thread and with
    two), with RK4 steps of ``dt`` s. ``steps`` per member (None: sized by a first run so
    that each timed run lasts about ``seconds`` s, 120 to 200,000); the best of ``repeat``
    runs each way. None when the member kernel cannot be built here (no compiler, an
    operation its writer does not know)."""
    from analysis.integrate.compiled import CompileError
    from analysis.integrate.kernels import Schedule, Unsupported, run_members

    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"dt: a finite RK4 step > 0 s, got {dt!r}")
    threads = max(1, int(threads))
    z = np.tile(np.asarray(system.state, dtype=float), (int(members) * threads, 1))

    def schedule(count: int, with_tangent: bool):
        every = max(1, count // 6)
        if with_tangent:
            return Schedule(count - 6 * every, every, 6, tangent=True, keep_sections=False)
        return Schedule(0, count, 1, keep_sections=False)

    def timed(sched) -> tuple[float, float]:
        best, cpu = math.inf, 0.0
        for _ in range(repeat):
            start, used = time.perf_counter(), time.process_time()
            run_members(system, z, None, dt, sched, threads=threads)
            wall = time.perf_counter() - start
            if wall < best:
                best, cpu = wall, time.process_time() - used
        return best, cpu

    try:
        run_members(system, z[:1], None, dt, schedule(12, tangent), threads=1)  # loaded
        if tangent:
            run_members(system, z[:1], None, dt, schedule(12, False), threads=1)
        if steps is None:
            first = 120
            size, _ = timed(schedule(first, False))
            steps = first * seconds / max(size, 1e-6)
        count = int(min(200_000, max(120, steps)))
        state, cpu = timed(schedule(count, False))
        factor, walls, cpus = None, state, cpu
        if tangent:
            with_tangent, cpu_t = timed(schedule(count, True))
            factor = with_tangent / state  # below 1 too: the lanes build's tangent was 0.81x
            walls, cpus = walls + with_tangent, cpus + cpu_t
    except (Unsupported, CompileError, InputError):  # no build, or a block it refuses
        return None
    busy = min(1.0, cpus / walls / threads) if walls > 0 else 1.0
    return KernelProbe(state * threads / (count * len(z)), factor, busy, threads)


def steady_seconds(run: Callable[[], object], seconds: float = 0.05,
                   most: int = 1000) -> float:
    """The mean wall time (s) of one call of ``run``, over as many calls (one at least,
    ``most`` at most) as fill about ``seconds`` s: a short call timed once may get a burst of
    a whole core on a loaded machine that the command's minutes do not."""
    calls, start = 0, time.perf_counter()
    while True:
        run()
        calls += 1
        elapsed = time.perf_counter() - start
        if elapsed >= seconds or calls >= most:
            return elapsed / calls


def tangent_step_factor(system: System, dt: float, members: int = 64,
                        steps: int = 240) -> float | None:
    """How many state steps one RK4 step with its tangent (λ1, the member kernels' tangent
    variant: one Jacobian–vector product per stage) costs for ``system``, timed on one thread
    of the CPU build (``probe_kernel``): ``members`` members of ``steps`` steps each way, the
    faster of two runs each. None when the member kernel cannot be built here (the scalar
    path then carries the tangent's ``n`` columns: ``n + 1``). ``dt``: the RK4 step (s)."""
    probe = probe_kernel(system, dt, tangent=True, members=members, steps=steps)
    return None if probe is None else probe.tangent_factor


def estimate_cost(system: System, members: int, steps: int, *, dt: float,
                  workers: int | None = None, what: str = "points",
                  compiled: bool = True, bound: bool = False, path: str = COMPILED,
                  tangent_steps: int = 0, load: float | None = None) -> CostEstimate:
    """The cost of ``members`` runs of ``steps`` RK4 steps of ``dt`` s each of ``system``
    (or of systems like it: the points of a grid) on ``workers`` workers (default: the
    cores), from a timed probe of the ``path`` that runs them: ``KERNELS``, the member
    kernels (``probe_kernel`` on as many threads as the workers, the cores at most;
    ``tangent_steps`` of the ``steps`` carry λ1's tangent, each counted by the measured
    ``tangent_factor``), or ``COMPILED``, the compiled RK4 blocks (``probe_step_seconds``;
    ``compiled=False``: the CasADi VM).
    Where the member kernel cannot be built the compiled probe stands in, the tangent as
    ``n`` more states (the scalar path's columns). ``load``: the 1-minute load average to
    report (None: read now, ``os.getloadavg``)."""
    if path not in (KERNELS, COMPILED):
        raise InputError(f"path: '{KERNELS}' or '{COMPILED}', got {path!r}")
    if not 0 <= tangent_steps <= steps:
        raise InputError(f"tangent_steps: a whole number in [0, steps = {steps}], got "
                         f"{tangent_steps!r}")
    from analysis.threads import thread_count

    seen = machine_load() if load is None else float(load)
    count = int(workers or os.cpu_count() or 1)
    threads = max(1, min(count, thread_count(), int(members)))
    probe = probe_kernel(system, dt, tangent=tangent_steps > 0, threads=threads) \
        if path == KERNELS else None
    busy, note = None, ""
    if probe is not None:
        factor = probe.tangent_factor or 1.0
        seconds = probe.step_seconds * (1 + (factor - 1) * tangent_steps / max(1, steps))
        busy, note = probe.busy, "member kernel probed"
        if tangent_steps:
            note += (f", tangent x{factor:.2f} on {tangent_steps / max(1, steps):.0%} of the "
                     "steps")
    else:  # one thread: the compiled path runs one trajectory a worker
        seconds = probe_step_seconds(system, dt, compiled=compiled)
        seconds *= 1 + system.n_state * tangent_steps / max(1, steps)
    estimate = CostEstimate(members=int(members), steps=int(steps), workers=count,
                            step_seconds=seconds, dt=float(dt),
                            coarsest_dt=coarsest_step(system), what=what, bound=bound,
                            spent=process_seconds(), kernel_note=note,
                            probe_threads=threads if probe is not None else 1)
    return with_load(estimate, seen, busy)
