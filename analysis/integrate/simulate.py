"""Time integration of a generated model: fixed-step RK4 (the paper) and adaptive CVODES.

Both return an ``xarray.Dataset`` with coordinate ``t`` (s) and one variable per state (``x``,
``y`` (m), ``vx``, ``vy`` (m/s) for the paper's rotor; ``x_rotor``, ``vx_housing`` … for
models of several bodies) from the end of the transient on, and attrs that trace the run to
the exact generated code: model name, spec path and sha256, balls per bearing, every
parameter value, method and step, the characteristic frequencies and the package versions.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Literal

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, Interrupt, SimulationError
from analysis.integrate.checks import check_resolution, check_rk4_step, check_seconds
from analysis.integrate.compiled import library, run_rk4
from analysis.model import BallCounts, Model, Structure, System, as_system

Method = Literal["rk4", "cvodes"]
BLOW_UP_FACTOR = 1000.0
"""A displacement beyond this many clearances is a blow-up (models without a clearance are
only checked for non-finite states)."""
RK4_STABILITY_LIMIT = 2.785
"""|λ|·Δt at which classical RK4 stops being stable on the imaginary axis (2√2)."""


@functools.cache
def package_version() -> str:
    try:
        return metadata.version("bearingdyn")
    except metadata.PackageNotFoundError:  # running from a source tree
        return "0+unknown"


def _check_times(duration: float, transient: float, dt: float) -> None:
    check_seconds("duration", duration)
    check_seconds("dt", dt)
    if not (math.isfinite(transient) and 0 <= transient < duration):
        raise InputError(f"transient: must be in [0, duration) = [0, {duration:g}) s, "
                         f"got {transient!r}")
    if dt > duration:
        raise InputError(f"dt: must be <= duration ({duration:g} s), got {dt!r}")


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
    **parameters: runtime parameter overrides, e.g. ``speed_rpm=5000, damping=100``.

    Returns an ``xarray.Dataset`` with one variable per state (units and meaning in its
    attributes) over ``t`` (s) and the run's provenance in ``attrs``.
    """
    run = _prepare(system, n_balls, initial_state, parameters, duration, transient, dt,
                   method, save_every, rtol, atol, in_memory=True)
    if method == "rk4":
        states = _run_rk4(run.system, run.system.p, run.z0, run.dt, save_every, run.n_saved,
                          run.limit, compiled)
    else:
        states = _run_cvodes(run.system, run.system.p, run.z0, run.times(), rtol, atol,
                             run.limit)
    times = run.times()
    return to_dataset(times[run.first:], states[:, run.first:], run.attrs, run.system.model)


@dataclass(frozen=True)
class _Run:
    """A checked run: its system, step, lengths, limit, provenance and first kept sample."""

    system: System
    z0: np.ndarray
    dt: float
    save_every: int
    n_saved: int
    first: int
    limit: float
    attrs: dict

    def times(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Times (s) of the saved samples ``start … stop − 1`` (all: 0 … n_saved)."""
        stop = self.n_saved + 1 if stop is None else stop
        return np.arange(start, stop) * (self.save_every * self.dt)


def _prepare(system, n_balls, initial_state, parameters, duration, transient, dt, method,
             save_every, rtol, atol, in_memory: bool) -> _Run:
    """Every check of a run, before any step is taken."""
    system = as_system(system, n_balls, initial_state, **parameters)
    model, n, values = system.model, system.structure, dict(system.parameters)
    sim = model.simulation_defaults
    duration = float(sim["duration"] if duration is None else duration)
    transient = float(sim["transient"] if transient is None else transient)
    dt = float(sim["dt"] if dt is None else dt)
    _check_times(duration, transient, dt)
    if method not in ("rk4", "cvodes"):
        raise InputError(f"method: must be 'rk4' or 'cvodes', got {method!r}")
    if method == "cvodes":
        if not (math.isfinite(rtol) and 0 < rtol < 1):
            raise InputError(f"rtol: must be in (0, 1), got {rtol!r}")
        if not (math.isfinite(atol) and 0 <= atol < 1):
            raise InputError(f"atol: must be in [0, 1), got {atol!r}")
    if not (isinstance(save_every, int) and save_every >= 1):
        raise InputError(f"save_every: must be an integer >= 1, got {save_every!r}")
    check_resolution(model, n, values, dt, duration)
    n_saved = round(duration / dt) // save_every
    if in_memory:
        _check_memory(model.n_state, n_saved, save_every)
    check_rk4_step(model, n, values, dt, method)
    z0 = system.state
    first = _first_kept(transient - 1e-12 * duration, save_every * dt)
    attrs = run_attrs(model, n, values)
    attrs.update(method=method, dt=dt, save_every=save_every, duration=duration,
                 transient=transient)
    attrs.update({f"{name}0": float(v) for name, v in zip(model.state_names, z0, strict=True)})
    if method == "cvodes":
        attrs.update(rtol=rtol, atol=atol)
    return _Run(system, z0, dt, save_every, n_saved, max(0, first), blow_up_limit(model, values),
                attrs)


def check_run(system: System | Model | str | Path, n_balls: BallCounts = None, *,
              duration: float | None = None, transient: float | None = None,
              dt: float | None = None, method: Method = "rk4", save_every: int = 1,
              **parameters: float) -> None:
    """Every check ``simulate`` makes before a step is taken, and nothing else: a job of
    several runs (``bearingdyn run``) validates all of them before it writes anything."""
    _prepare(system, n_balls, None, parameters, duration, transient, dt, method, save_every,
             1e-10, 1e-16, in_memory=False)


def _first_kept(threshold: float, step: float) -> int:
    """Smallest k with k·step >= threshold, computed as ``np.arange(…) * step`` computes the
    times (so the first kept sample is the same whichever way the run is stored)."""
    k = max(0, math.ceil(threshold / step))
    while k > 0 and float(np.float64(k - 1) * step) >= threshold:
        k -= 1
    while float(np.float64(k) * step) < threshold:
        k += 1
    return k


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
                   "rk4", save_every, 1e-10, 1e-16, in_memory=False)
    model = run.system.model
    size = run.n_saved + 1 - run.first

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
                var.attrs.update({"units": model.state_units[name],
                                  "long_name": state_meaning(model, name)})
                variables.append(var)
            f.attrs.update(run.attrs)

            def sink(start: int, kept: np.ndarray) -> None:
                Interrupt.check()  # between blocks, outside HDF5's code
                stop = start + kept.shape[1]
                lo = max(start, run.first)
                if lo >= stop:
                    return
                out = slice(lo - run.first, stop - run.first)
                t_var[out] = run.times(lo, stop)
                for i, var in enumerate(variables):
                    var[out] = kept[i, lo - start:]

            _run_rk4(run.system, run.system.p, run.z0, run.dt, run.save_every, run.n_saved,
                     run.limit, compiled, sink=sink)

    return atomic_write(path, write, size=8 * (model.n_state + 1) * size)


MEMORY_BUDGET = 8 * 2**30
"""Most bytes the states a run keeps in memory may take (their float64 values, twice: the
blocks and the assembled array)."""


def _check_memory(n_state: int, n_saved: int, save_every: int) -> None:
    need = 2 * 8 * (n_state + 1) * (n_saved + 1)
    if need > MEMORY_BUDGET:
        raise InputError(f"save_every: the run would keep {n_saved + 1:.3g} samples "
                         f"({need / 2**30:.3g} GiB); at most {MEMORY_BUDGET / 2**30:g} GiB: raise "
                         f"save_every to at least {math.ceil(save_every * need / MEMORY_BUDGET)} "
                         "or shorten the run")


BALL_FRACTION = 0.25
"""... or beyond this fraction of the largest ball diameter: Hertz contact describes
deflections far smaller than the ball, so a displacement of a quarter of it is no longer a
motion of the bearing the model describes (a static deflection under 1e5 N on the paper's
bearing is 0.12 of its ball diameter)."""


def blow_up_limit(model: Model, values: Mapping[str, float]) -> float:
    """Displacement (m) beyond which a run of ``model`` with parameter ``values`` has blown
    up: ``BLOW_UP_FACTOR`` times the largest radial clearance of its bearings, or
    ``BALL_FRACTION`` of the largest ball diameter, whichever is smaller (the parameters
    that play the ``clearance`` and ``ball_diameter`` roles, ``Model.role``; inf without
    either: non-finite values only)."""
    clearance = max((abs(v) for v in model.role_values("clearance", values)), default=0.0)
    ball = max((abs(v) for v in model.role_values("ball_diameter", values)), default=0.0)
    limits = [BLOW_UP_FACTOR * clearance] if clearance > 0 else []
    limits += [BALL_FRACTION * ball] if ball > 0 else []
    return min(limits, default=np.inf)


def run_attrs(model: Model, structure: Structure, values: dict[str, float]) -> dict:
    """Provenance of a run: model, spec path and hash, versions, balls, every parameter,
    frequencies, the state names."""
    attrs = {"model": model.name, "spec_sha256": model.spec_sha256,
             "spec_file": model.spec_file, **model.structure_attrs(structure),
             "state_names": " ".join(model.state_names),
             "bearingdyn_version": package_version(),
             "generator": ", ".join(f"{k} {v}" for k, v in model.module.GENERATOR.items()),
             "casadi_version": ca.__version__}
    attrs.update(values)
    attrs.update(model.frequencies(structure, values).as_dict())
    return attrs


def state_names(ds: xr.Dataset) -> tuple[str, ...]:
    """The state variables of a run, in the order of the state vector."""
    return tuple(ds.attrs.get("state_names", "x y vx vy").split())


def state_at(ds: xr.Dataset, index: int) -> np.ndarray:
    """The state (SI units, the model's order) at sample ``index`` of a run (-1: the last)."""
    return np.array([float(ds[v][index]) for v in state_names(ds)])


def state_meaning(model: Model, name: str) -> str:
    """Words for a state variable: 'rotor displacement along the radial load', …"""
    velocity = name.startswith("v") and name[1:] in model.state_names
    base = name[1:] if velocity else name
    coordinate, _, body = base.partition("_")
    body = body or model.module.BODIES[0][0]
    what = {"x": "displacement along the radial load", "y": "displacement across the radial load",
            "tx": "tilt dx/dz", "ty": "tilt dy/dz"}[coordinate]
    if velocity:
        what = what.replace("displacement", "velocity").replace("tilt", "tilt rate")
    return f"{body} {what}"


def to_dataset(t: np.ndarray, states: np.ndarray, attrs: dict, model: Model) -> xr.Dataset:
    """A run as a Dataset: one variable per state over ``t`` (s)."""
    units = model.state_units
    data = {name: ("t", states[i], {"units": units[name],
                                    "long_name": state_meaning(model, name)})
            for i, name in enumerate(model.state_names)}
    return xr.Dataset(data, coords={"t": ("t", t, {"units": "s", "long_name": "time"})},
                      attrs=attrs)


def _displacement(states: np.ndarray, pairs: list[tuple[int, int | None]]) -> np.ndarray:
    """Largest centre displacement of any body (m) in each column of ``states``."""
    out = np.zeros(states.shape[1])
    for i, j in pairs:
        out = np.maximum(out, np.abs(states[i]) if j is None else np.hypot(states[i], states[j]))
    return out


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


def _blow_up(states: np.ndarray, times: np.ndarray, limit: float,
             pairs: list[tuple[int, int | None]],
             bounds: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Raise SimulationError at the first column of ``states`` (n × m, at ``times`` s) that
    is not finite or whose centre displacement is beyond ``limit`` (m). ``bounds``: the
    rows' ``extremes`` when already known. A block whose extremes are within the limit is
    passed at once; only a block that may hold a bad state is searched state by state."""
    low, high = bounds if bounds is not None else extremes(states.T, len(states))
    if _bounded(low, high, limit, pairs):
        return
    bad = ~np.all(np.isfinite(states), axis=0) | (_displacement(states, pairs) > limit)
    if np.any(bad):
        when = times[int(np.argmax(bad))]
        bound = f"beyond {limit:g} m" if np.isfinite(limit) else "growing without bound"
        raise SimulationError(
            f"the motion blew up at t = {when:.6g} s (displacement not finite or {bound}); "
            "try a smaller dt, more damping, or check the parameters")


def _run_rk4(system: System, p: np.ndarray, z0: np.ndarray, dt: float,
             save_every: int, n_saved: int, limit: float, compiled: bool = True,
             sink=None) -> np.ndarray | None:
    """RK4 in blocks of up to 1e4 steps (``analysis.integrate.compiled``: compiled C, or the VM).

    Every kept state of every block is checked against the blow-up limit before the next
    block runs, and a blow-up is reported with the time of the first bad state: no run that
    leaves the limit is returned."""
    n, pairs = system.n_state, system.model.centre_indices()

    def check(block: np.ndarray) -> None:
        _blow_up(block[:, :n].T, block[:, n] * dt, limit, pairs)

    return run_rk4(library(system.model, system.structure, compiled), p, z0, dt,
                   n_saved * save_every, save_every, check=check, sink=sink)


def _run_cvodes(system: System, p: np.ndarray, z0: np.ndarray,
                times: np.ndarray, rtol: float, atol: float, limit: float) -> np.ndarray:
    rhs = system.functions.rhs
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
    _blow_up(states, times, limit, system.model.centre_indices())
    return states
