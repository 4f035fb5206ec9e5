"""Stability charts: a 2-D grid (``analysis.sweeps.grid``), each point classified
(``analysis.stability.classify``) as periodic-n, quasi-periodic or chaotic, with its largest
Lyapunov exponent and amplitude.

Each point is computed in one pass (``analysis.sweeps.points``: states and tangent together,
neighbouring points of the same balls as members of one call of the member kernels,
``analysis.integrate.kernels``, on every core or the GPU: ``device``);
``chart_point_two_pass`` is the former two-pass point, kept for comparison. A chart runs
through one executor (``analysis.sweeps.executors``) and stores each finished group of
points at once as one block (``analysis.sweeps.store``: one ``block-<first key>`` entry
holding the group's keys and each field stacked, written by the calling process as groups
arrive; a block is whole or absent): re-running an interrupted command computes only the
missing points. Entries of one point (charts stored before blocks) are read as well.

A chart is a study plan (``analysis.integrate.study``): ``plan_chart`` runs its every check
once (the grid, the box of its initial states, the device judged once) and returns a
``ChartPlan``, which the one runner (``analysis.sweeps.runner.run_study``) runs;
``stability_chart`` is the two in one call.

A setting without a section classifies each point on its model's own section
(``classify.default_section``: vc for a balanced rotor in one bearing) and records
``samples`` shaft revolutions (``classify.GRID_RECORD_SECTION``); with a section, both are
that section's.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import SimulationError
from analysis.integrate.cost import CostEstimate
from analysis.integrate.kernels.cpu import cores
from analysis.integrate.kernels.placement import Placement
from analysis.integrate.study import Progress, Say
from analysis.model import System, as_system
from analysis.provenance import run_attrs, state_at
from analysis.stability.classify import (
    NATURE_CODES,
    default_section,
    failure_text,
    nature_code,
)
from analysis.sweeps.executors import Executor, run_with_progress
from analysis.sweeps.grid import (
    Axis,
    Setting,
    amplitude_fields,
    amplitudes,
    axis_bearing,
    check_grid,
    grid_cost,
    record,
)
from analysis.sweeps.multistability import Ics, point_attractors
from analysis.sweeps.points import chart_grid_points, chart_points, grid_device
from analysis.sweeps.runner import run_study
from analysis.sweeps.store import PointStore, stacked


def classified_section(setting: Setting, system: System) -> str:
    """The section ``system``'s point is classified on: the setting's, else the model's own
    (``default_section`` of the run's attrs)."""
    if setting.section is not None:
        return setting.section
    return default_section(run_attrs(system.model, system.structure, dict(system.parameters)))


def chart_point_two_pass(setting: Setting, system: System) -> dict:
    """Class, period, largest Lyapunov exponent (1/s) and amplitudes (m) at one point, in
    two passes (simulate and keep every state, then ``lyapunov`` from the record's first
    state): the former chart point, kept for comparison. The chart uses
    ``analysis.sweeps.points.chart_point`` (one pass)."""
    from analysis.stability.classify import classify
    from analysis.stability.lyapunov import lyapunov

    ds = record(setting, system)
    exponents = None
    if setting.lyapunov:
        start = tuple(state_at(ds, 0))
        exponents = lyapunov(as_system(system, None, start),
                             duration=float(ds.t[-1] - ds.t[0]), transient=0.0,
                             dt=setting.step(), n_exponents=1)
    result = classify(ds, setting.section, exponents)
    lam = float(exponents.exponents[0]) if exponents is not None else np.nan
    ci = float(exponents.ci95[0]) if exponents is not None else np.nan
    return {"nature": result.nature, "nature_code": nature_code(result.nature),
            "period": result.period or 0, "lyapunov": lam, "ci95": ci,
            "graph_ratio": result.graph_ratio or np.nan, **amplitudes(ds)}


def _failed_point(setting: Setting, exc: SimulationError) -> dict:
    """A point whose run blew up: recorded as its class, and the chart goes on."""
    return {"nature": failure_text(exc), "nature_code": NATURE_CODES["failed"],
            "period": 0, "lyapunov": np.nan, "ci95": np.nan, "graph_ratio": np.nan,
            **dict.fromkeys(amplitude_fields(setting.loaded()), np.nan)}


def _task_system(task: tuple) -> System:
    setting, xname, xval, yname, yval, *_ = task
    return setting.system_at(**{xname: xval, yname: yval})


GROUP_POINTS = {"cpu": 32, "gpu": 1 << 15}
"""Neighbouring points of the same balls per call of the member kernels (and per store
write): on the CPU enough to keep every core busy while an interrupted chart loses little;
on a GPU enough to fill it."""


def _chart_group_task(group: list[tuple], device: str = "cpu",
                      threads: int | None = None) -> tuple[list[str], dict[str, np.ndarray]]:
    """Chart points of one model and balls together (``points.chart_grid_points``: planned
    as arrays, one call of the member kernels on ``device``, ``threads`` CPU threads), as
    the group's keys and its columns (each field an array over the points: what
    ``PointStore.save_columns`` stores; a failed point's row ``_failed_point``'s); with
    ``Ics`` (a task's last item) also each point's attractors among K initial states (a
    System per point: ``points.chart_points``)."""
    setting, xname, _, yname, _, _, ics = group[0]
    keys = [task[-2] for task in group]
    if ics is None:  # no System per point: the group's points as arrays
        columns, failed = chart_grid_points(setting, (xname, yname),
                                            [(task[2], task[4]) for task in group], device,
                                            threads, columns=True)
        if failed:  # rows again, a failed point's its own (the columns' widths its text's)
            columns = stacked([_failed_point(setting, failed[j]) if j in failed else
                               {f: column[j] for f, column in columns.items()}
                               for j in range(len(group))])
        return keys, columns
    systems = [_task_system(task) for task in group]
    rows = [point if isinstance(point, dict) else _failed_point(setting, point)
            for point in chart_points(setting, systems, device, threads)]
    for row, system, key in zip(rows, systems, keys, strict=True):
        row.update(_ics_point(setting, ics, system, key))
    return keys, stacked(rows)


def _ics_point(setting: Setting, ics: Ics, system: System, key: str) -> dict:
    """The point's attractors among ``ics``' initial states (``multistability``); a point
    whose mapping fails records no attractor and the chart goes on."""
    iy, ix = (int(k) for k in key.split("-"))
    try:
        return point_attractors(ics, system, classified_section(setting, system),
                                iy * 10_000 + ix, setting.dt)
    except SimulationError:
        return {"n_attractors": 0, "attractor_codes": np.full(ics.count, -1),
                "diverged_share": np.nan, "multistable": 0}


def _chart_groups(setting: Setting, tasks: list[tuple],
                  size: int = GROUP_POINTS["cpu"]) -> list[list[tuple]]:
    """Neighbouring pending points of the same balls in groups of ``size`` (one group per
    point without a tangent: the kernels run the tangent's points)."""
    if not setting.lyapunov:
        return [[task] for task in tasks]
    groups: list[list[tuple]] = []
    group: list[tuple] = []
    previous = balls = last = None
    known: dict[tuple, tuple] = {}  # the balls of a point: built once per ball axis value
    by_x = bool(tasks) and axis_bearing(tasks[0][1]) is not None  # one x axis per chart
    for task in tasks:
        key = (task[4], task[2] if by_x else None)
        if key != last:  # the balls looked up where the key changes
            if key not in known:
                known[key] = _task_system(task).structure
            balls, last = known[key], key
        if group and (balls is previous or balls == previous) and len(group) < size:
            group.append(task)
        else:
            group = [task]
            groups.append(group)
        previous = balls
    return groups


def chart_device(setting: Setting, x: Axis, y: Axis, device: str | Placement) -> Placement:
    """Where the chart's points with λ1 run (``device``: ``cpu``, ``gpu`` or ``auto``),
    judged before any point, store or estimate (``points.grid_device``): with λ1 the
    tangent kernel of every balls of the grid is built first, and one that cannot be built
    on ``cpu`` or ``gpu`` is one ``InputError`` naming the model and the reason; ``auto``
    keeps the points-one-by-one fallback of the cores (``points.kernel_points``)."""
    return grid_device(setting, (x, y), device, len(x.values) * len(y.values), tangent=True,
                       kernels=setting.lyapunov, fallback=True)


@dataclass(frozen=True)
class ChartPlan:
    """A stability chart, checked whole by ``plan_chart``: a ``StudyPlan``
    (``analysis.integrate.study``) run by ``analysis.sweeps.runner.run_study``.

    ``setting``, ``x``, ``y``, ``ics`` as ``stability_chart`` takes them, checked;
    ``placement``: where its points run (judged once); ``definition``: its store's key."""

    setting: Setting
    x: Axis
    y: Axis
    output: Path
    placement: Placement
    definition: dict = field(compare=False)
    ics: Ics | None = None

    kind = "chart"
    unit = "points"

    @property
    def total(self) -> int:
        """The grid's points."""
        return len(self.x.values) * len(self.y.values)

    def cost(self, workers: int) -> CostEstimate:
        """The chart's cost on ``workers`` workers (``grid.grid_cost``: every initial state
        of ``ics`` a member of its point)."""
        return grid_cost(self.setting, self.x, self.y, workers=workers,
                         members_per_point=self.ics.count if self.ics is not None else 1)

    def run(self, store: PointStore, executor: Executor, progress: Progress | None,
            say: Say | None = None) -> xr.Dataset:
        """Classify the points ``store`` lacks, in groups (``GROUP_POINTS``) on
        ``executor``, each group stored as one block as it arrives; the chart of every
        point."""
        setting, x, y, ics = self.setting, self.x, self.y, self.ics
        done = store.keys()
        stored = [len(done)]

        def keep(group: list[tuple], block: tuple[list[str], dict[str, np.ndarray]]) -> None:
            store.save_columns(*block)
            stored[0] += len(block[0])

        columns = [f"-{ix:04d}" for ix in range(len(x.values))]
        tasks = [(setting, x.name, xv, y.name, yv, key, ics)
                 for iy, yv in enumerate(y.values) for xv, column in zip(x.values, columns,
                                                                          strict=True)
                 if (key := f"{iy:04d}{column}") not in done]
        threads = max(1, cores() // getattr(executor, "workers", 1))  # a pool shares them
        with _young_heap():
            run_with_progress(executor, partial(_chart_group_task, device=self.placement,
                                                threads=threads),
                              _chart_groups(setting, tasks, GROUP_POINTS[self.placement]),
                              lambda: stored[0], self.total, progress, keep)
            return _assemble_chart(store, setting, x, y, ics)


@contextmanager
def _young_heap():
    """The objects alive before the chart's points left out of the garbage collector's
    full collections while they run (``gc.freeze``, undone on leaving, however left): a
    chart's groups allocate few long-lived containers, and a full collection would walk
    the whole heap of the libraries loaded (0.003–0.006 CPU ms a point of an 8000-point
    chart, measured with and without). Nothing is done where objects are frozen already
    (the caller's) or the collector is off."""
    if gc.get_freeze_count() or not gc.isenabled():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def plan_chart(setting: Setting, x: Axis, y: Axis, output: str | Path, *,
               ics: Ics | None = None, device: str | Placement = "cpu") -> ChartPlan:
    """The ``ChartPlan`` of the grid y × x written to ``output``, every input checked once
    before any point, store or estimate: the grid (``grid.check_grid``), the box of ``ics``
    within the model's bounds (``Ics.check``), then the device and its kernels
    (``chart_device``: the ``Placement`` the points take). ``InputError`` naming its field
    otherwise."""
    check_grid(setting, x, y)
    if ics is not None:  # its box fits the model, before any point runs
        ics.check(setting.system_at(**{x.name: x.values[0], y.name: y.values[0]}))
    placement = chart_device(setting, x, y, device)
    definition = {"kind": "chart", "setting": asdict(setting), "x": asdict(x), "y": asdict(y),
                  "structure": list(setting.loaded().structure(setting.n_balls))}
    if ics is not None:
        definition["ics"] = {"count": ics.count, "seed": ics.seed,
                             "box": ics.box.text if ics.box else None,
                             "options": asdict(ics.options)}
    return ChartPlan(setting, x, y, Path(output), placement, definition, ics)


def stability_chart(setting: Setting, x: Axis, y: Axis, output: str | Path, *,
                    executor: Executor | None = None,
                    progress: Callable[[int, int], None] | None = None,
                    on_damaged: Callable[[str], None] | None = None,
                    ics: Ics | None = None, device: str | Placement = "cpu") -> xr.Dataset:
    """Classify every point of the grid y × x; writes and returns the netCDF Dataset
    (``run_study(plan_chart(…))``).

    Resumable as ``analysis.sweeps.diagram.bifurcation_diagram``; a point whose run fails is
    classed ``failed: …`` (``nature_code`` 0) and the chart goes on. ``ics``: also map K
    initial states per point (``multistability``: ``n_attractors``, ``multistable``,
    ``attractor_codes``, ``diverged_share``). ``device``: where the points with λ1 run
    (``cpu``, ``gpu`` or ``auto``: ``chart_device``, checked before any point)."""
    return run_study(plan_chart(setting, x, y, output, ics=ics, device=device), executor,
                     progress=progress, on_damaged=on_damaged)


def _assemble_chart(store: PointStore, setting: Setting, x: Axis, y: Axis,
                    ics: Ics | None = None) -> xr.Dataset:
    shape = (len(y.values), len(x.values))
    keys, stored = store.columns()  # every field a column over the stored points
    at = dict(zip(keys.tolist(), range(len(keys)), strict=True))  # a key twice: its last
    order = np.array([at[f"{iy:04d}-{ix:04d}"] for iy in range(shape[0])
                      for ix in range(shape[1])], dtype=np.intp)  # row-major: the grid's
    extra = ("n_attractors", "multistable", "diverged_share") if ics is not None else ()
    fields = ("nature_code", "period", "lyapunov", "ci95",
              *(f for f in stored if f.startswith("amplitude_")), "graph_ratio", *extra)
    arrays = {f: np.asarray(stored[f][order], dtype=float).reshape(shape) for f in fields}
    nature = stored["nature"][order].astype(object).reshape(shape)
    codes = np.full((*shape, ics.count if ics is not None else 0), -1, dtype=np.int64)
    if ics is not None:
        codes[...] = stored["attractor_codes"][order].reshape(codes.shape)
    dims = (y.name, x.name)
    state_units = setting.loaded().state_units
    units = {"lyapunov": "1/s", "ci95": "1/s",
             **{f: state_units.get(f[len("amplitude_"):], "m") for f in fields
                if f.startswith("amplitude_")}}
    data = {f: (dims, arrays[f], {"units": units[f]} if f in units else {}) for f in fields}
    data["nature_code"] = (dims, arrays["nature_code"].astype(int),
                           {"legend": ", ".join(f"{v}: {k}" for k, v in NATURE_CODES.items())})
    data["period"] = (dims, arrays["period"].astype(int))
    data["nature"] = (dims, nature)
    if ics is not None:
        data["n_attractors"] = (dims, arrays["n_attractors"].astype(int),
                                {"long_name": f"attractors met by {ics.count} initial states"})
        data["multistable"] = (dims, arrays["multistable"].astype(int),
                               {"long_name": "two or more attractors (1) or not (0)"})
        data["attractor_codes"] = ((*dims, "attractor_slot"), codes,
                                   {"long_name": "nature_code of each attractor (-1: none)"})
    section = classified_section(setting, setting.system_at(**{x.name: x.values[0],
                                                                y.name: y.values[0]}))
    attrs = setting.attrs("chart", section, (x, y))
    attrs.update(x=x.name, y=y.name)
    if ics is not None:
        attrs.update(ics=ics.count, ics_seed=ics.seed,
                     ics_box=ics.box.text if ics.box else "positions within ± the clearance")
    return xr.Dataset(data, coords={y.name: y.coord(), x.name: x.coord()}, attrs=attrs)


def _axis_heading(name: str) -> str:
    bearing = axis_bearing(name)
    return f"{name} (balls in bearing {bearing})" if bearing else name


def chart_table(ds: xr.Dataset) -> str:
    """Markdown table of a chart: the shape of the paper's Table 2 (a structure axis says
    its bearing: ``n_balls[left] (balls in bearing left)``; amplitudes of the first body's
    displacements in µm, or in their own unit when not metres)."""
    xname, yname = ds.attrs["x"], ds.attrs["y"]
    amplitude_names = [v for v in ds.data_vars if str(v).startswith("amplitude_")]

    def heading(v: str) -> str:
        unit = ds[v].attrs.get("units", "m")
        return f"amplitude {v[len('amplitude_'):]} ({'µm' if unit == 'm' else unit})"

    def value(p, v: str) -> str:
        scale = 1e6 if ds[v].attrs.get("units", "m") == "m" else 1.0
        return f"{float(p[v]) * scale:.3g}"

    lines = [f"| {_axis_heading(yname)} | {_axis_heading(xname)} | nature | "
             "largest Lyapunov exponent (1/s) | "
             + " | ".join(map(heading, amplitude_names)) + " |",
             "|---|---|---|---|" + "---|" * len(amplitude_names)]
    for yv in ds[yname].values:
        for xv in ds[xname].values:
            p = ds.sel({yname: yv, xname: xv})
            lam = float(p.lyapunov)
            lam_text = "–" if math.isnan(lam) else f"{lam:.3g} ± {float(p.ci95):.2g}"
            lines.append(f"| {yv:g} | {xv:g} | {p.nature.item()} | {lam_text} | "
                         + " | ".join(value(p, v) for v in amplitude_names) + " |")
    return "\n".join(lines) + "\n"
