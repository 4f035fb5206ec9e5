"""Bifurcation diagrams: one runtime parameter of the model (speed, clearance, load,
unbalance, damping, …) or its structure (``n_balls`` for a model with one bearing,
``n_balls[left]`` for the bearing ``left`` of a model with several) on a grid
(``analysis.sweeps.grid``); at each value the motion is simulated, the transient dropped and
``samples`` Poincaré points of every state variable kept. With ``follow=True`` each value
continues the previous one, up and/or down the grid (hysteresis shows as different
branches).

Following keeps the forcing phase. The model is non-autonomous: its forcing depends on time
only through angles ω_j·t (each bearing's cage angle, the shaft angle of the unbalance, a
forcing period of its own), so a state belongs with the angles at its time. A followed value
starts from the previous value's end state z(t_end) at the time

    t_start = t_end · T_new / T_old      (T: the period of the section, s)

at which the new value has run as many section periods as the old one had at t_end. Its
section angle is then exactly the old one, and so is every other forcing angle when the grid
parameter scales all forcing frequencies by one factor (the speed: shaft, cages and VC are
proportional to it) or leaves them unchanged (in the shipped models: load, damping,
clearance, unbalance, …). Where it changes their ratios (``n_balls``, race diameters) only
the section's angle is carried: no start time matches incommensurate angles all at once.

Why not restart at t = 0 (what following did before): the end state lies at some fraction
of a section period past a section time (and, with several forcing frequencies, at some
phase of the others), so the restart kicks the rotor by about the orbit's size and lets it
fall onto whatever attractor coexists (the period-3 orbit of the balanced rotor at 50 N,
say). Why not keep t_end itself: at a new speed the angles at t_end differ from the old
ones by Δω·t_end, many turns after a few values. Why not restart at t = 0 from the last
section point: exact for a single forcing frequency, but it drops the phase of any other
(the shaft angle of an unbalanced rotor on the VC section). Time runs on along a chain (a
few tens of seconds for a hundred values: the angles lose no significant accuracy); each
run's start time is stored with its point (``t_start`` in the result), so a resumed chain
continues bit for bit.

A diagram runs through one executor (``analysis.sweeps.executors``: serial, local processes
or Dask) and stores each finished point at once (``analysis.sweeps.store``): re-running an
interrupted command computes only the missing points. Followed chains write their points
from the worker (a Dask cluster on several machines needs a shared file system for them).
A brute-force diagram on the member kernels (``device``) stores each call's
``ENSEMBLE_BLOCK`` values as one entry (``PointStore.save_block``) and resumes from the
last stored block.

A diagram is a study plan (``analysis.integrate.study``): ``plan_diagram`` runs its every
check once (the direction, the grid, a device only without following, the device judged
once) and returns a ``DiagramPlan``, which the one runner
(``analysis.sweeps.runner.run_study``) runs; ``bifurcation_diagram`` is the two in one call.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError, ParameterError, SimulationError
from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.cost import CostEstimate
from analysis.integrate.kernels import (
    Schedule,
    blow_up_error,
    run_members,
    section_step,
)
from analysis.integrate.kernels.placement import Placement
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import blow_up_limit, check_bounded
from analysis.integrate.study import Progress, Say
from analysis.model import System, as_system
from analysis.provenance import completed_attrs, state_at, to_dataset
from analysis.signal.phasor import phasor_fields, phasor_record
from analysis.signal.poincare import poincare_section
from analysis.stability.classify import failure_text
from analysis.sweeps.executors import Executor, run_with_progress
from analysis.sweeps.grid import (
    Axis,
    Setting,
    amplitude_fields,
    amplitudes,
    check_grid,
    grid_cost,
    record,
)
from analysis.sweeps.runner import run_study
from analysis.sweeps.store import PointStore


@dataclass(frozen=True)
class Start:
    """Where a value's run starts: ``state`` (SI, the model's order) at time ``time`` (s)."""

    state: tuple[float, ...]
    time: float = 0.0


def record_from(setting: Setting, system: System, start: Start) -> xr.Dataset:
    """Like ``record`` but from ``start.state`` at t = ``start.time``: fixed-step RK4 on
    t = start.time + n·dt (the integrator's own times), the transient dropped.
    (``simulate`` always starts at t = 0.)"""
    model = system.model
    system = as_system(system, None, start.state)
    run = setting.plan(system, start.time)
    duration, dt, n_steps = run.duration, run.dt, run.n_steps
    states = run_rk4(library(model, system.structure), system.p, system.state, dt, n_steps,
                     t0=start.time)
    elapsed = np.arange(n_steps + 1) * dt
    check_bounded(states, start.time + elapsed, blow_up_limit(model, dict(system.parameters)),
                  model.centre_indices())
    keep = elapsed >= setting.transient - 1e-12 * duration
    attrs = completed_attrs(system, **run.settings(), initial_state=True)
    return to_dataset(start.time + elapsed[keep], states[:, keep], attrs, model)


def diagram_point(setting: Setting, system: System, start: Start | None = None) -> dict:
    """Poincaré samples of every state variable, amplitudes, the 1X amplitude and phase of
    the first body's displacements (``analysis.signal.phasor.phasor_record``), and the
    run's start and end (``t_start``, ``t_final`` in s, ``final`` the end state) at one grid
    value; from the spec's initial state at t = 0 without ``start``."""
    if start is None:
        ds, t_start = record(setting, system), 0.0
    else:
        ds, t_start = record_from(setting, system, start), start.time
    pts = poincare_section(ds, setting.record_section)
    k = setting.samples
    out = {v: pts[v].values[:k] for v in ds.attrs["state_names"].split()}
    out["final"] = state_at(ds, -1)
    out["t_start"] = t_start
    out["t_final"] = float(ds.t[-1])
    out.update(amplitudes(ds))
    out.update(phasor_record(ds))
    return out


def follow_start(setting: Setting, previous: System, point: Mapping, system: System) -> Start:
    """Start of a followed value ``system`` after the ``previous`` one ended as ``point`` (a
    result of ``diagram_point``): its end state at the time with the same section phase,
    t = t_final·T_new/T_old (s; see the module docstring)."""
    periods = float(point["t_final"]) / setting.period(previous)
    return Start(tuple(np.asarray(point["final"], dtype=float)),
                 periods * setting.period(system))


FOLLOW_RESTART = "end state at the same section phase"
"""How a followed value starts (``follow_start``); part of a diagram's stored definition
and of its attrs (``follow_restart``)."""


@dataclass(frozen=True)
class Chain:
    """One direction of a diagram: grid indices in order, run by one worker."""

    setting: Setting
    axis: Axis
    direction: str
    follow: bool
    output: str
    definition: dict = field(hash=False, compare=False)

    def order(self) -> list[int]:
        idx = list(range(len(self.axis.values)))
        return idx if self.direction == "up" else idx[::-1]

    def system(self, i: int) -> System:
        """The System of grid index ``i``."""
        return self.setting.system_at(**{self.axis.name: self.axis.values[i]})


def run_chain(chain: Chain) -> int:
    """Compute the missing points of one chain in order, storing each as it finishes; a
    followed value starts where the previous one ended (``follow_start``)."""
    store = PointStore(chain.output, chain.definition)
    done, computed = store.done(), 0
    previous, point = None, None
    for i in chain.order():
        key = f"{chain.direction}-{i:05d}"
        system = chain.system(i)
        if key in done:
            point = store.load(key)
        else:
            start = follow_start(chain.setting, previous, point, system) \
                if chain.follow and point is not None else None
            point = safe_diagram_point(chain.setting, system, start)
            store.save(key, point)
            computed += 1
        if str(point.get("status", "")):
            point = None  # a failed value: the next one starts from the initial state
        previous = system
    return computed


def safe_diagram_point(setting: Setting, system: System, start: Start | None = None) -> dict:
    """``diagram_point``, or for a value whose run fails a record of it (``status``
    ``failed: …``, no section points, NaN amplitudes) so the diagram goes on."""
    try:
        return {**diagram_point(setting, system, start), "status": ""}
    except SimulationError as exc:
        return _failed(system.model, exc)


def _failed(model, exc: SimulationError) -> dict:
    """The record of a value whose run failed (``status`` ``failed: …``)."""
    return {**{v: np.zeros(0) for v in model.state_names},
            "final": np.full(model.n_state, np.nan), "t_start": np.nan,
            "t_final": np.nan, "status": failure_text(exc),
            **dict.fromkeys(amplitude_fields(model), np.nan),
            **dict.fromkeys(phasor_fields(_displacements(model)), np.nan)}


ENSEMBLE_BLOCK = {"cpu": 64, "gpu": 1 << 15}
"""Values per call of the member kernels in a brute-force diagram (``device`` given), and
per store write: an interrupted diagram resumes from the last stored block."""


def ensemble_points(setting: Setting, systems: list[System],
                    device: str = "cpu") -> list[dict]:
    """``safe_diagram_point`` of several values (no following: each from its initial
    state at t = 0) as members of one call of the member kernels per model and balls
    (``analysis.integrate.kernels``, the state variant, on ``device``).

    Each value's step is the largest h <= ``setting.step()`` dividing its record section's
    period (``kernels.section_step``), so its section points are states at steps (today's
    points interpolate between samples of h = dt: the step rule changes a non-chaotic
    value's points by the difference between the two RK4 solutions, ``O(dt⁴)``). Its
    amplitudes are the extremes over the record's steps (h instead of dt); the 1X phasor
    needs the whole record and is NaN here (the per-value path, ``device=None``, keeps it).
    """
    out: list = [None] * len(systems)
    groups: dict[tuple, list[int]] = {}
    for i, system in enumerate(systems):
        groups.setdefault((id(system.model), system.structure), []).append(i)
    dt = setting.step()
    for indices in groups.values():
        model = systems[indices[0]].model
        plans = []
        for i in indices:
            h, every = section_step(setting.period(systems[i]), dt)
            if i in (indices[0], indices[-1]):  # the whole check (the grid's at its corners)
                checked = setting.plan(systems[i], warn=lambda message: None)
            else:  # times only: 50 ms a value saved
                checked = RunPlan(systems[i], dt, setting.seconds(systems[i]),
                                  setting.transient)
                checked.check_kept()
            run = replace(checked, dt=h)  # h <= dt passes what dt passed
            first = max(1, -(-run.first // every))
            plans.append((h, every, first, run.first, run.n_steps))
        schedule = Schedule([(f - 1) * e for _, e, f, *_ in plans], [e for _, e, *_ in plans],
                            setting.samples, extremes_from=[a for *_, a, _ in plans],
                            extremes_to=[b for *_, b in plans])
        result = run_members(systems[indices[0]],
                             np.array([np.asarray(systems[i].state, float) for i in indices]),
                             np.array([systems[i].p for i in indices]),
                             np.array([h for h, *_ in plans]), schedule, device=device)
        names = [f[len("amplitude_"):] for f in amplitude_fields(model)]
        where = [model.state_names.index(v) for v in names]
        for j, i in enumerate(indices):
            h, last = plans[j][0], plans[j][-1]
            if result.diverged_at[j] >= 0:
                exc = blow_up_error(systems[i], int(result.diverged_at[j]), h,
                                    result.final[j])
                out[i] = _failed(model, exc)
                continue
            sections = result.sections[j, :setting.samples]
            out[i] = {**{v: sections[:, k] for k, v in enumerate(model.state_names)},
                      "final": result.final[j].copy(), "t_start": 0.0,
                      "t_final": float(max(last, schedule.per_member(len(plans))[0][j]
                                           + plans[j][1] * setting.samples) * h),
                      **{f"amplitude_{v}": float(result.high[j, k] - result.low[j, k]) / 2
                         for v, k in zip(names, where, strict=True)},
                      **dict.fromkeys(phasor_fields(_displacements(model)), np.nan),
                      "status": ""}
    return out


def _ensemble_task(chain: Chain, indices: list[int], device: str) -> list[tuple[str, dict]]:
    """One block of a brute-force diagram's values on the member kernels."""
    points = ensemble_points(chain.setting, [chain.system(i) for i in indices], device)
    return [(f"{chain.direction}-{i:05d}", point)
            for i, point in zip(indices, points, strict=True)]


def _padded(point: dict, samples: int) -> dict:
    """``point`` with section points of a failed value (none) as ``samples`` NaN, the shape
    of a good value's: the points of a block are stacked (``PointStore.save_block``), and
    the diagram's arrays hold NaN where a value has no point either way."""
    return {k: np.full(samples, np.nan) if np.ndim(v) == 1 and len(v) == 0 else v
            for k, v in point.items()}


def _displacements(model) -> tuple[str, ...]:
    """The first body's displacements of ``model`` (the variables of its 1X record)."""
    return tuple(name[len("amplitude_"):] for name in amplitude_fields(model))


def _point_task(args: tuple) -> tuple[str, dict]:
    """A diagram point without state following (parallel over the grid)."""
    chain, i = args
    return f"{chain.direction}-{i:05d}", safe_diagram_point(chain.setting, chain.system(i))


DIRECTIONS = {"up": ("up",), "down": ("down",), "both": ("up", "down")}
"""The chains of a diagram's ``direction``."""


@dataclass(frozen=True)
class DiagramPlan:
    """A brute-force bifurcation diagram, checked whole by ``plan_diagram``: a
    ``StudyPlan`` (``analysis.integrate.study``) run by
    ``analysis.sweeps.runner.run_study``.

    ``directions``: its chains in order (``up``, ``down``); ``placement``: where its values
    run as members of the member kernels (judged once), None value by value;
    ``definition``: its store's key."""

    setting: Setting
    axis: Axis
    output: Path
    directions: tuple[str, ...]
    follow: bool
    placement: Placement | None
    definition: dict = field(compare=False)

    kind = "diagram"
    unit = "points"

    @property
    def total(self) -> int:
        """The values of every chain."""
        return len(self.directions) * len(self.axis.values)

    def cost(self, workers: int) -> CostEstimate:
        """The diagram's cost (``grid.grid_cost``): a followed diagram runs one value at a
        time (on 1 worker, each value's whole work probed: ``safe_diagram_point``); without
        following its values are members of the member kernels (``KERNELS``) on
        ``workers``."""
        from analysis.integrate.cost import KERNELS

        setting = self.setting
        point = (lambda system: safe_diagram_point(setting, system)) if self.follow else None
        return grid_cost(setting, self.axis, workers=1 if self.follow else workers,
                         members_per_point=len(self.directions), lyapunov=False,
                         path=None if self.follow else KERNELS, point=point)

    def run(self, store: PointStore, executor: Executor, progress: Progress | None,
            say: Say | None = None) -> xr.Dataset:
        """The values ``store`` lacks: followed chains (one per direction, each on one
        worker, storing its points), blocks of ``ENSEMBLE_BLOCK`` values on the member
        kernels (``placement``), or value by value on ``executor``; the diagram of every
        value."""
        setting, axis, follow = self.setting, self.axis, self.follow
        directions, device, total = list(self.directions), self.placement, self.total
        chains = [Chain(setting, axis, d, follow, str(self.output), self.definition)
                  for d in directions]
        if follow:
            run_with_progress(executor, run_chain, chains, lambda: len(store.done()), total,
                              progress, None)
        elif device is not None:
            done = store.keys()  # a block's entry is named by its first key only
            stored = len(done)
            for chain in chains:
                todo = [i for i in range(len(axis.values))
                        if f"{chain.direction}-{i:05d}" not in done]
                size = ENSEMBLE_BLOCK[device]
                for start in range(0, len(todo), size):
                    block = _ensemble_task(chain, todo[start:start + size], device)
                    store.save_block([(key, _padded(point, setting.samples))
                                      for key, point in block])
                    stored += len(block)
                    if progress is not None:
                        progress(stored, total)
        else:
            todo = [(c, i) for c in chains for i in range(len(axis.values))
                    if f"{c.direction}-{i:05d}" not in store.done()]
            run_with_progress(executor, _point_task, todo, lambda: len(store.done()), total,
                              progress, lambda task, result: store.save(*result))
        return _assemble_diagram(store, setting, axis, directions, follow)


def plan_diagram(setting: Setting, axis: Axis, output: str | Path, *,
                 direction: str = "up", follow: bool = True,
                 device: str | Placement | None = None) -> DiagramPlan:
    """The ``DiagramPlan`` over ``axis`` written to ``output``, every input checked once
    before any value, store or estimate: ``direction`` (``up``, ``down`` or ``both``), the
    grid (``grid.check_grid``), ``device`` only without ``follow`` (a followed diagram is
    one trajectory), then the device and its state kernels (``points.grid_device``: the
    ``Placement`` the values take). ``InputError`` naming its field otherwise."""
    if direction not in DIRECTIONS:
        raise InputError(f"direction: must be up, down or both, got {direction!r}")
    directions = DIRECTIONS[direction]
    check_grid(setting, axis)
    placement = None
    if device is not None:
        if follow:
            raise ParameterError(
                "device", "{field}: the member kernels run the values of {unfollowed} "
                "(a followed {sweep} is one trajectory); {add}",
                {"unfollowed": ("a diagram with follow=False", "a --no-follow sweep"),
                 "sweep": ("diagram", "sweep"), "add": ("set follow=False", "add --no-follow")})
        from analysis.sweeps.points import grid_device  # the device and its kernels, first

        placement = grid_device(setting, [axis], device, len(axis.values) * len(directions))
    definition = {"kind": "diagram", "setting": asdict(setting), "axis": asdict(axis),
                  "structure": list(setting.loaded().structure(setting.n_balls)),
                  "directions": list(directions), "follow": follow}
    if follow:  # stores of the former restarts at t = 0 are not resumed with these
        definition["restart"] = FOLLOW_RESTART
    return DiagramPlan(setting, axis, Path(output), directions, follow, placement, definition)


def bifurcation_diagram(setting: Setting, axis: Axis, output: str | Path, *,
                        direction: str = "up", follow: bool = True,
                        executor: Executor | None = None,
                        progress: Callable[[int, int], None] | None = None,
                        on_damaged: Callable[[str], None] | None = None,
                        device: str | Placement | None = None) -> xr.Dataset:
    """Brute-force orbit diagram over ``axis``; writes and returns the netCDF Dataset
    (``run_study(plan_diagram(…))``).

    Resumable (``analysis.sweeps.store``): a stored point that cannot be read is removed,
    reported to ``on_damaged(key)`` and computed again. A value whose run fails is recorded
    (``status``: ``failed: …``) and the diagram goes on. ``device`` (``cpu``, ``gpu``,
    ``auto``; without ``follow`` only): the values run as members of the member kernels,
    ``ENSEMBLE_BLOCK`` per call (``ensemble_points``: sections on steps, no 1X phasor); None:
    value by value (``diagram_point``) through ``executor``."""
    return run_study(plan_diagram(setting, axis, output, direction=direction, follow=follow,
                                  device=device), executor, progress=progress,
                     on_damaged=on_damaged)


def _assemble_diagram(store: PointStore, setting: Setting, axis: Axis, directions: list[str],
                      follow: bool) -> xr.Dataset:
    n = len(axis.values)
    model = setting.loaded()
    units = model.state_units
    section = setting.record_section
    stored = store.points()  # single points (followed, value by value) and blocks (device)
    first = stored[f"{directions[0]}-{0:05d}"]
    arrays = {v: np.full((len(directions), n, setting.samples), np.nan)
              for v in model.state_names}
    amplitude_names = [v for v in first if v.startswith("amplitude_")]
    phasor_names = [v for v in phasor_fields(_displacements(model)) if v in first]
    per_value = {v: np.full((len(directions), n), np.nan)
                 for v in [*amplitude_names, *phasor_names, "t_start"]}
    status = np.full((len(directions), n), "", dtype=object)
    for d, direction in enumerate(directions):
        for i in range(n):
            point = stored[f"{direction}-{i:05d}"]
            for v in arrays:
                arrays[v][d, i, :len(point[v])] = point[v]
            for v in per_value:
                per_value[v][d, i] = point.get(v, np.nan)  # no 1X in an older store
            status[d, i] = str(point.get("status", ""))
    data = {v: (("direction", axis.name, "k"), arrays[v],
                {"units": units[v], "long_name": f"{v} on the {section} section"})
            for v in arrays}
    data.update({v: (("direction", axis.name), per_value[v],
                     {"units": units.get(v[len("amplitude_"):], "m")}) for v in amplitude_names})
    for v in phasor_names:  # the 1X record: amplitude (unit of the variable), lag (rad)
        amplitude, var = v.startswith("amplitude1x_"), v.partition("_")[2]
        data[v] = (("direction", axis.name), per_value[v],
                   {"units": units.get(var, "m") if amplitude else "rad",
                    "long_name": f"1X amplitude of {var}" if amplitude else
                    f"1X phase lag of {var} after the shaft's zero angle"})
    data["status"] = (("direction", axis.name), status.astype(str),
                      {"long_name": "empty, or why the value's run failed (failed: …)"})
    data["t_start"] = (("direction", axis.name), per_value["t_start"],
                       {"units": "s", "long_name": "time at which the value's run starts"})
    attrs = setting.attrs("diagram", section)
    attrs.update(param=axis.name, follow=int(follow))
    if follow:
        attrs.update(follow_restart=FOLLOW_RESTART)
    return xr.Dataset(data, coords={"direction": directions, axis.name: axis.coord(),
                                    "k": np.arange(setting.samples)}, attrs=attrs)
