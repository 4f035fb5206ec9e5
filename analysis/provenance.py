"""Result attributes: the one writer and reader of what a result file says about itself.

Every result (run, chart, diagram, branch, curve, stiffness table) carries in its netCDF
attrs the system it was computed for: the model, its spec path and SHA-256, balls per
bearing, every parameter value (SI units), the characteristic frequencies (Hz), the state
names and the versions. This module writes them (``run_attrs``, ``completed_attrs``,
``to_dataset``), reads them back (``state_names``, ``displacement_names``,
``vc_frequencies``, ``cage_frequencies``, ``system_of_attrs``, ``load_dataset``) and turns
them into JSON (``provenance``, ``plain``).

Layer: above ``analysis.model`` (it needs ``Model`` and ``System``) and ``analysis.io``
(files), below ``integrate``, ``signal``, ``stability``, ``sweeps`` and ``reports``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import xarray as xr

import modelgen
from analysis.errors import InputError
from analysis.io import open_result, read_attrs
from analysis.model import Model, Structure, System, load_model

PAPER_STATE = ("x", "y", "vx", "vy")
"""The state of the paper's one-body models, and of files older than ``state_names``."""
RUN_ATTRS_NONNEGATIVE = ("shaft_hz", "speed_rpm")
"""Attributes of a run that must be finite numbers >= 0 when present."""


def package_version() -> str:
    """The version of bearingdyn (``modelgen.__version__``: one source for every result,
    citation and generated model)."""
    return modelgen.__version__


# --- writing -------------------------------------------------------------------------------

def run_attrs(model: Model, structure: Structure, values: dict[str, float]) -> dict:
    """Provenance of a result: model, spec path and hash, balls, the state names, versions,
    every parameter (SI units) and the frequencies (Hz)."""
    attrs = {"model": model.name, "spec_sha256": model.spec_sha256,
             "spec_file": model.spec_file, **model.structure_attrs(structure),
             "state_names": " ".join(model.state_names),
             "bearingdyn_version": package_version(),
             "generator": ", ".join(f"{k} {v}" for k, v in model.module.GENERATOR.items()),
             "casadi_version": ca.__version__}
    attrs.update(values)
    attrs.update(model.frequencies(structure, values).as_dict())
    return attrs


def completed_attrs(system: System, *, method: str, dt: float, save_every: int,
                    duration: float, transient: float, t_start: float | None = None,
                    initial_state: bool = False,
                    tolerances: tuple[float, float] | None = None,
                    speed_profile: Mapping[str, Any] | None = None) -> dict:
    """The attrs of a time run of ``system``: ``run_attrs``, then in this order ``method``,
    ``dt`` (s), ``save_every``, ``duration`` (s), ``transient`` (s), ``t_start`` (s, when
    given), the initial state as ``<state>0`` (SI units, with ``initial_state``),
    ``rtol``, ``atol`` (with ``tolerances``) and a speed profile's attrs (``speed_profile``,
    ``speed_profile_t`` (s), ``speed_profile_rpm`` (rpm): ``SpeedProfile.attrs``; then
    ``speed_rpm`` and the frequencies are those at t = 0)."""
    model = system.model
    attrs = run_attrs(model, system.structure, dict(system.parameters))
    attrs.update(method=method, dt=dt, save_every=save_every, duration=duration,
                 transient=transient)
    if t_start is not None:
        attrs.update(t_start=t_start)
    if initial_state:
        attrs.update({f"{name}0": float(v)
                      for name, v in zip(model.state_names, system.state, strict=True)})
    if tolerances is not None:
        attrs.update(rtol=tolerances[0], atol=tolerances[1])
    if speed_profile:
        attrs.update(speed_profile)
    return attrs


def noise_attrs(snr_db: float, seed: int, variables: Sequence[str]) -> dict:
    """What white measurement noise added to a run says about itself: the SNR (dB), the
    seed of its generator and the variables it was added to."""
    return {"noise_snr_db": float(snr_db), "noise_seed": int(seed),
            "noise_variables": " ".join(variables),
            "noise": "white Gaussian, numpy.random.default_rng(noise_seed), std = "
                     "std(variable)*10^(-noise_snr_db/20), variables in this order"}


def state_meaning(model: Model, name: str) -> str:
    """Words for a state variable: 'rotor displacement along the radial load', …"""
    velocity = is_velocity(name, model.state_names)
    base = name[1:] if velocity else name
    coordinate, _, body = base.partition("_")
    body = body or model.module.BODIES[0][0]
    what = {"x": "displacement along the radial load", "y": "displacement across the radial load",
            "tx": "tilt dx/dz", "ty": "tilt dy/dz"}[coordinate]
    if velocity:
        what = what.replace("displacement", "velocity").replace("tilt", "tilt rate")
    return f"{body} {what}"


def state_variable_attrs(model: Model, name: str) -> dict[str, str]:
    """The attrs of a run's state variable: ``units`` and ``long_name``."""
    return {"units": model.state_units[name], "long_name": state_meaning(model, name)}


def to_dataset(t: np.ndarray, states: np.ndarray, attrs: dict, model: Model) -> xr.Dataset:
    """A run as a Dataset: one variable per state over ``t`` (s), ``attrs`` as its own."""
    data = {name: ("t", states[i], state_variable_attrs(model, name))
            for i, name in enumerate(model.state_names)}
    return xr.Dataset(data, coords={"t": ("t", t, {"units": "s", "long_name": "time"})},
                      attrs=attrs)


# --- reading -------------------------------------------------------------------------------

def state_names(source: xr.Dataset | Mapping) -> tuple[str, ...]:
    """The state variables of a run (or section; a result or its attrs), in the order of
    the state vector: its ``state_names`` attr, ``x y vx vy`` for files older than it."""
    names = getattr(source, "attrs", source).get("state_names")
    return tuple(str(names).split()) if names else PAPER_STATE


def state_at(ds: xr.Dataset, index: int) -> np.ndarray:
    """The state (SI units, the model's order) at sample ``index`` of a run (-1: the last)."""
    return np.array([float(ds[v][index]) for v in state_names(ds)])


def is_velocity(name: str, names: Sequence[str]) -> bool:
    """Whether ``name`` is the velocity of another state variable (``vx`` of ``x``)."""
    return name.startswith("v") and name[1:] in names


def displacement_names(source: xr.Dataset | Mapping) -> tuple[str, ...]:
    """The default variables of spectra and figures: the translations (``x``, ``y``) of the
    run's first body (``x``, ``y``; ``x_rotor``, ``y_rotor``; ``x`` for one coordinate);
    ``source`` a run or its attrs."""
    names = state_names(source)
    positions = [n for n in names if not is_velocity(n, names)]
    if not positions:
        return names[:1]
    suffix = positions[0].partition("_")[2]
    chosen = tuple(n for n in positions if n.partition("_")[0] in ("x", "y")
                   and n.partition("_")[2] == suffix)
    return chosen or (positions[0],)


def _per_bearing(attrs: Mapping, prefix: str) -> dict[str, float]:
    several = {key[len(prefix) + 1:]: float(value) for key, value in attrs.items()
               if str(key).startswith(prefix + "_")}
    if several:
        return several
    value = float(attrs.get(prefix, 0.0))
    return {"": value} if value > 0 else {}


def vc_frequencies(attrs: Mapping) -> dict[str, float]:
    """Each bearing's VC frequency (Hz) from a run's attrs: ``{"": vc_hz}`` for a model with
    one bearing, ``{"left": vc_hz_left, …}`` for several, ``{}`` without bearings (VC 0)."""
    return _per_bearing(attrs, "vc_hz")


def cage_frequencies(attrs: Mapping) -> dict[str, float]:
    """Each bearing's cage frequency (Hz), keyed like :func:`vc_frequencies`."""
    return _per_bearing(attrs, "cage_hz")


def structure_of_attrs(model: Model, attrs: Mapping) -> Structure:
    """Balls per bearing from a result's attributes (``n_balls`` or ``n_balls_<bearing>``)."""
    if not model.bearing_names:
        return ()
    if "n_balls" in attrs:
        return model.structure(int(attrs["n_balls"]))
    return model.structure({b: int(attrs[f"n_balls_{b}"]) for b in model.bearing_names})


def system_of_attrs(attrs: Mapping, state: np.ndarray | None = None) -> System:
    """The System a result was computed for, from its attributes (``model``, ``spec_file``,
    balls per bearing and every parameter); ``state`` (default: the spec's initial state)."""
    spec = str(attrs.get("spec_file", ""))
    model = load_model(spec) if spec and Path(spec).is_absolute() and Path(spec).exists() \
        else load_model(str(attrs["model"]))
    values = {name: float(attrs[name]) for name in model.parameter_names if name in attrs}
    return System.make(model, structure_of_attrs(model, attrs), state, **values)


def load_dataset(path: str | Path) -> xr.Dataset:
    """Read a simulation run of any model written by bearingdyn, or raise ``InputError``
    saying why not: it must have ``t`` and every state variable its ``state_names`` attr
    names (``x``, ``y``, ``vx``, ``vy`` for files written before that attr), and pass
    ``check_run``."""
    return as_run(open_result(path), path)


def as_run(data: xr.Dataset, path: str | Path = "the run") -> xr.Dataset:
    """``data`` (a result read from ``path``) when it is a run that can be analysed
    (``load_dataset``'s checks); else ``InputError``: a file of another program (no
    ``model`` attribute), a result of another kind, or a damaged run (``check_run``)."""
    check_ours(data, path)
    missing = [v for v in state_names(data) if v not in data]
    if "t" not in data.coords or missing:
        raise InputError(f"result file: '{path}' is not a bearingdyn run "
                         f"(missing {', '.join(missing) or 't'})")
    check_run(data, path)
    return data


def check_ours(data: xr.Dataset, path: str | Path) -> None:
    """``InputError`` unless ``data`` was written by bearingdyn (it names its model)."""
    if not isinstance(data.attrs.get("model"), str):
        names = ", ".join(map(str, data.data_vars)) or "none"
        raise InputError(f"result file: '{path}' is not a bearingdyn result (it names no "
                         f"model; variables: {names[:120]}); give a file that bearingdyn "
                         "wrote")


def check_run(ds: xr.Dataset, path: str | Path = "the run") -> None:
    """Raise ``InputError`` when a run cannot be analysed as it is: its times not strictly
    increasing at the step its attributes give, a state variable not finite or not over
    ``t``, or an attribute the analyses read (``dt``, frequencies, speed) not a finite
    number in its range (a damaged or edited file)."""
    where = f"result file: '{path}'"
    t = np.asarray(ds["t"].values, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise InputError(f"{where}: holds {t.size} sample(s); a run needs at least 2")
    for name in ("dt", *RUN_ATTRS_NONNEGATIVE, *(k for k in ds.attrs if
                                                 str(k).startswith(("vc_hz", "cage_hz")))):
        if name not in ds.attrs:
            continue
        try:
            value = float(ds.attrs[name])
        except (TypeError, ValueError):
            value = float("nan")
        if not (np.isfinite(value) and (value > 0 if name == "dt" else value >= 0)):
            raise InputError(f"{where}: attribute {name} must be a finite number "
                             f"{'> 0' if name == 'dt' else '>= 0'}, got {ds.attrs[name]} "
                             "(a damaged or edited file)")
    step = np.diff(t)
    if not np.all(np.isfinite(t)) or not np.all(step > 0):
        raise InputError(f"{where}: its times are not strictly increasing")
    if "dt" in ds.attrs:
        spacing = float(ds.attrs["dt"]) * float(ds.attrs.get("save_every", 1))
        if not np.allclose(step, spacing, rtol=1e-6, atol=0.0):
            raise InputError(f"{where}: its samples are not {spacing:g} s apart as its "
                             "attributes dt and save_every say (a damaged or edited file)")
    for name in state_names(ds):
        if ds[name].dims != ("t",):
            raise InputError(f"{where}: variable {name} is not a series over t")
        bad = ~np.isfinite(ds[name].values)
        if bad.any():
            raise InputError(f"{where}: variable {name} is not finite at t = "
                             f"{t[int(np.argmax(bad))]:g} s (NaN or inf); it cannot be "
                             "analysed")


# --- JSON ----------------------------------------------------------------------------------

def provenance(source: Any) -> dict[str, Any]:
    """The provenance of a result in plain JSON types, the same content as its netCDF attrs:
    ``source`` is a result (``xarray`` object: its attrs), a mapping of attrs, or a
    ``System`` (then ``run_attrs`` of it: the model, spec path and sha256, balls per
    bearing, every parameter value, the frequencies and the versions, exactly what
    ``simulate`` writes for that system before the run's own settings), or the path of a
    result file (its attrs, read without its data)."""
    if isinstance(source, (str, Path)):
        attrs: Mapping = read_attrs(source)
    elif isinstance(source, System):
        attrs = run_attrs(source.model, source.structure, dict(source.parameters))
    else:
        attrs = getattr(source, "attrs", source)
    return {str(key): plain(value) for key, value in attrs.items()}


def plain(value: Any, *, finite: bool = False) -> Any:
    """A netCDF attribute or data value as a JSON value: numpy arrays to lists, numpy
    scalars to Python, bytes to text; with ``finite``, a NaN or infinite number (a scalar)
    to ``None`` (strict JSON has no NaN)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        value = value.item()
    elif isinstance(value, bytes):
        return value.decode()
    if finite and isinstance(value, float) and not math.isfinite(value):
        return None
    return value
