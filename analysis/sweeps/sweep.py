"""Bifurcation diagrams and stability charts over parameter grids.

* ``bifurcation_diagram``: one runtime parameter of the model (speed, clearance, load,
  unbalance, damping, …) or its structure (``n_balls`` for a model with one bearing,
  ``n_balls[left]`` for the bearing ``left`` of a model with several) on a grid; at each
  value the motion is simulated, the transient dropped and ``samples`` Poincaré points of
  every state variable kept. With ``follow=True`` each value continues the previous one,
  up and/or down the grid (hysteresis shows as different branches).
* ``stability_chart``: a 2-D grid; each point classified (``analysis.stability.classify``) as
  periodic-n, quasi-periodic or chaotic, with its largest Lyapunov exponent and amplitude.

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

Both run through one executor (``analysis.sweeps.executors``: serial, local processes or Dask) and
store each finished point at once (``analysis.sweeps.store``): re-running an interrupted command
computes only the missing points. Followed diagram chains write their points from the
worker (a Dask cluster on several machines needs a shared file system for them); chart
points are written by the calling process as they arrive.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError, SimulationError
from analysis.integrate.checks import check_rk4_step, check_seconds
from analysis.integrate.compiled import library, run_rk4
from analysis.integrate.lanes import LANES
from analysis.integrate.simulate import blow_up_limit, run_attrs, simulate, state_at, to_dataset
from analysis.io import save_dataset
from analysis.model import BallCounts, System, load_model
from analysis.signal import displacement_names
from analysis.signal.poincare import period_of, poincare_section
from analysis.sweeps.executors import Executor, SerialExecutor
from analysis.sweeps.points import chart_points  # one pass; chart_point_two_pass below
from analysis.sweeps.store import PointStore

NATURE_CODES = {"failed": 0, "periodic-1": 1, "periodic-2": 2, "periodic-n": 3,
                "quasi-periodic": 4, "chaotic": 5}
"""Integer codes of the chart classes (periodic-n: n >= 3; failed: the point's run blew up
or its solver failed, its ``nature`` says how: ``failed: blew up at t = 0.52 s``)."""


def failure_text(exc: SimulationError) -> str:
    """``failed: <what happened>``: the class recorded for a point whose run failed."""
    return "failed: " + str(exc).split(";")[0].replace("the motion ", "")


def _displacement_fields(model_name: str) -> list[str]:
    model = load_model(model_name)
    names = displacement_names(xr.Dataset(attrs={"state_names": " ".join(model.state_names)}))
    return [f"amplitude_{v}" for v in names]


STRUCTURE_AXIS = "n_balls"
"""An axis over the number of balls: ``n_balls`` (the model's only bearing) or
``n_balls[<bearing>]``."""


def axis_bearing(name: str) -> str | None:
    """The bearing a structure axis names: ``""`` for ``n_balls``, ``"left"`` for
    ``n_balls[left]``, None for a parameter axis."""
    if name == STRUCTURE_AXIS:
        return ""
    if name.startswith(STRUCTURE_AXIS + "[") and name.endswith("]") and len(name) > 9:
        return name[len(STRUCTURE_AXIS) + 1:-1]
    return None


@dataclass(frozen=True)
class Axis:
    """A grid axis: ``name`` (a runtime parameter, ``n_balls`` or ``n_balls[bearing]``) and
    its values."""

    name: str
    values: tuple[float, ...]

    @classmethod
    def parse(cls, text: str) -> Axis:
        """``speed_rpm:1000:10000:200`` (start:stop:count), or ``n_balls:5:12`` /
        ``n_balls[left]:5:12`` (every whole number from low to high)."""
        parts = text.split(":")
        form = ("expected name:start:stop:count (or n_balls:low:high, "
                f"n_balls[bearing]:low:high), got {text!r}")
        name = parts[0]
        if not name:
            raise InputError(f"axis: a parameter name is missing; {form}")
        if axis_bearing(name) is not None and len(parts) == 3:
            low, high = (_axis_number(name, p, int, form) for p in parts[1:])
            if high < low:
                raise InputError(f"axis {name}: low must be <= high (the balls run upward), "
                                 f"got {low}:{high}; write {name}:{high}:{low}")
            return cls.linear(name, low, high, high - low + 1)
        if len(parts) != 4:
            raise InputError(f"axis: {form}")
        start, stop = (_axis_number(name, p, float, form) for p in parts[1:3])
        return cls.linear(name, start, stop, _axis_number(name, parts[3], int, form))

    @classmethod
    def linear(cls, name: str, start: float, stop: float, num: int) -> Axis:
        """``num`` equally spaced values from ``start`` to ``stop`` (whole, distinct numbers
        for ``n_balls`` and ``n_balls[bearing]``)."""
        for what, value in (("start", start), ("stop", stop)):
            if not math.isfinite(value):
                raise InputError(f"axis {name}: {what} must be a finite number, got {value}")
        if not 1 <= num <= MAX_AXIS_VALUES:
            raise InputError(f"axis {name}: count must be in [1, {MAX_AXIS_VALUES}], got {num}")
        values = np.linspace(start, stop, num)
        if axis_bearing(name) is not None:
            values = np.unique(np.round(values))
        return cls(name, tuple(values.tolist()))


MAX_AXIS_VALUES = 100_000
"""Most values one grid axis may have (a chart of 1600 points takes minutes on 2 cores)."""
MAX_GRID_POINTS = 1_000_000
"""Most points a chart may have."""


def _axis_number(name: str, text: str, kind: type, form: str):
    try:
        return kind(text)
    except ValueError:
        word = "a whole number" if kind is int else "a number"
        raise InputError(f"axis {name}: {text!r} is not {word}; {form}") from None


@dataclass(frozen=True)
class Setting:
    """What every point shares: model (name, spec path or generated folder), balls per
    bearing, base parameters, times (s), section (see ``analysis.signal.poincare``)."""

    model: str
    n_balls: BallCounts
    values: dict[str, float]
    transient: float
    samples: int
    section: str = "shaft"
    dt: float = 1e-5
    lyapunov: bool = True

    def at(self, **coords: float) -> tuple[BallCounts, dict[str, float]]:
        """(n_balls, parameter values) at a grid point."""
        n_balls, values = self.n_balls, dict(self.values)
        for name, value in coords.items():
            bearing = axis_bearing(name)
            if bearing == "":
                n_balls = round(value)
            elif bearing is not None:  # merged into the base counts given by name
                base = dict(n_balls) if isinstance(n_balls, Mapping) else {}
                n_balls = {**base, bearing: round(value)}
            else:
                values[name] = value
        return n_balls, values


def check_grid(setting: Setting, *axes: Axis) -> None:
    """Raise ``InputError`` before anything runs when an axis or the base setting does not
    fit the model (an unknown parameter or bearing, balls out of range, a bad section)."""
    _check_setting_times(setting)
    model = load_model(setting.model)
    model.parameters(setting.values)
    model.structure(setting.n_balls)
    names = [axis.name for axis in axes]
    if len(set(names)) < len(names):
        raise InputError(f"axis {names[0]}: the same on both axes; give two different "
                         "parameters (--x and --y)")
    if math.prod(len(axis.values) for axis in axes) > MAX_GRID_POINTS:
        raise InputError(f"axes: at most {MAX_GRID_POINTS} points in all, got "
                         f"{' x '.join(str(len(a.values)) for a in axes)}")
    for axis in axes:
        if axis.name in setting.values:
            raise InputError(f"--set {axis.name}: also an axis; drop the --set (the axis "
                             "gives its values)")
        bearing = axis_bearing(axis.name)
        if bearing == "" and setting.n_balls is not None and \
                not isinstance(setting.n_balls, Mapping):
            raise InputError(f"--n-balls: also an axis ({axis.name}); drop --n-balls")
        if bearing and isinstance(setting.n_balls, Mapping) and bearing in setting.n_balls:
            raise InputError(f"--n-balls {bearing}: also an axis ({axis.name}); drop it "
                             "from --n-balls")
        bearing = axis_bearing(axis.name)
        if bearing == "" and len(model.bearings) > 1:
            raise InputError(f"axis {axis.name}: model '{model.name}' has bearings "
                             f"{', '.join(model.bearing_names)}; name one, e.g. "
                             f"n_balls[{model.bearing_names[0]}]")
        if bearing and bearing not in model.bearing_names:
            raise InputError(f"axis {axis.name}: model '{model.name}' has no bearing "
                             f"'{bearing}'; bearings: {', '.join(model.bearing_names) or 'none'}")
        for value in (axis.values[0], axis.values[-1]):
            n_balls, values = setting.at(**{axis.name: value})
            structure = model.structure(n_balls)
            period_of({**model.parameters(values),
                       **model.frequencies(structure, model.parameters(values)).as_dict()},
                      setting.section)


MAX_SAMPLES = 100_000
"""Most section samples per grid value."""


def _check_setting_times(setting: Setting) -> None:
    """The times every point shares, each named as its option."""
    check_seconds("transient", setting.transient, zero=True)
    if not (isinstance(setting.samples, int) and 1 <= setting.samples <= MAX_SAMPLES):
        raise InputError(f"samples: must be a whole number in [1, {MAX_SAMPLES}] (section "
                         f"periods recorded per value), got {setting.samples}")
    if not (math.isfinite(setting.dt) and 0 < setting.dt <= 1e-2):
        raise InputError(f"dt: must be in (0, 0.01] s, got {setting.dt}")


def _period(setting: Setting, n_balls: BallCounts, values: dict[str, float]) -> float:
    """The period (s) of the setting's section at a grid value."""
    model = load_model(setting.model)
    full = model.parameters(values)
    freqs = model.frequencies(model.structure(n_balls), full)
    try:
        return period_of({**full, **freqs.as_dict()}, setting.section)
    except InputError as exc:
        raise InputError(f"section {setting.section}: no period here ({exc})") from None


def _duration(setting: Setting, period: float) -> float:
    """Simulated time (s) of a value: the transient, then ``samples`` + ½ section periods."""
    return setting.transient + (setting.samples + 0.5) * period


def _record(setting: Setting, n_balls: BallCounts, values: dict[str, float],
            initial_state=None) -> xr.Dataset:
    """Simulate transient + ``samples`` section periods from t = 0."""
    duration = _duration(setting, _period(setting, n_balls, values))
    return simulate(load_model(setting.model), n_balls, duration=duration,
                    transient=setting.transient, dt=setting.dt, initial_state=initial_state,
                    **values)


@dataclass(frozen=True)
class Start:
    """Where a value's run starts: ``state`` (SI, the model's order) at time ``time`` (s)."""

    state: tuple[float, ...]
    time: float = 0.0


def _record_from(setting: Setting, n_balls: BallCounts, values: dict[str, float],
                 start: Start) -> xr.Dataset:
    """Like ``_record`` but from ``start.state`` at t = ``start.time``: fixed-step RK4 on
    t = start.time + n·dt (the integrator's own times), the transient dropped.
    (``simulate`` always starts at t = 0.)"""
    model = load_model(setting.model)
    system = System.make(model, n_balls, start.state, **values)
    duration, dt = _duration(setting, _period(setting, n_balls, values)), setting.dt
    check_rk4_step(model, system.structure, dict(system.parameters), dt, "rk4")
    n_steps = round(duration / dt)
    states = run_rk4(library(model, system.structure), system.p, system.state, dt, n_steps,
                     t0=start.time)
    elapsed = np.arange(n_steps + 1) * dt
    _check_bounded(system, states, start.time + elapsed)
    keep = elapsed >= setting.transient - 1e-12 * duration
    attrs = run_attrs(model, system.structure, dict(system.parameters))
    attrs.update(method="rk4", dt=dt, save_every=1, duration=duration,
                 transient=setting.transient, t_start=start.time)
    attrs.update({f"{name}0": float(v) for name, v in zip(model.state_names, system.state,
                                                          strict=True)})
    return to_dataset(start.time + elapsed[keep], states[:, keep], attrs, model)


def _check_bounded(system: System, states: np.ndarray, times: np.ndarray) -> None:
    """``SimulationError`` when a state is not finite or a body's centre is beyond
    ``blow_up_limit`` (m), as ``simulate`` checks its runs."""
    limit = blow_up_limit(system.model, system.parameters)
    bad = ~np.all(np.isfinite(states), axis=0)
    for i, j in system.model.centre_indices():
        radius = np.abs(states[i]) if j is None else np.hypot(states[i], states[j])
        bad |= radius > limit
    if np.any(bad):
        raise SimulationError(
            f"the motion blew up at t = {times[int(np.argmax(bad))]:.6g} s (displacement "
            f"not finite or beyond {limit:g} m); try a smaller dt, more damping, or check "
            "the parameters")


def _amplitudes(ds: xr.Dataset) -> dict[str, float]:
    """Half peak-to-peak of the first body's displacements: ``amplitude_x``, … (unit of
    the variable)."""
    return {f"amplitude_{v}": float(np.ptp(ds[v].values)) / 2 for v in displacement_names(ds)}


def diagram_point(setting: Setting, n_balls: BallCounts, values: dict[str, float],
                  start: Start | None = None) -> dict:
    """Poincaré samples of every state variable, amplitudes, and the run's start and end
    (``t_start``, ``t_final`` in s, ``final`` the end state) at one grid value; from the
    spec's initial state at t = 0 without ``start``."""
    if start is None:
        ds, t_start = _record(setting, n_balls, values), 0.0
    else:
        ds, t_start = _record_from(setting, n_balls, values, start), start.time
    pts = poincare_section(ds, setting.section)
    k = setting.samples
    out = {v: pts[v].values[:k] for v in ds.attrs["state_names"].split()}
    out["final"] = state_at(ds, -1)
    out["t_start"] = t_start
    out["t_final"] = float(ds.t[-1])
    out.update(_amplitudes(ds))
    return out


def follow_start(setting: Setting, previous: tuple[BallCounts, dict[str, float]],
                 point: Mapping, n_balls: BallCounts, values: dict[str, float]) -> Start:
    """Start of a followed value after the ``previous`` (n_balls, values) ended as
    ``point`` (a result of ``diagram_point``): its end state at the time with the same
    section phase, t = t_final·T_new/T_old (s; see the module docstring)."""
    periods = float(point["t_final"]) / _period(setting, *previous)
    return Start(tuple(np.asarray(point["final"], dtype=float)),
                 periods * _period(setting, n_balls, values))


def chart_point_two_pass(setting: Setting, n_balls, values) -> dict:
    """Class, period, largest Lyapunov exponent (1/s) and amplitudes (m) at one point, in
    two passes (simulate and keep every state, then ``lyapunov`` from the record's first
    state): the former chart point, kept for comparison. The chart uses
    ``analysis.sweeps.points.chart_point`` (one pass)."""
    from analysis.stability.classify import classify
    from analysis.stability.lyapunov import lyapunov

    ds = _record(setting, n_balls, values)
    exponents = None
    if setting.lyapunov:
        start = tuple(state_at(ds, 0))
        exponents = lyapunov(setting.model, n_balls, duration=float(ds.t[-1] - ds.t[0]),
                             transient=0.0, dt=setting.dt, n_exponents=1,
                             initial_state=start, **values)
    result = classify(ds, setting.section if setting.section != "shaft" else None,
                      exponents)
    nature = result.nature
    code = NATURE_CODES.get(nature, NATURE_CODES["periodic-n"])
    lam = float(exponents.exponents[0]) if exponents is not None else np.nan
    ci = float(exponents.ci95[0]) if exponents is not None else np.nan
    return {"nature": nature, "nature_code": code, "period": result.period or 0,
            "lyapunov": lam, "ci95": ci, "graph_ratio": result.graph_ratio or np.nan,
            **_amplitudes(ds)}


# --- bifurcation diagrams -----------------------------------------------------------------

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


def run_chain(chain: Chain) -> int:
    """Compute the missing points of one chain in order, storing each as it finishes; a
    followed value starts where the previous one ended (``follow_start``)."""
    store = PointStore(chain.output, chain.definition)
    done, computed = store.done(), 0
    previous, point = None, None
    for i in chain.order():
        key = f"{chain.direction}-{i:05d}"
        n_balls, values = chain.setting.at(**{chain.axis.name: chain.axis.values[i]})
        if key in done:
            point = store.load(key)
        else:
            start = follow_start(chain.setting, previous, point, n_balls, values) \
                if chain.follow and point is not None else None
            point = safe_diagram_point(chain.setting, n_balls, values, start)
            store.save(key, point)
            computed += 1
        if str(point.get("status", "")):
            point = None  # a failed value: the next one starts from the initial state
        previous = (n_balls, values)
    return computed


def safe_diagram_point(setting: Setting, n_balls: BallCounts, values: dict[str, float],
                       start: Start | None = None) -> dict:
    """``diagram_point``, or for a value whose run fails a record of it (``status``
    ``failed: …``, no section points, NaN amplitudes) so the diagram goes on."""
    try:
        return {**diagram_point(setting, n_balls, values, start), "status": ""}
    except SimulationError as exc:
        model = load_model(setting.model)
        return {**{v: np.zeros(0) for v in model.state_names},
                "final": np.full(model.n_state, np.nan), "t_start": np.nan,
                "t_final": np.nan, "status": failure_text(exc),
                **dict.fromkeys(_displacement_fields(setting.model), np.nan)}


def _point_task(args: tuple) -> tuple[str, dict]:
    """A diagram point without state following (parallel over the grid)."""
    chain, i = args
    n_balls, values = chain.setting.at(**{chain.axis.name: chain.axis.values[i]})
    return f"{chain.direction}-{i:05d}", safe_diagram_point(chain.setting, n_balls, values)


def bifurcation_diagram(setting: Setting, axis: Axis, output: str | Path, *,
                        direction: str = "up", follow: bool = True,
                        executor: Executor | None = None,
                        progress: Callable[[int, int], None] | None = None,
                        on_damaged: Callable[[str], None] | None = None) -> xr.Dataset:
    """Brute-force orbit diagram over ``axis``; writes and returns the netCDF Dataset.

    Resumable (``analysis.sweeps.store``): a stored point that cannot be read is removed,
    reported to ``on_damaged(key)`` and computed again. A value whose run fails is recorded
    (``status``: ``failed: …``) and the diagram goes on."""
    if direction not in ("up", "down", "both"):
        raise InputError(f"direction: must be up, down or both, got {direction!r}")
    directions = ["up", "down"] if direction == "both" else [direction]
    check_grid(setting, axis)
    definition = {"kind": "diagram", "setting": asdict(setting), "axis": asdict(axis),
                  "structure": _structure(setting), "directions": directions,
                  "follow": follow}
    if follow:  # stores of the former restarts at t = 0 are not resumed with these
        definition["restart"] = FOLLOW_RESTART
    store = PointStore(output, definition, lock=True, on_damaged=on_damaged)
    try:
        chains = [Chain(setting, axis, d, follow, str(output), definition) for d in directions]
        total = len(chains) * len(axis.values)
        executor = executor or SerialExecutor()
        if follow:
            _run_with_progress(executor, run_chain, chains, store, total, progress, None)
        else:
            todo = [(c, i) for c in chains for i in range(len(axis.values))
                    if f"{c.direction}-{i:05d}" not in store.done()]
            _run_with_progress(executor, _point_task, todo, store, total, progress,
                               lambda task, result: store.save(*result))
        ds = _assemble_diagram(store, setting, axis, directions, follow)
        save_dataset(ds, output)
        store.remove()
    finally:
        store.close()
    return ds


def _structure(setting: Setting) -> list[int]:
    """The base balls per bearing of a sweep (part of its stored definition)."""
    return list(load_model(setting.model).structure(setting.n_balls))


def _axis_coord(axis: Axis) -> tuple[str, list[float], dict[str, str]]:
    bearing = axis_bearing(axis.name)
    attrs = {"long_name": f"balls in bearing {bearing}" if bearing else
             "balls" if bearing == "" else axis.name}
    return (axis.name, list(axis.values), attrs)


def _assemble_diagram(store, setting, axis, directions, follow) -> xr.Dataset:
    n = len(axis.values)
    model = load_model(setting.model)
    units = model.state_units
    first = store.load(f"{directions[0]}-{0:05d}")
    arrays = {v: np.full((len(directions), n, setting.samples), np.nan)
              for v in model.state_names}
    amplitudes = [v for v in first if v.startswith("amplitude_")]
    per_value = {v: np.full((len(directions), n), np.nan) for v in [*amplitudes, "t_start"]}
    status = np.full((len(directions), n), "", dtype=object)
    for d, direction in enumerate(directions):
        for i in range(n):
            point = store.load(f"{direction}-{i:05d}")
            for v in arrays:
                arrays[v][d, i, :len(point[v])] = point[v]
            for v in per_value:
                per_value[v][d, i] = point[v]
            status[d, i] = str(point.get("status", ""))
    data = {v: (("direction", axis.name, "k"), arrays[v],
                {"units": units[v], "long_name": f"{v} on the {setting.section} section"})
            for v in arrays}
    data.update({v: (("direction", axis.name), per_value[v],
                     {"units": units.get(v[len("amplitude_"):], "m")}) for v in amplitudes})
    data["status"] = (("direction", axis.name), status.astype(str),
                      {"long_name": "empty, or why the value's run failed (failed: …)"})
    data["t_start"] = (("direction", axis.name), per_value["t_start"],
                       {"units": "s", "long_name": "time at which the value's run starts"})
    attrs = _attrs(setting, "diagram")
    attrs.update(param=axis.name, follow=int(follow))
    if follow:
        attrs.update(follow_restart=FOLLOW_RESTART)
    return xr.Dataset(data, coords={"direction": directions, axis.name: _axis_coord(axis),
                                    "k": np.arange(setting.samples)}, attrs=attrs)


# --- stability charts ---------------------------------------------------------------------

def _failed_point(setting: Setting, exc: SimulationError) -> dict:
    """A point whose run blew up: recorded as its class, and the chart goes on."""
    return {"nature": failure_text(exc), "nature_code": NATURE_CODES["failed"],
            "period": 0, "lyapunov": np.nan, "ci95": np.nan, "graph_ratio": np.nan,
            **dict.fromkeys(_displacement_fields(setting.model), np.nan)}


def _chart_group_task(group: list[tuple]) -> list[tuple[str, dict]]:
    """Chart points of one model and balls together (``points.chart_points``: their
    tangents in lockstep, each result ``points.chart_point``'s bit for bit)."""
    setting = group[0][0]
    points = [setting.at(**{xname: xval, yname: yval})
              for _, xname, xval, yname, yval, _ in group]
    return [(task[-1], out if isinstance(out, dict) else _failed_point(setting, out))
            for task, out in zip(group, chart_points(setting, points), strict=True)]


def _chart_groups(setting: Setting, tasks: list[tuple]) -> list[list[tuple]]:
    """Neighbouring pending points of the same balls in groups of ``LANES`` (one group per
    point without a tangent: lanes only speed up the tangent)."""
    if not setting.lyapunov:
        return [[task] for task in tasks]
    model = load_model(setting.model)
    groups: list[list[tuple]] = []
    previous = None
    for task in tasks:
        _, xname, xval, yname, yval, _ = task
        balls = model.structure(setting.at(**{xname: xval, yname: yval})[0])
        if groups and balls == previous and len(groups[-1]) < LANES:
            groups[-1].append(task)
        else:
            groups.append([task])
        previous = balls
    return groups


def stability_chart(setting: Setting, x: Axis, y: Axis, output: str | Path, *,
                    executor: Executor | None = None,
                    progress: Callable[[int, int], None] | None = None,
                    on_damaged: Callable[[str], None] | None = None) -> xr.Dataset:
    """Classify every point of the grid y × x; writes and returns the netCDF Dataset.

    Resumable as ``bifurcation_diagram``; a point whose run fails is classed ``failed: …``
    (``nature_code`` 0) and the chart goes on."""
    check_grid(setting, x, y)
    definition = {"kind": "chart", "setting": asdict(setting), "x": asdict(x), "y": asdict(y),
                  "structure": _structure(setting)}
    store = PointStore(output, definition, lock=True, on_damaged=on_damaged)
    try:
        done = store.done()
        tasks = [(setting, x.name, xv, y.name, yv, f"{iy:04d}-{ix:04d}")
                 for iy, yv in enumerate(y.values) for ix, xv in enumerate(x.values)
                 if f"{iy:04d}-{ix:04d}" not in done]
        _run_with_progress(executor or SerialExecutor(), _chart_group_task,
                           _chart_groups(setting, tasks), store,
                           len(x.values) * len(y.values), progress,
                           lambda group, results: [store.save(*r) for r in results])
        ds = _assemble_chart(store, setting, x, y)
        save_dataset(ds, output)
        store.remove()
    finally:
        store.close()
    return ds


def _assemble_chart(store, setting, x: Axis, y: Axis) -> xr.Dataset:
    shape = (len(y.values), len(x.values))
    first = store.load(f"{0:04d}-{0:04d}")
    fields = ("nature_code", "period", "lyapunov", "ci95",
              *(f for f in first if f.startswith("amplitude_")), "graph_ratio")
    arrays = {f: np.full(shape, np.nan) for f in fields}
    nature = np.empty(shape, dtype=object)
    for iy in range(shape[0]):
        for ix in range(shape[1]):
            point = store.load(f"{iy:04d}-{ix:04d}")
            for f in fields:
                arrays[f][iy, ix] = point[f]
            nature[iy, ix] = str(point["nature"])
    dims = (y.name, x.name)
    state_units = load_model(setting.model).state_units
    units = {"lyapunov": "1/s", "ci95": "1/s",
             **{f: state_units.get(f[len("amplitude_"):], "m") for f in fields
                if f.startswith("amplitude_")}}
    data = {f: (dims, arrays[f], {"units": units[f]} if f in units else {}) for f in fields}
    data["nature_code"] = (dims, arrays["nature_code"].astype(int),
                           {"legend": ", ".join(f"{v}: {k}" for k, v in NATURE_CODES.items())})
    data["period"] = (dims, arrays["period"].astype(int))
    data["nature"] = (dims, nature)
    attrs = _attrs(setting, "chart")
    attrs.update(x=x.name, y=y.name)
    return xr.Dataset(data, coords={y.name: _axis_coord(y), x.name: _axis_coord(x)},
                      attrs=attrs)


def _attrs(setting: Setting, kind: str) -> dict:
    model = load_model(setting.model)
    n = model.structure(setting.n_balls)
    attrs = run_attrs(model, n, model.parameters(setting.values))
    attrs.update(kind=kind, transient=setting.transient, samples=setting.samples,
                 section=setting.section, dt=setting.dt, lyapunov=int(setting.lyapunov))
    return attrs


def _run_with_progress(executor: Executor, fn, tasks, store: PointStore, total: int,
                       progress, on_result) -> None:
    """Run tasks in a background thread; report the number of stored points meanwhile."""
    failure: list[BaseException] = []

    def consume():
        try:
            for task, result in executor.run(fn, tasks):
                if on_result:
                    on_result(task, result)
        except BaseException as exc:  # re-raised in the calling thread
            failure.append(exc)

    worker = threading.Thread(target=consume, daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.5)
        if progress:
            progress(len(store.done()), total)
    if failure:
        raise failure[0]
    if progress:
        progress(len(store.done()), total)


def _axis_heading(ds: xr.Dataset, name: str) -> str:
    bearing = axis_bearing(name)
    return f"{name} (balls in bearing {bearing})" if bearing else name


def chart_table(ds: xr.Dataset) -> str:
    """Markdown table of a chart: the shape of the paper's Table 2 (a structure axis says
    its bearing: ``n_balls[left] (balls in bearing left)``; amplitudes of the first body's
    displacements in µm, or in their own unit when not metres)."""
    xname, yname = ds.attrs["x"], ds.attrs["y"]
    amplitudes = [v for v in ds.data_vars if str(v).startswith("amplitude_")]

    def heading(v: str) -> str:
        unit = ds[v].attrs.get("units", "m")
        return f"amplitude {v[len('amplitude_'):]} ({'µm' if unit == 'm' else unit})"

    def value(p, v: str) -> str:
        scale = 1e6 if ds[v].attrs.get("units", "m") == "m" else 1.0
        return f"{float(p[v]) * scale:.3g}"

    lines = [f"| {_axis_heading(ds, yname)} | {_axis_heading(ds, xname)} | nature | "
             "largest Lyapunov exponent (1/s) | " + " | ".join(map(heading, amplitudes)) + " |",
             "|---|---|---|---|" + "---|" * len(amplitudes)]
    for yv in ds[yname].values:
        for xv in ds[xname].values:
            p = ds.sel({yname: yv, xname: xv})
            lam = float(p.lyapunov)
            lam_text = "–" if math.isnan(lam) else f"{lam:.3g} ± {float(p.ci95):.2g}"
            lines.append(f"| {yv:g} | {xv:g} | {p.nature.item()} | {lam_text} | "
                         + " | ".join(value(p, v) for v in amplitudes) + " |")
    return "\n".join(lines) + "\n"
