"""Many runs of one System at once: initial states or parameter points, one compiled call.

An *ensemble* is K members of one model and balls, each its own initial state and
parameter values, all integrated with fixed-step RK4 by the same steps ``simulate`` takes:
the model's RK4 step with its parameter-only subexpressions computed once per call
(``tangent.tangent_step(rk4_step, Carry(constants=True))``, the step of the compiled blocks
of ``analysis.integrate.compiled``), step k running from ``k·h`` to ``(k + 1)·h`` (s). So
member i is ``simulate`` of its own System bit for bit (``np.array_equal``), whatever
members share its call.

Compiled, the members run in the member kernel's CPU build (``analysis.integrate.kernels``:
the step written as scalar C from the same SX Function, one member per OpenMP iteration on
every core, each member's numbers those of the scalar step); without it (``compiled=False``,
an operation the kernel writer does not know, no compiler, a failed self-test) one by one
through the RK4 blocks, with the same results. ``device="gpu"`` runs them in the kernel's
CUDA build instead (the same C text, equal to the CPU build to the last bits of CUDA's libm),
``"auto"`` there when the ensemble is wide enough; the device is judged once per call
(``kernels.placement.place``: a ``Placement``, which every level below takes as it is).

- ``StroboscopicMap``: the System sampled once per forcing period T, z_{j+1} = F(z_j) with
  N fixed RK4 steps of h = T/N; ``advance`` moves K rows ``[z, k]`` by whole periods.
- ``ensemble``: K members over a duration, as an ``xarray.Dataset`` over (member, t).

Members never stop each other: one that blows up stops at its first bad state and carries
NaN to the end of the call (one that overflows in the scalar blocks carries NaN or inf), its
neighbours unchanged; ``StroboscopicMap.diverged`` flags it (the blow-up rule of
``simulate.check_bounded``) and ``ensemble`` records when (``diverged_at``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.integrate.checks import check_start
from analysis.integrate.compiled import CompileError, Library, block_plan, library
from analysis.integrate.flow import Period, period_seconds, steps_per_period
from analysis.integrate.kernels.members import Schedule, unbuildable
from analysis.integrate.kernels.members import run_members as run_kernel
from analysis.integrate.kernels.placement import CPU, Placement, place
from analysis.integrate.kernels.source import Unsupported
from analysis.integrate.plan import RunPlan, check_memory
from analysis.integrate.simulate import bad_states, blow_up_limit
from analysis.model import System
from analysis.provenance import completed_attrs, to_dataset


def run_scalar(lib: Library, p: np.ndarray, h: float, s: np.ndarray, n_out: int,
               every: int) -> np.ndarray:
    """``n_out · every`` RK4 steps of ``h`` s of one member through ``lib``'s blocks (t0 = 0,
    so step k from ``k·h``); ``s`` (n + 1: ``[z, k]``) is changed in place to the state
    after the last step. Returns the states z after every ``every`` steps, (n_out × n)."""
    n = len(s) - 1
    out = np.empty((n_out, n))
    zn, done = np.array(s, dtype=float), 0
    for size in block_plan(n_out * every):
        block = np.asarray(lib.blocks[size](zn, p, h, 0.0))  # (n + 1) × size
        first = -(done + 1) % every  # column of the first step to keep
        kept = block[:n, first::every].T
        start = (done + first + 1) // every - 1  # kept sample 0 is after step `every`
        out[start:start + len(kept)] = kept
        zn = block[:, -1]
        done += size
    s[:] = zn
    return out


def device_of(device: str | Placement, members: int, steps: int,
              compiled: bool = True) -> Placement:
    """The ``Placement`` of ``members`` members of ``steps`` RK4 steps on ``device``
    (``cpu``, ``gpu`` or ``auto``: ``kernels.placement.place``, ``DeviceError`` for another
    name or ``gpu`` without CuPy or a GPU; a ``Placement`` is kept as it is).
    ``compiled=False`` (the CasADi virtual machine) runs on the CPU: ``auto`` is then
    ``cpu``, ``gpu`` an ``InputError``."""
    placed = place(device, members, steps=steps)
    if compiled or not placed.gpu:
        return placed
    if placed.asked == "gpu":
        raise InputError("device: 'gpu' runs the compiled member kernel; compiled=False runs "
                         "on the CPU (device='cpu' or 'auto')")
    return placed.on_cpu()


def run_members(system: System, p: np.ndarray, h: np.ndarray, s: np.ndarray, n_out: int,
                every: int, compiled: bool = True,
                device: str | Placement = "cpu") -> np.ndarray:
    """``n_out · every`` RK4 steps of every member of ``system``'s model and balls: ``p``
    (K × n_par) and ``h`` (K, s) per member, ``s`` (K × (n + 1) rows ``[z, k]``, changed in
    place), step k from ``k·h``. Returns (K, n_out, n): each member's z after every
    ``every`` steps.

    Compiled: all members in one call of the member kernel (``kernels.run_members``; a
    member that blows up stops there, its later states NaN, its row the first bad state)
    on ``device`` (``device_of``; a ``Placement`` as it is): ``cpu``, the CPU build on
    every core; ``gpu``, the CUDA
    build (``InputError`` naming the reason when the model's kernel cannot be written or
    built); ``auto``, the GPU for wide ensembles. On the CPU without a kernel
    (``compiled=False``, an operation the writer does not know, no compiler) member by
    member through the RK4 blocks (``run_scalar``). The CPU paths give ``simulate``'s steps
    bit for bit, the CUDA build the same to the last bits of CUDA's libm."""
    k, n = s.shape[0], s.shape[1] - 1
    device = device_of(device, k, n_out * every, compiled)
    if n_out == 0:
        return np.empty((k, 0, n))
    out = None
    if compiled:
        try:
            out = run_kernel(system, s[:, :n], p, h, Schedule(0, every, n_out), k0=s[:, n],
                             device=device)
        except (Unsupported, CompileError) as exc:
            if device.gpu:
                raise unbuildable(system, device.kind, exc) from None
            out = None
    if out is None:
        result = np.empty((k, n_out, n))
        lib = library(system.model, system.structure, compiled)
        for i in range(k):
            row = np.ascontiguousarray(s[i], dtype=float)
            result[i] = run_scalar(lib, p[i], float(h[i]), row, n_out, every)
            s[i] = row
        return result
    s[:, :n] = out.final
    s[:, n] += n_out * every
    return out.sections


bad_points = bad_states
"""``simulate.bad_states``: the blow-up predicate (one function for every path)."""


@dataclass(frozen=True)
class StroboscopicMap:
    """A System sampled once per forcing period: z_{j+1} = F(z_j), N fixed RK4 steps of
    h = T/N (the steps of ``simulate`` with ``dt = h``: a member's section points are the
    run's states every N steps, bit for bit). Make it with ``make``."""

    system: System
    """The model, balls and parameter values (SI units, speed in rpm) every member shares."""
    period: Period
    """The forcing period (``analysis.integrate.flow.Period``)."""
    period_s: float
    """T, s."""
    steps: int
    """N = ceil(T / dt_max − 1e-9) RK4 steps per period."""
    dt: float
    """h = T / N, s."""
    limit: float
    """Blow-up bound of a centre displacement, m (``simulate.blow_up_limit``; inf: only
    non-finite values count)."""
    compiled: bool = True
    """Run compiled C (the RK4 blocks' cache); False: the CasADi virtual machine."""
    device: str | Placement = CPU
    """Where ``advance`` runs the members: a ``Placement`` (kept; default: the cores,
    ``placement.CPU``), or ``auto`` (placed per call by its members and steps:
    ``device_of``)."""

    @classmethod
    def make(cls, system: System, period: str | Period, dt: float | None = None,
             compiled: bool = True, device: str | Placement = CPU) -> StroboscopicMap:
        """The map of ``system`` over ``period`` (a ``Period`` or its name: ``vc``,
        ``shaft``, ``vc[left]:4``, ``ratio:p/q``, ``param:NAME``; required here, since the
        default period's rule lives in ``analysis.stability``, a layer above:
        ``stability.periodic.as_period(model, None)`` gives it). ``dt``: the largest RK4
        step in s (None: the spec's), checked as a flow map's step is (``RunPlan.step``:
        finite and > 0, resolving the fastest forcing, RK4-stable; ``InputError``
        otherwise). ``device``: ``cpu``, ``gpu`` or ``auto`` (``device_of``; checked here:
        ``InputError`` for another name, for ``gpu`` without CuPy or a GPU, or with
        ``compiled=False``; ``cpu`` and ``gpu`` are kept as their ``Placement``, ``auto``
        is placed by each call's members)."""
        placed = device_of(device, 1, 1, compiled)
        if isinstance(device, str) and device != "auto":
            device = placed  # judged: advance takes it as it is (auto: per call's members)
        per = period if isinstance(period, Period) else Period.parse(period)
        per.check(system.model)
        plan = RunPlan.step(system, dt)
        values = dict(system.parameters)
        seconds = period_seconds(system.model, system.structure, per, values)
        steps = steps_per_period(system.model, system.structure, per, values, plan.dt)
        return cls(system, per, seconds, steps, seconds / steps,
                   blow_up_limit(system.model, values), compiled, device)

    def advance(self, s: np.ndarray, n_periods: int) -> np.ndarray:
        """Move every member ``n_periods`` periods on.

        ``s``: (K, n + 1) rows ``[z, k]``, z the state (SI units) after RK4 step k, so at
        time ``k·h`` s (k a whole number, members may differ); changed in place to the rows
        after ``n_periods · N`` more steps. Returns (K, n_periods, n): each member's state
        after each period (the section points). A member that blows up carries NaN or inf;
        the others are not affected."""
        if s.ndim != 2 or s.shape[1] != self.system.n_state + 1:
            raise InputError(f"s: rows [z, k] of {self.system.n_state + 1} numbers, got an "
                             f"array of shape {s.shape}")
        check_count("n_periods", n_periods, 0)
        k = len(s)
        p = np.repeat(self.system.p[None, :], k, axis=0)
        return run_members(self.system, p, np.full(k, self.dt), s, n_periods, self.steps,
                           self.compiled, self.device)

    def diverged(self, points: np.ndarray) -> np.ndarray:
        """(K,) bool: whether any of a member's ``points`` ((K, m, n) as ``advance``
        returns, or (K, n)) is not finite or has a centre displacement beyond ``limit``
        (the rule of ``simulate.check_bounded``)."""
        points = np.asarray(points, dtype=float)
        bad = bad_points(points, self.limit, self.system.model.centre_indices())
        return bad.reshape(len(points), -1).any(axis=1)


def _members(system: System, states: np.ndarray | None,
             parameters: Sequence[Mapping[str, float]] | None) -> list[System]:
    """One System per member: ``system`` with ``states[i]`` and ``parameters[i]``."""
    if states is None and parameters is None:
        raise InputError("ensemble: give the members' states, parameters or both")
    count = {len(x) for x in (states, parameters) if x is not None}
    if len(count) != 1:
        raise InputError(f"ensemble: {len(states)} states but {len(parameters)} parameter "
                         "sets; give one of each per member")
    (k,) = count
    if k == 0:
        raise InputError("ensemble: no members")
    members = []
    for i in range(k):
        overrides = dict(parameters[i]) if parameters is not None else {}
        unknown = sorted(set(overrides) - set(system.model.parameter_names))
        if unknown:
            raise InputError(f"parameters[{i}]: {', '.join(unknown)}: not parameters of model "
                             f"'{system.model.name}' (balls and state are per ensemble and "
                             "per member state)")
        state = None if states is None else system.model.check_state(states[i],
                                                                     f"states[{i}]")
        members.append(system.replace(state=state, **overrides))
        if state is not None:  # within the model's bounds (integrate.checks.StartLimits)
            check_start(members[-1], field=f"states[{i}]")
    return members


def ensemble(system: System, states: np.ndarray | None = None,
             duration: float | None = None, *,
             parameters: Sequence[Mapping[str, float]] | None = None,
             dt: float | None = None, save_every: int = 1,
             compiled: bool = True, device: str | Placement = "cpu") -> xr.Dataset:
    """K runs of ``system`` from t = 0 (no transient), one per member.

    ``states`` (K, n): the members' initial states (SI units; None: the system's);
    ``parameters``: K mappings of parameter overrides (SI units, speed in rpm; None: the
    system's); ``duration`` (s; None: the spec's), ``dt`` (s; None: the spec's) and
    ``save_every`` as in ``simulate``, each member's run checked as ``simulate`` checks it
    (``RunPlan.make``; ``InputError``). ``device``: where the members run: ``"cpu"`` (the
    member kernel's CPU build on every core), ``"gpu"`` (its CUDA build: CuPy and a visible
    GPU, ``pip install bearingdyn[gpu]``) or ``"auto"`` (the GPU from
    ``kernels.devices.AUTO_MIN_MEMBERS`` members and ``AUTO_MIN_STEPS`` member-steps, else
    the CPU), judged once (``device_of``; a ``Placement`` is taken as it is); any other
    value, or ``gpu`` without CuPy or a GPU, is an ``InputError`` of one line before
    anything runs.

    Returns a Dataset over (member, t): one variable per state (units as ``simulate``'s),
    ``diverged_at`` (member; s): the time of the first saved sample that is not finite or
    beyond the blow-up limit (``simulate.check_bounded``'s rule), NaN for a member that
    stayed bounded; that member's later samples are NaN (no error is raised). The varied
    parameters and the initial states are variables over member; ``attrs`` are the
    provenance of ``system`` (``provenance.completed_attrs``) with ``members`` = K. A
    bounded member equals ``simulate(member system, duration=duration, transient=0, dt=dt,
    save_every=save_every)`` bit for bit on the CPU, to round-off on the GPU."""
    members = _members(system, None if states is None else np.asarray(states, dtype=float),
                       parameters)
    plans = [RunPlan.make(m, duration=duration, transient=0.0, dt=dt,
                          save_every=save_every) for m in members]
    plan = plans[0]
    n, k = system.n_state, len(members)
    check_memory(k * (n + 1) - 1, plan.n_saved, save_every)
    device = device_of(device, k, plan.n_saved * save_every, compiled)
    states_out = np.empty((k, plan.n_saved + 1, n))
    s = np.array([np.append(m.state, 0.0) for m in members])
    states_out[:, 0] = s[:, :n]
    states_out[:, 1:] = run_members(system, np.array([m.p for m in members]),
                                    np.full(k, plan.dt), s, plan.n_saved, save_every, compiled,
                                    device)
    return _dataset(system, members, plan, states_out)


def _dataset(system: System, members: list[System], plan: RunPlan,
             states: np.ndarray) -> xr.Dataset:
    """The Dataset of ``ensemble`` from the members' saved states (K × samples × n)."""
    model = system.model
    times = plan.times()
    limits = np.array([blow_up_limit(model, dict(m.parameters)) for m in members])
    bad = np.stack([bad_points(states[i], limits[i], model.centre_indices())
                    for i in range(len(members))])
    first = np.where(bad.any(axis=1), bad.argmax(axis=1), -1)
    diverged_at = np.where(first >= 0, times[np.maximum(first, 0)], np.nan)
    for i, j in enumerate(first):
        if j >= 0:
            states[i, j + 1:] = np.nan
    attrs = {**completed_attrs(system, **plan.settings()), "members": len(members)}
    runs = [to_dataset(times, states[i].T, attrs, model) for i in range(len(members))]
    ds = xr.concat(runs, dim="member", combine_attrs="override")
    ds = ds.assign_coords(member=np.arange(len(members)))
    ds["diverged_at"] = ("member", diverged_at,
                         {"units": "s", "long_name": "time of the first sample beyond the "
                          "blow-up limit (NaN: bounded)"})
    for name in model.parameter_names:
        values = np.array([float(m.parameters[name]) for m in members])
        if np.any(values != values[0]):
            ds[name] = ("member", values, {"units": model.units.get(name, ""),
                                           "long_name": f"{name} of each member"})
    for i, name in enumerate(model.state_names):
        ds[f"{name}0"] = ("member", np.array([m.state[i] for m in members]),
                          {"units": model.state_units[name],
                           "long_name": f"initial {name} of each member"})
    return ds
