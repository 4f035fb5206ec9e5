"""The grid a diagram or chart runs over: its axes (``Axis``) and what every point shares
(``Setting``: the model, balls, base parameters, times, section and step).

A ``Setting`` gives each grid point its ``System`` (``Setting.system_at``), its record
length (``Setting.seconds``: the transient, then ``samples`` + ½ periods of its record
section) and the attributes of the result file (``Setting.attrs``, read back by
``Setting.from_attrs``). ``None`` means "the model's own": ``section=None`` classifies each
chart point on ``analysis.stability.classify.default_section`` and records
``GRID_RECORD_SECTION`` (shaft) periods; ``dt=None`` is the spec's ``[simulation] dt``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError, ParameterError, check_count
from analysis.integrate.checks import check_seconds
from analysis.integrate.cost import (
    COMPILED,
    FILE_SECONDS,
    KERNELS,
    CostEstimate,
    best_seconds,
    coarsest_step,
    estimate_cost,
    process_seconds,
)
from analysis.integrate.plan import RunPlan
from analysis.integrate.simulate import simulate
from analysis.model import BallCounts, Model, System, as_system, load_model
from analysis.provenance import displacement_names, run_attrs
from analysis.signal.poincare import period_of
from analysis.stability.classify import GRID_RECORD_SECTION

STRUCTURE_AXIS = "n_balls"
"""An axis over the number of balls: ``n_balls`` (the model's only bearing) or
``n_balls[<bearing>]``."""
MAX_AXIS_VALUES = 100_000
"""Most values one grid axis may have (a chart of 1600 points takes minutes on 2 cores)."""
MAX_GRID_POINTS = 1_000_000
"""Most points a chart may have."""
MAX_SAMPLES = 100_000
"""Most section samples per grid value."""


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

    @property
    def structural(self) -> bool:
        """An axis over balls (``n_balls``, ``n_balls[bearing]``): whole numbers."""
        return axis_bearing(self.name) is not None

    def coord(self) -> tuple[str, np.ndarray, dict[str, str]]:
        """The axis as a result-file coordinate: balls as integers (int64), parameters as
        floats, with a ``long_name``."""
        bearing = axis_bearing(self.name)
        attrs = {"long_name": f"balls in bearing {bearing}" if bearing else
                 "balls" if bearing == "" else self.name}
        values = np.array(self.values, dtype=np.int64 if self.structural else float)
        return (self.name, values, attrs)


def _axis_number(name: str, text: str, kind: type, form: str):
    try:
        return kind(text)
    except ValueError:
        word = "a whole number" if kind is int else "a number"
        raise InputError(f"axis {name}: {text!r} is not {word}; {form}") from None


def section_period(system: System, section: str) -> float:
    """The period (s) of ``section`` (``analysis.signal.poincare``) at ``system``."""
    full = dict(system.parameters)
    freqs = system.model.frequencies(system.structure, full)
    return period_of({**full, **freqs.as_dict()}, section)


@dataclass(frozen=True)
class Setting:
    """What every point shares: model (name, spec path or generated folder), balls per
    bearing, base parameters, times (s), section (see ``analysis.signal.poincare``; None:
    the model's own, see the module docstring), RK4 step (s; None: the spec's) and whether
    a chart computes λ1 at every point."""

    model: str
    n_balls: BallCounts
    values: dict[str, float]
    transient: float
    samples: int
    section: str | None = None
    dt: float | None = None
    lyapunov: bool = True

    def loaded(self) -> Model:
        """The setting's model (``load_model``, cached)."""
        return load_model(self.model)

    def step(self) -> float:
        """The RK4 step (s): ``dt``, or the spec's ``[simulation] dt``."""
        return float(self.loaded().simulation_defaults["dt"]) if self.dt is None else self.dt

    @property
    def record_section(self) -> str:
        """The section whose periods a point records: ``section``, else
        ``GRID_RECORD_SECTION`` (shaft)."""
        return self.section or GRID_RECORD_SECTION

    def system_at(self, **coords: float) -> System:
        """The System (spec's initial state) at a grid point: the base balls and parameters
        with ``coords`` (axis name → value) applied."""
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
        return as_system(self.model, n_balls, None, **values)

    def period(self, system: System) -> float:
        """The period (s) of the record section at ``system``."""
        try:
            return section_period(system, self.record_section)
        except InputError as exc:
            raise InputError(f"section {self.record_section}: no period here ({exc})") from None

    def seconds(self, system: System) -> float:
        """Simulated time (s) of a point: the transient, then ``samples`` + ½ periods of
        the record section."""
        return self.transient + (self.samples + 0.5) * self.period(system)

    def plan(self, system: System, start: float | None = None,
             warn: Callable[[str], None] | None = None) -> RunPlan:
        """The checked run of a point (``RunPlan.make``): ``seconds`` from t = ``start`` (s;
        None: from 0), the transient dropped, at ``step()``."""
        return RunPlan.make(system, duration=self.seconds(system), transient=self.transient,
                            dt=self.step(), t0=start, warn=warn)

    def attrs(self, kind: str, section: str, axes: tuple[Axis, ...] = ()) -> dict:
        """The result file's attributes: the run's provenance at the base setting without
        what ``axes`` overrule (their parameters, balls and the frequencies they change),
        then ``kind``, the times, ``section`` (the one the points were classified or
        sampled on), ``record_section`` when it differs, ``dt`` and ``lyapunov``."""
        model = self.loaded()
        attrs = run_attrs(model, model.structure(self.n_balls), model.parameters(self.values))
        overruled = set()
        for axis in axes:
            bearing = axis_bearing(axis.name)
            overruled |= {axis.name} if bearing is None else \
                {"n_balls", "bearing_name"} if bearing == "" else {f"n_balls_{bearing}"}
            for end in (axis.values[0], axis.values[-1]):
                other = self.system_at(**{axis.name: end})
                moved = other.model.frequencies(other.structure, dict(other.parameters))
                overruled |= {k for k, v in moved.as_dict().items() if attrs.get(k) != v}
        attrs = {k: v for k, v in attrs.items() if k not in overruled}
        attrs.update(kind=kind, transient=self.transient, samples=self.samples,
                     section=section, dt=self.step(), lyapunov=int(self.lyapunov))
        if self.record_section != section:
            attrs["record_section"] = self.record_section
        return attrs

    @classmethod
    def from_attrs(cls, attrs: Mapping, axes: tuple[str, ...] = ()) -> Setting:
        """The Setting a result file was computed with, from its attrs (``Setting.attrs``'s,
        or those of an older file: base balls and parameters that the axes named ``axes``
        overrule are dropped; without ``record_section`` the ``section`` was recorded)."""
        spec = str(attrs.get("spec_file", ""))
        source = spec if spec and Path(spec).is_absolute() else str(attrs["model"])
        model = load_model(source)
        bearings = {axis_bearing(a) for a in axes}
        values = {name: float(attrs[name]) for name in model.parameter_names
                  if name in attrs and name not in axes}
        n_balls: BallCounts = None
        if len(model.bearing_names) == 1 and "" not in bearings and "n_balls" in attrs:
            n_balls = int(attrs["n_balls"])
        elif len(model.bearing_names) > 1:
            n_balls = {b: int(attrs[f"n_balls_{b}"]) for b in model.bearing_names
                       if b not in bearings and f"n_balls_{b}" in attrs} or None
        section = str(attrs["section"])
        recorded = str(attrs.get("record_section", section))
        return cls(source, n_balls, values, float(attrs["transient"]), int(attrs["samples"]),
                   section if recorded == section else None, float(attrs["dt"]),
                   bool(int(attrs.get("lyapunov", 0))))


def check_grid(setting: Setting, *axes: Axis, warn: Callable[[str], None] | None = None) -> None:
    """Raise ``InputError`` before anything runs when an axis or the base setting does not
    fit the model (an unknown parameter or bearing, balls out of range, a bad section), or
    a point's run would be refused: the run plan (``Setting.plan``: times, steps per period
    of the fastest forcing, RK4 stability) is made at every corner of the grid, where the
    forcing is fastest and the contact stiffest. ``warn(message)``: a coarse step
    (default: a Python warning)."""
    _check_setting_times(setting)
    model = setting.loaded()
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
            raise ParameterError("sets", f"{{field}} {axis.name}: also an axis; drop {{it}} "
                                 "(the axis gives its values)",
                                 {"it": (f"{axis.name} from sets", "the --set")})
        bearing = axis_bearing(axis.name)
        if bearing == "" and setting.n_balls is not None and \
                not isinstance(setting.n_balls, Mapping):
            raise ParameterError("n_balls", f"{{field}}: also an axis ({axis.name}); drop "
                                 "{field}")
        if bearing and isinstance(setting.n_balls, Mapping) and bearing in setting.n_balls:
            raise ParameterError("n_balls", f"{{field}} {bearing}: also an axis "
                                 f"({axis.name}); drop it from {{field}}")
        if bearing == "" and len(model.bearings) > 1:
            raise InputError(f"axis {axis.name}: model '{model.name}' has bearings "
                             f"{', '.join(model.bearing_names)}; name one, e.g. "
                             f"n_balls[{model.bearing_names[0]}]")
        if bearing and bearing not in model.bearing_names:
            raise InputError(f"axis {axis.name}: model '{model.name}' has no bearing "
                             f"'{bearing}'; bearings: {', '.join(model.bearing_names) or 'none'}")
        for value in (axis.values[0], axis.values[-1]):
            _check_section_at(setting, axis.name, value)
    for corner in itertools.product(*((axis.values[0], axis.values[-1]) for axis in axes)):
        system = setting.system_at(**{a.name: v for a, v in zip(axes, corner, strict=True)})
        setting.plan(system, warn=warn)  # times, resolution, RK4 step at the grid's corners


GRID_COST_SAMPLES = 64
"""Grid points whose record lengths are averaged for a grid's expected cost (evenly spaced
over the grid in its order)."""


def grid_cost(setting: Setting, *axes: Axis, workers: int | None = None,
              members_per_point: int = 1, lyapunov: bool | None = None,
              path: str | None = None,
              point: Callable[[System], object] | None = None) -> CostEstimate:
    """The cost of a grid's points (``analysis.integrate.cost``), said before they run: the
    mean RK4 steps of up to ``GRID_COST_SAMPLES`` points evenly spread over the grid (a
    point records ``samples`` periods of its own section: a speed axis spans a factor of
    ten), ``members_per_point`` runs a point (initial states, directions), timed on the
    ``path`` that runs them: None, the member kernels with λ1 (``lyapunov``; None: the
    setting's: a chart's points, ``points.kernel_points``) and the compiled blocks without
    (``points.one_pass``, a followed sweep); ``KERNELS`` for a sweep without following. On
    the kernels the steps of the record and of the tangent's transient
    (``lyapunov.default_lengths``) carry λ1's tangent, each counted by its measured cost
    (``estimate_cost``; ``n + 1`` state steps where the member kernel cannot be built). The
    step per second is probed at the corner with the longest record; the coarser ``--dt``
    offered is one every corner accepts. ``point``: the command's whole work of one point
    (a followed sweep's ``diagram.safe_diagram_point``), timed at that corner (the faster
    of two calls): what it takes beyond its probed steps is a point's host work (sections,
    the 1X phasor, the run's checks: as much as its RK4 steps on a followed sweep), scaled
    to the mean record. Call after ``check_grid``."""
    from analysis.stability.lyapunov import default_lengths

    names = [a.name for a in axes]
    corners = [setting.system_at(**dict(zip(names, values, strict=True)))
               for values in itertools.product(*((a.values[0], a.values[-1]) for a in axes))]
    system = max(corners, key=setting.seconds)
    dt = setting.step()
    shape = [len(axis.values) for axis in axes]
    total = math.prod(shape)
    picked = np.unique(np.linspace(0, total - 1, min(total, GRID_COST_SAMPLES)).round())
    seconds = [setting.seconds(setting.system_at(**{
        n: a.values[i] for n, a, i in zip(names, axes, np.unravel_index(int(k), shape),
                                          strict=True)})) for k in picked]
    steps = math.ceil(float(np.mean(seconds)) / dt)
    tangent = 0
    if setting.lyapunov if lyapunov is None else lyapunov:
        before = min(default_lengths(system.model)[2], setting.transient)
        tangent = min(steps, math.ceil((float(np.mean(seconds)) - setting.transient + before)
                                       / dt))
    route = path or (KERNELS if tangent else COMPILED)
    est = estimate_cost(system, total * members_per_point, steps, dt=dt, workers=workers,
                        path=route, tangent_steps=tangent)
    steps_fine = [c for c in (coarsest_step(corner) for corner in corners) if c is not None]
    parts = []
    if point is not None:
        whole = best_seconds(lambda: point(system))
        longest = math.ceil(setting.seconds(system) / dt)
        host = max(0.0, whole - longest * est.step_seconds) * steps / longest  # the mean
        runs = total * members_per_point
        parts.append(("the host's work of the points (probed)",
                      host * runs / max(1, min(est.workers, runs))))
    return replace(est, average=len(picked) > 1,
                   coarsest_dt=min(steps_fine) if len(steps_fine) == len(corners) else None,
                   spent=process_seconds()).with_parts(*parts, ("the file", FILE_SECONDS))


def _check_section_at(setting: Setting, name: str, value: float) -> None:
    """``InputError`` naming the axis and its value when the recorded section has no period
    at ``name`` = ``value`` (a shaft at rest: 0 rpm), instead of the frequency it lacks."""
    section = setting.record_section
    try:
        section_period(setting.system_at(**{name: value}), section)
    except InputError as exc:
        frequency, _, _ = str(exc).partition(":")
        if not frequency.endswith("_hz") and "_hz_" not in frequency:
            raise
        raise InputError(f"axis {name}: the '{section}' section has no period at {name} = "
                         f"{value:g} ({frequency} = 0 Hz); give values at which it turns "
                         "(> 0 at both ends), or another --section") from None


def _check_setting_times(setting: Setting) -> None:
    """The times every point shares, each named as its option."""
    check_seconds("transient", setting.transient, zero=True)
    check_count("samples", setting.samples, 1, MAX_SAMPLES,
                " (section periods recorded per value)")


def amplitude_fields(model: Model) -> list[str]:
    """``amplitude_<v>`` of the first body's displacements ``v`` of ``model``."""
    names = displacement_names(xr.Dataset(attrs={"state_names": " ".join(model.state_names)}))
    return [f"amplitude_{v}" for v in names]


def amplitudes(ds: xr.Dataset) -> dict[str, float]:
    """Half peak-to-peak of the first body's displacements of a run: ``amplitude_x``, …
    (unit of the variable)."""
    return {f"amplitude_{v}": float(np.ptp(ds[v].values)) / 2 for v in displacement_names(ds)}


def record(setting: Setting, system: System) -> xr.Dataset:
    """Simulate ``system`` for ``setting.seconds`` from t = 0 (RK4, ``setting.step()``), the
    transient dropped: the run of a grid point."""
    return simulate(system, duration=setting.seconds(system), transient=setting.transient,
                    dt=setting.step())
