"""Time integration of a generated model: fixed-step RK4 (the paper) and adaptive CVODES.

Both return an ``xarray.Dataset`` with coordinate ``t`` (s) and variables ``x``, ``y`` (m),
``vx``, ``vy`` (m/s) from the end of the transient on, and attrs that trace the run to the
exact generated code: model name, spec sha256, number of balls, every parameter value,
method and step, the characteristic frequencies and the package versions.
"""

from __future__ import annotations

import functools
import math
from importlib import metadata
from typing import Literal

import casadi as ca
import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.integrate.checks import check_rk4_step
from analysis.integrate.compiled import library, run_rk4
from analysis.model import Model, load_model

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


def _resolve(model: Model | str) -> Model:
    return load_model(model) if isinstance(model, str) else model


def _check_times(duration: float, transient: float, dt: float) -> None:
    for name, value in (("duration", duration), ("dt", dt)):
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{name}: must be a finite number > 0 s, got {value!r}")
    if not (math.isfinite(transient) and 0 <= transient < duration):
        raise InputError(f"transient: must be in [0, duration) = [0, {duration:g}) s, "
                         f"got {transient!r}")
    if dt > duration:
        raise InputError(f"dt: must be <= duration ({duration:g} s), got {dt!r}")


def simulate(
    model: Model | str,
    n_balls: int | None = None,
    *,
    duration: float | None = None,
    transient: float | None = None,
    dt: float | None = None,
    method: Method = "rk4",
    save_every: int = 1,
    initial_state: tuple[float, float, float, float] | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-16,
    compiled: bool = True,
    **parameters: float,
) -> xr.Dataset:
    """Integrate ``model`` and return the motion after ``transient``.

    Parameters (SI units; speed in rpm)
    ----------
    n_balls: number of balls (default: the spec's).
    duration: simulated time in s, transient included (default: the spec's).
    transient: time in s dropped from the output (default: the spec's).
    dt: RK4 step in s (paper: 1e-5), and the output spacing of both methods.
    method: ``"rk4"`` fixed step, or ``"cvodes"`` adaptive BDF with ``rtol``/``atol``.
    save_every: keep every n-th RK4 step only (output spacing ``save_every * dt``).
    initial_state: (x0, y0, vx0, vy0) in m and m/s (default: the spec's, paper 1e-6 m).
    compiled: run RK4 as compiled C (built once per model and N_b, then cached; see
        ``analysis.integrate.compiled``); ``False``: the CasADi virtual machine (same results).
    **parameters: runtime parameter overrides, e.g. ``speed_rpm=5000, damping=100``.
    """
    model = _resolve(model)
    n = model.check_n_balls(n_balls)
    values = model.parameters(parameters)
    sim = model.simulation_defaults
    duration = float(sim["duration"] if duration is None else duration)
    transient = float(sim["transient"] if transient is None else transient)
    dt = float(sim["dt"] if dt is None else dt)
    _check_times(duration, transient, dt)
    check_rk4_step(model, n, values, dt, method)
    if not (isinstance(save_every, int) and save_every >= 1):
        raise InputError(f"save_every: must be an integer >= 1, got {save_every!r}")
    z0 = np.array(initial_state if initial_state is not None
                  else (sim["x0"], sim["y0"], sim["vx0"], sim["vy0"]), dtype=float)
    if z0.shape != (4,) or not np.all(np.isfinite(z0)):
        raise InputError(f"initial_state: must be 4 finite numbers (x0, y0, vx0, vy0), "
                         f"got {initial_state!r}")
    n_steps = round(duration / dt)
    n_saved = n_steps // save_every
    times = np.arange(n_saved + 1) * (save_every * dt)
    p = model.parameter_vector(values)
    clearance = abs(values.get("radial_clearance", 0.0))
    limit = BLOW_UP_FACTOR * clearance if clearance > 0 else np.inf  # else: non-finite only
    if method == "rk4":
        states = _run_rk4(model, n, p, z0, dt, save_every, n_saved, limit, compiled)
    elif method == "cvodes":
        if not (math.isfinite(rtol) and 0 < rtol < 1):
            raise InputError(f"rtol: must be in (0, 1), got {rtol!r}")
        if not (math.isfinite(atol) and 0 <= atol < 1):
            raise InputError(f"atol: must be in [0, 1), got {atol!r}")
        states = _run_cvodes(model, n, p, z0, times, rtol, atol, limit)
    else:
        raise InputError(f"method: must be 'rk4' or 'cvodes', got {method!r}")
    keep = times >= transient - 1e-12 * duration
    attrs = run_attrs(model, n, values)
    attrs.update(method=method, dt=dt, save_every=save_every, duration=duration,
                 transient=transient, x0=z0[0], y0=z0[1], vx0=z0[2], vy0=z0[3])
    if method == "cvodes":
        attrs.update(rtol=rtol, atol=atol)
    return to_dataset(times[keep], states[:, keep], attrs)


def run_attrs(model: Model, n_balls: int, values: dict[str, float]) -> dict:
    """Provenance of a run: model, spec hash, versions, every parameter, frequencies."""
    attrs = {"model": model.name, "spec_sha256": model.spec_sha256, "n_balls": n_balls,
             "bearingdyn_version": package_version(),
             "generator": ", ".join(f"{k} {v}" for k, v in model.module.GENERATOR.items()),
             "casadi_version": ca.__version__}
    attrs.update(values)
    attrs.update(model.frequencies(n_balls, values).as_dict())
    return attrs


STATE = ("x", "y", "vx", "vy")
"""The state variables of a run, in the order of the state vector."""


def state_at(ds: xr.Dataset, index: int) -> np.ndarray:
    """The state [x, y, vx, vy] (m, m/s) at sample ``index`` of a run (-1: the last)."""
    return np.array([float(ds[v][index]) for v in STATE])


def to_dataset(t: np.ndarray, states: np.ndarray, attrs: dict) -> xr.Dataset:
    units = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}
    meaning = {"x": "rotor displacement along the radial load",
               "y": "rotor displacement across the radial load",
               "vx": "rotor velocity along the radial load",
               "vy": "rotor velocity across the radial load"}
    data = {name: ("t", states[i], {"units": units[name], "long_name": meaning[name]})
            for i, name in enumerate(units)}
    return xr.Dataset(data, coords={"t": ("t", t, {"units": "s", "long_name": "time"})},
                      attrs=attrs)


def _blow_up(states: np.ndarray, times: np.ndarray, limit: float) -> None:
    bad = ~np.all(np.isfinite(states), axis=0) | (np.hypot(states[0], states[1]) > limit)
    if np.any(bad):
        when = times[int(np.argmax(bad))]
        bound = f"beyond {limit:g} m" if np.isfinite(limit) else "growing without bound"
        raise SimulationError(
            f"the motion blew up at t = {when:.6g} s (displacement not finite or {bound}); "
            "try a smaller dt, more damping, or check the parameters")


def _run_rk4(model: Model, n_balls: int, p: np.ndarray, z0: np.ndarray, dt: float,
             save_every: int, n_saved: int, limit: float, compiled: bool = True) -> np.ndarray:
    """RK4 in blocks of up to 1e4 steps (``analysis.integrate.compiled``: compiled C, or the VM).

    A blow-up is looked for at the end of every block (non-finite values propagate), then
    reported with the time of the first bad state of that block."""
    def check(block: np.ndarray) -> None:
        try:
            _blow_up(block[-1:, :4].T, block[-1:, 4] * dt, limit)
        except SimulationError:
            _blow_up(block[:, :4].T, block[:, 4] * dt, limit)
            raise

    return run_rk4(library(model, n_balls, compiled), p, z0, dt, n_saved * save_every,
                   save_every, check=check)


def _run_cvodes(model: Model, n_balls: int, p: np.ndarray, z0: np.ndarray,
                times: np.ndarray, rtol: float, atol: float, limit: float) -> np.ndarray:
    rhs = model.functions(n_balls).rhs
    t, z, par = ca.SX.sym("t"), ca.SX.sym("z", 4), ca.SX.sym("p", len(p))
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
    _blow_up(states, times, limit)
    return states
