"""Bifurcation diagrams and stability charts over parameter grids.

* ``bifurcation_diagram``: one parameter (speed, clearance, load, unbalance, damping or
  n_balls) on a grid; at each value the motion is simulated, the transient dropped and
  ``samples`` Poincaré points kept. With ``follow=True`` each point starts from the end state
  of the previous one, up and/or down the grid (hysteresis shows as different branches).
* ``stability_chart``: a 2-D grid; each point classified (``analysis.stability.classify``) as
  periodic-n, quasi-periodic or chaotic, with its largest Lyapunov exponent and amplitude.

Both run through one executor (``analysis.sweeps.executors``: serial, local processes or Dask) and
store each finished point at once (``analysis.sweeps.store``): re-running an interrupted command
computes only the missing points. Followed diagram chains write their points from the
worker (a Dask cluster on several machines needs a shared file system for them); chart
points are written by the calling process as they arrive.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.simulate import run_attrs, simulate, state_at
from analysis.io import save_dataset
from analysis.model import load_model
from analysis.signal.poincare import poincare_section
from analysis.sweeps.executors import Executor, SerialExecutor
from analysis.sweeps.store import PointStore

NATURE_CODES = {"periodic-1": 1, "periodic-2": 2, "periodic-n": 3, "quasi-periodic": 4,
                "chaotic": 5}
"""Integer codes of the chart classes (periodic-n: n >= 3)."""


@dataclass(frozen=True)
class Axis:
    """A grid axis: ``name`` (a runtime parameter, or ``n_balls``) and its values."""

    name: str
    values: tuple[float, ...]

    @classmethod
    def parse(cls, text: str) -> Axis:
        """``speed_rpm:1000:10000:200`` (start:stop:count) or ``n_balls:5:12`` (integers)."""
        parts = text.split(":")
        try:
            if parts[0] == "n_balls" and len(parts) == 3:
                low, high = int(parts[1]), int(parts[2])
                return cls("n_balls", tuple(float(n) for n in range(low, high + 1)))
            name, start, stop, num = parts[0], float(parts[1]), float(parts[2]), int(parts[3])
        except (ValueError, IndexError):
            raise InputError(f"axis: expected name:start:stop:count (or n_balls:low:high), "
                             f"got {text!r}") from None
        return cls.linear(name, start, stop, num)

    @classmethod
    def linear(cls, name: str, start: float, stop: float, num: int) -> Axis:
        """``num`` equally spaced values from ``start`` to ``stop`` (whole, distinct numbers
        for ``n_balls``)."""
        if num < 1:
            raise InputError(f"axis {name}: count must be >= 1, got {num}")
        values = np.linspace(start, stop, num)
        if name == "n_balls":
            values = np.unique(np.round(values))
        return cls(name, tuple(values.tolist()))


@dataclass(frozen=True)
class Setting:
    """What every point shares: model, base parameters, times (s), section."""

    model: str
    n_balls: int | None
    values: dict[str, float]
    transient: float
    samples: int
    section: str = "shaft"
    dt: float = 1e-5
    lyapunov: bool = True

    def at(self, **coords: float) -> tuple[int | None, dict[str, float]]:
        """(n_balls, parameter values) at a grid point."""
        n_balls, values = self.n_balls, dict(self.values)
        for name, value in coords.items():
            if name == "n_balls":
                n_balls = round(value)
            else:
                values[name] = value
        return n_balls, values


def _record(setting: Setting, n_balls: int | None, values: dict[str, float],
            initial_state=None) -> xr.Dataset:
    """Simulate transient + ``samples`` section periods."""
    model = load_model(setting.model)
    freqs = model.frequencies(model.check_n_balls(n_balls), model.parameters(values))
    section_hz = {"shaft": freqs.shaft_hz, "cage": freqs.cage_hz, "vc": freqs.vc_hz}[
        setting.section]
    if not section_hz > 0:
        raise InputError(f"section: the {setting.section} frequency is zero here")
    duration = setting.transient + (setting.samples + 0.5) / section_hz
    return simulate(model, n_balls, duration=duration, transient=setting.transient,
                    dt=setting.dt, initial_state=initial_state, **values)


def diagram_point(setting: Setting, n_balls, values, initial_state=None) -> dict:
    """Poincaré samples (x, y, vx, vy), end state and amplitudes at one grid value."""
    ds = _record(setting, n_balls, values, initial_state)
    pts = poincare_section(ds, setting.section)
    k = setting.samples
    out = {v: pts[v].values[:k] for v in ("x", "y", "vx", "vy")}
    out["final"] = state_at(ds, -1)
    out["amplitude_x"] = float(np.ptp(ds.x.values)) / 2
    out["amplitude_y"] = float(np.ptp(ds.y.values)) / 2
    return out


def chart_point(setting: Setting, n_balls, values) -> dict:
    """Class, period, largest Lyapunov exponent (1/s) and amplitudes (m) at one point."""
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
            "amplitude_x": float(np.ptp(ds.x.values)) / 2,
            "amplitude_y": float(np.ptp(ds.y.values)) / 2}


# --- bifurcation diagrams -----------------------------------------------------------------

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
    """Compute the missing points of one chain in order, storing each as it finishes."""
    store = PointStore(chain.output, chain.definition)
    done, state, computed = store.done(), None, 0
    for i in chain.order():
        key = f"{chain.direction}-{i:05d}"
        if key in done:
            state = tuple(store.load(key)["final"]) if chain.follow else None
            continue
        n_balls, values = chain.setting.at(**{chain.axis.name: chain.axis.values[i]})
        out = diagram_point(chain.setting, n_balls, values, state if chain.follow else None)
        store.save(key, out)
        state = tuple(out["final"])
        computed += 1
    return computed


def _point_task(args: tuple) -> tuple[str, dict]:
    """A diagram point without state following (parallel over the grid)."""
    chain, i = args
    n_balls, values = chain.setting.at(**{chain.axis.name: chain.axis.values[i]})
    return f"{chain.direction}-{i:05d}", diagram_point(chain.setting, n_balls, values)


def bifurcation_diagram(setting: Setting, axis: Axis, output: str | Path, *,
                        direction: str = "up", follow: bool = True,
                        executor: Executor | None = None,
                        progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """Brute-force orbit diagram over ``axis``; writes and returns the netCDF Dataset."""
    if direction not in ("up", "down", "both"):
        raise InputError(f"direction: must be up, down or both, got {direction!r}")
    directions = ["up", "down"] if direction == "both" else [direction]
    definition = {"kind": "diagram", "setting": asdict(setting), "axis": asdict(axis),
                  "directions": directions, "follow": follow}
    store = PointStore(output, definition)
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
    return ds


def _assemble_diagram(store, setting, axis, directions, follow) -> xr.Dataset:
    n = len(axis.values)
    arrays = {v: np.full((len(directions), n, setting.samples), np.nan)
              for v in ("x", "y", "vx", "vy")}
    amp = {v: np.full((len(directions), n), np.nan) for v in ("amplitude_x", "amplitude_y")}
    for d, direction in enumerate(directions):
        for i in range(n):
            point = store.load(f"{direction}-{i:05d}")
            for v in arrays:
                arrays[v][d, i, :len(point[v])] = point[v]
            for v in amp:
                amp[v][d, i] = point[v]
    units = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}
    data = {v: (("direction", axis.name, "k"), arrays[v],
                {"units": units[v], "long_name": f"{v} on the {setting.section} section"})
            for v in arrays}
    data.update({v: (("direction", axis.name), amp[v], {"units": "m"}) for v in amp})
    attrs = _attrs(setting, "diagram")
    attrs.update(param=axis.name, follow=int(follow))
    return xr.Dataset(data, coords={"direction": directions, axis.name: list(axis.values),
                                    "k": np.arange(setting.samples)}, attrs=attrs)


# --- stability charts ---------------------------------------------------------------------

def _chart_task(args: tuple) -> tuple[str, dict]:
    setting, xname, xval, yname, yval, key = args
    n_balls, values = setting.at(**{xname: xval, yname: yval})
    return key, chart_point(setting, n_balls, values)


def stability_chart(setting: Setting, x: Axis, y: Axis, output: str | Path, *,
                    executor: Executor | None = None,
                    progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """Classify every point of the grid y × x; writes and returns the netCDF Dataset."""
    definition = {"kind": "chart", "setting": asdict(setting), "x": asdict(x), "y": asdict(y)}
    store = PointStore(output, definition)
    done = store.done()
    tasks = [(setting, x.name, xv, y.name, yv, f"{iy:04d}-{ix:04d}")
             for iy, yv in enumerate(y.values) for ix, xv in enumerate(x.values)
             if f"{iy:04d}-{ix:04d}" not in done]
    _run_with_progress(executor or SerialExecutor(), _chart_task, tasks, store,
                       len(x.values) * len(y.values), progress,
                       lambda task, result: store.save(*result))
    ds = _assemble_chart(store, setting, x, y)
    save_dataset(ds, output)
    store.remove()
    return ds


def _assemble_chart(store, setting, x: Axis, y: Axis) -> xr.Dataset:
    shape = (len(y.values), len(x.values))
    fields = ("nature_code", "period", "lyapunov", "ci95", "amplitude_x", "amplitude_y",
              "graph_ratio")
    arrays = {f: np.full(shape, np.nan) for f in fields}
    nature = np.empty(shape, dtype=object)
    for iy in range(shape[0]):
        for ix in range(shape[1]):
            point = store.load(f"{iy:04d}-{ix:04d}")
            for f in fields:
                arrays[f][iy, ix] = point[f]
            nature[iy, ix] = str(point["nature"])
    dims = (y.name, x.name)
    units = {"lyapunov": "1/s", "ci95": "1/s", "amplitude_x": "m", "amplitude_y": "m"}
    data = {f: (dims, arrays[f], {"units": units[f]} if f in units else {}) for f in fields}
    data["nature_code"] = (dims, arrays["nature_code"].astype(int),
                           {"legend": ", ".join(f"{v}: {k}" for k, v in NATURE_CODES.items())})
    data["period"] = (dims, arrays["period"].astype(int))
    data["nature"] = (dims, nature)
    attrs = _attrs(setting, "chart")
    attrs.update(x=x.name, y=y.name)
    return xr.Dataset(data, coords={y.name: list(y.values), x.name: list(x.values)},
                      attrs=attrs)


def _attrs(setting: Setting, kind: str) -> dict:
    model = load_model(setting.model)
    n = model.check_n_balls(setting.n_balls)
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


def chart_table(ds: xr.Dataset) -> str:
    """Markdown table of a chart with one column value: the shape of the paper's Table 2."""
    xname, yname = ds.attrs["x"], ds.attrs["y"]
    lines = [f"| {yname} | {xname} | nature | largest Lyapunov exponent (1/s) | "
             "amplitude x (µm) | amplitude y (µm) |", "|---|---|---|---|---|---|"]
    for yv in ds[yname].values:
        for xv in ds[xname].values:
            p = ds.sel({yname: yv, xname: xv})
            lam = float(p.lyapunov)
            lam_text = "–" if math.isnan(lam) else f"{lam:.3g} ± {float(p.ci95):.2g}"
            lines.append(f"| {yv:g} | {xv:g} | {p.nature.item()} | {lam_text} | "
                         f"{float(p.amplitude_x) * 1e6:.3g} | {float(p.amplitude_y) * 1e6:.3g} |")
    return "\n".join(lines) + "\n"
