"""Time integration of a generated model: fixed-step RK4 (the paper) and adaptive CVODES.

Both return an ``xarray.Dataset`` with coordinate ``t`` (s) and one variable per state (``x``,
``y`` (m), ``vx``, ``vy`` (m/s) for the paper's rotor; ``x_rotor``, ``vx_housing`` … for
models of several bodies) from the end of the transient on, and attrs that trace the run to
the exact generated code: model name, spec path and sha256, balls per bearing, every
parameter value, method and step, the characteristic frequencies and the package versions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, Interrupt, SimulationError
from analysis.integrate.checks import (  # noqa: F401  (blow_up_limit's old home)
    BALL_FRACTION,
    BLOW_UP_FACTOR,
    blow_up_limit,
    check_deflection,
    check_start,
)
from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.plan import Method, RunPlan
from analysis.integrate.speed_profile import SpeedProfile
from analysis.model import BallCounts, Model, System, as_system
from analysis.provenance import completed_attrs, state_variable_attrs, to_dataset


def simulate(
    system: System | Model | str | Path,
    n_balls: BallCounts = None,
    *,
    duration: float | None = None,
    transient: float | None = None,
    dt: float | None = None,
    method: Method = "rk4",
    save_every: int = 1,
    initial_state: Sequence[float] | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-16,
    compiled: bool = True,
    speed_profile: SpeedProfile | None = None,
    **parameters: float,
) -> xr.Dataset:
    """Integrate a system and return its motion after ``transient``.

    Parameters (SI units; speed in rpm)
    ----------
    system: a ``System`` (model, balls, parameters, initial state), or a model (name, spec
        path, folder or ``Model``) completed by the arguments below.
    n_balls: balls per bearing (default: the spec's); one number for a one-bearing model,
        else a mapping bearing name -> number.
    duration: simulated time in s, transient included (default: the spec's).
    transient: time in s dropped from the output (default: the spec's).
    dt: RK4 step in s (paper: 1e-5), and the output spacing of both methods.
    method: ``"rk4"`` fixed step, or ``"cvodes"`` adaptive BDF with ``rtol``/``atol``.
    save_every: keep every n-th RK4 step only (output spacing ``save_every * dt``).
    initial_state: the state at t = 0 in the order of the model's state names (default:
        the system's, else the spec's; the paper's 1e-6 m for its model).
    compiled: run RK4 as compiled C (built once per model and balls, then cached; see
        ``analysis.integrate.compiled``); ``False``: the CasADi virtual machine (same results).
    speed_profile: the speed the shaft follows, a field of the run (``RunPlan.profile``): a
        run-up or coast-down (``SpeedProfile.ramp(1000, 10000)``,
        ``SpeedProfile.table(t, rpm)``, ``read_table(path)``; see
        ``analysis.integrate.speed_profile``), recorded in the attrs (``speed_profile``,
        ``speed_profile_t``, ``speed_profile_rpm``; ``speed_rpm`` and the frequencies are
        then those at t = 0). A constant profile is the constant speed: the same run, bit
        for bit. ``speed_rpm=SpeedProfile(…)`` is read as this keyword.
    **parameters: runtime parameter overrides, e.g. ``speed_rpm=5000, damping=100``.

    Returns an ``xarray.Dataset`` with one variable per state (units and meaning in its
    attributes) over ``t`` (s) and the run's provenance in ``attrs``.
    """
    run = _prepare(system, n_balls, initial_state, parameters, duration, transient, dt,
                   method, save_every, rtol, atol, in_memory=True, profile=speed_profile)
    if method == "rk4":
        plan = run.plan
        states = _run_rk4(run.system, run.p, run.z0, plan.dt, save_every, plan.n_saved,
                          run.limit, compiled, functions=run.functions)
    else:
        states = _run_cvodes(run.system, run.p, run.z0, run.plan.times(), rtol, atol,
                             run.limit, run.functions)
    times = run.plan.times()
    first = run.plan.first
    return to_dataset(times[first:], states[:, first:], run.attrs, run.system.model)


@dataclass(frozen=True)
class _Run:
    """A checked run: its plan, provenance and blow-up limit (m); with a speed profile
    (the plan's), the profile's Functions and their parameter vector."""

    plan: RunPlan
    attrs: dict
    limit: float

    @property
    def profile(self) -> SpeedProfile | None:
        return self.plan.profile

    @property
    def functions(self):
        """The profile's ``ProfileFunctions`` (None: the model's own)."""
        if self.profile is None:
            return None
        from analysis.integrate.speed_profile import hinge_count, profile_functions

        return profile_functions(self.system.model, self.system.structure,
                                 hinge_count(len(self.profile.rpm)))

    @property
    def p(self) -> np.ndarray:
        """The parameter vector of the run's Functions."""
        p = self.plan.system.p
        if self.profile is None:
            return p
        return np.concatenate([p, self.profile.parameters(self.plan.duration)])

    @property
    def system(self) -> System:
        return self.plan.system

    @property
    def z0(self) -> np.ndarray:
        return self.plan.system.state


def _prepare(system, n_balls, initial_state, parameters, duration, transient, dt, method,
             save_every, rtol, atol, in_memory: bool,
             profile: SpeedProfile | None = None) -> _Run:
    """Every check of a run (``RunPlan.make``), before any step is taken; a speed
    profile's (``plan.check_profile``) after the plan's. A ``SpeedProfile`` given as
    ``speed_rpm`` is taken off the parameters: the profile is a field of the run plan."""
    parameters = dict(parameters)
    if isinstance(parameters.get("speed_rpm"), SpeedProfile):
        if profile is not None:
            raise InputError("speed_rpm: a speed profile given twice (speed_rpm and "
                             "speed_profile); give it once")
        profile = parameters.pop("speed_rpm")
    system = as_system(system, n_balls, initial_state, **parameters)
    plan = RunPlan.make(system, duration=duration, transient=transient, dt=dt, method=method,
                        save_every=save_every, rtol=rtol, atol=atol, in_memory=in_memory,
                        profile=profile)
    system, profile = plan.system, plan.profile
    check_start(system)  # the initial state within the model's bounds (StartLimits)
    check_deflection(system)  # a contact stiffness in the wrong unit: a warning
    attrs = completed_attrs(system, **plan.settings(), initial_state=True,
                            tolerances=(rtol, atol) if method == "cvodes" else None,
                            speed_profile=None if profile is None
                            else profile.attrs(plan.duration))
    return _Run(plan, attrs, blow_up_limit(system.model, dict(system.parameters)))


def check_run(system: System | Model | str | Path, n_balls: BallCounts = None, *,
              duration: float | None = None, transient: float | None = None,
              dt: float | None = None, method: Method = "rk4", save_every: int = 1,
              speed_profile: SpeedProfile | None = None, **parameters: float) -> None:
    """Every check ``simulate`` makes before a step is taken, and nothing else: a job of
    several runs (``bearingdyn run``) validates all of them before it writes anything."""
    _prepare(system, n_balls, None, parameters, duration, transient, dt, method, save_every,
             1e-10, 1e-16, in_memory=False, profile=speed_profile)


def simulate_to_file(
    system: System | Model | str | Path,
    path: str | Path,
    n_balls: BallCounts = None,
    *,
    duration: float | None = None,
    transient: float | None = None,
    dt: float | None = None,
    save_every: int = 1,
    initial_state: Sequence[float] | None = None,
    compiled: bool = True,
    chunk: int = 100_000,
    speed_profile: SpeedProfile | None = None,
    **parameters: float,
) -> Path:
    """``simulate`` with fixed-step RK4, streamed to the netCDF file ``path`` block by block:
    a run of any length in constant memory (the states are never held whole). The file
    holds what ``save_dataset(simulate(...), path)`` writes (the same variables,
    coordinates, attributes and values); it is written atomically, so a run that blows up,
    a full disk or Ctrl-C leave no file (and a file already at ``path`` as it was).
    ``chunk``: samples per HDF5 chunk. Other arguments as in ``simulate``."""
    from analysis.io import atomic_write

    run = _prepare(system, n_balls, initial_state, parameters, duration, transient, dt,
                   "rk4", save_every, 1e-10, 1e-16, in_memory=False, profile=speed_profile)
    model = run.system.model
    size = run.plan.n_saved + 1 - run.plan.first

    def write(tmp: Path) -> None:
        import h5netcdf

        with h5netcdf.File(tmp, "w") as f:
            f.dimensions = {"t": size}
            rows = min(chunk, max(size, 1))
            t_var = f.create_variable("t", ("t",), "f8", chunks=(rows,))
            t_var.attrs.update({"_FillValue": np.nan, "units": "s", "long_name": "time"})
            variables = []
            for name in model.state_names:
                var = f.create_variable(name, ("t",), "f8", chunks=(rows,),
                                        fillvalue=np.nan)
                var.attrs.update(state_variable_attrs(model, name))
                variables.append(var)
            f.attrs.update(run.attrs)

            def sink(start: int, kept: np.ndarray) -> None:
                Interrupt.check()  # between blocks, outside HDF5's code
                stop = start + kept.shape[1]
                lo = max(start, run.plan.first)
                if lo >= stop:
                    return
                out = slice(lo - run.plan.first, stop - run.plan.first)
                t_var[out] = run.plan.times(lo, stop)
                for i, var in enumerate(variables):
                    var[out] = kept[i, lo - start:]

            plan = run.plan
            _run_rk4(run.system, run.p, run.z0, plan.dt, plan.save_every, plan.n_saved,
                     run.limit, compiled, sink=sink, functions=run.functions)

    return atomic_write(path, write, size=8 * (model.n_state + 1) * size)


def bad_states(points: np.ndarray, limit: float,
               pairs: Sequence[tuple[int, int | None]]) -> np.ndarray:
    """The blow-up predicate, the one of every path (``check_bounded``, the ensembles, and in
    C the member kernels, ``kernels.source.blow_up_c``): for ``points`` (… × n states, SI
    units) whether a value is not finite or a body's centre displacement (``hypot(x, y)``,
    ``|x|`` for a body moving along x; ``pairs`` from ``Model.centre_indices``) is beyond
    ``limit`` (m). Returns a bool array of ``points.shape[:-1]``."""
    bad = ~np.all(np.isfinite(points), axis=-1)
    with np.errstate(invalid="ignore", over="ignore"):
        for i, j in pairs:
            shift = np.abs(points[..., i]) if j is None else \
                np.hypot(points[..., i], points[..., j])
            bad |= shift > limit
    return bad


def extremes(rows: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest value of each of the first ``n`` columns of ``rows`` (m × ≥ n,
    one state per row; NaN where a column holds one). One contiguous copy per block: ten
    times faster than reducing the strided columns in place."""
    columns = np.ascontiguousarray(rows[:, :n].T)
    return columns.min(axis=1), columns.max(axis=1)


def _bounded(low: np.ndarray, high: np.ndarray, limit: float,
             pairs: list[tuple[int, int | None]]) -> bool:
    """True when every state between these extremes is finite and within ``limit`` (m):
    the largest centre displacement is at most that of the extremes' magnitudes."""
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        return False
    big = np.maximum(np.abs(low), np.abs(high))
    return all((big[i] if j is None else np.hypot(big[i], big[j])) <= limit
               for i, j in pairs)


def check_bounded(states: np.ndarray, times: np.ndarray, limit: float,
                  pairs: list[tuple[int, int | None]],
                  bounds: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Raise SimulationError at the first column of ``states`` (n × m, at ``times`` s) that
    is not finite or whose centre displacement is beyond ``limit`` (m). ``bounds``: the
    rows' ``extremes`` when already known. A block whose extremes are within the limit is
    passed at once; only a block that may hold a bad state is searched state by state."""
    low, high = bounds if bounds is not None else extremes(states.T, len(states))
    if _bounded(low, high, limit, pairs):
        return
    bad = bad_states(states.T, limit, pairs)
    if np.any(bad):
        when = times[int(np.argmax(bad))]
        bound = f"beyond {limit:g} m" if np.isfinite(limit) else "growing without bound"
        raise SimulationError(
            f"the motion blew up at t = {when:.6g} s (displacement not finite or {bound}); "
            "try a smaller dt, more damping, or check the parameters")


def _run_rk4(system: System, p: np.ndarray, z0: np.ndarray, dt: float,
             save_every: int, n_saved: int, limit: float, compiled: bool = True,
             sink=None, functions=None) -> np.ndarray | None:
    """RK4 in blocks of up to 1e4 steps (``analysis.integrate.compiled``: compiled C, or the VM);
    ``functions``: a speed profile's (``p`` then holds its parameters too).

    Every kept state of every block is checked against the blow-up limit before the next
    block runs, and a blow-up is reported with the time of the first bad state: no run that
    leaves the limit is returned."""
    n, pairs = system.n_state, system.model.centre_indices()

    def check(block: np.ndarray) -> None:
        check_bounded(block[:, :n].T, block[:, n] * dt, limit, pairs)

    return run_rk4(library(system.model, system.structure, compiled, functions), p, z0, dt,
                   n_saved * save_every, save_every, check=check, sink=sink)


def _run_cvodes(system: System, p: np.ndarray, z0: np.ndarray,
                times: np.ndarray, rtol: float, atol: float, limit: float,
                functions=None) -> np.ndarray:
    rhs = (system.functions if functions is None else functions).rhs
    t, z, par = ca.SX.sym("t"), ca.SX.sym("z", system.n_state), ca.SX.sym("p", len(p))
    dae = {"t": t, "x": z, "p": par, "ode": rhs(t, z, par)}
    opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 10_000_000,
            "max_step_size": float(times[1] - times[0]) if len(times) > 1 else 0.0}
    try:
        integ = ca.integrator("cvodes_run", "cvodes", dae, float(times[0]),
                              times[1:].tolist(), opts)
        zs = np.asarray(integ(x0=z0, p=p)["xf"])
    except RuntimeError as exc:
        raise SimulationError(f"CVODES failed: {str(exc).splitlines()[-1]}") from None
    states = np.concatenate([z0[:, None], zs], axis=1)
    check_bounded(states, times, limit, system.model.centre_indices())
    return states
