"""An uncertainty study: at each value of a swept parameter (or number of balls), every
quasi-Monte Carlo draw of the uncertain parameters run as one member of the member kernels,
classified with the tangent's λ1 as calibrate classifies (``analysis.inference.simulate``),
its regime counted and its amplitude kept.

**The draws** are a Saltelli design (``sampling.draw``): N base points give N (P + 2) rows,
every row one member at every swept value (the same draws at each value). The regime
probabilities and their Wilson intervals (``probabilities``) are over the 2N independent
rows (A and B); the amplitude's distribution is over them too; the Sobol' indices
(``sobol.indices``) of the chaotic indicator and of the amplitude use every row.

**A member** is run as calibrate runs one: fixed-step RK4 with a step that divides the
shaft period (``RunSettings.steps``), ``transient_revolutions`` dropped, ``revolutions``
recorded at ``samples_per_revolution`` samples each with one tangent vector renormalised
at each sample (``simulate.run_engine``); the record's shaft Poincaré points are classified
by ``stability.classify.classify_section`` with λ1 and its 95 % interval; a member that
blows up is ``diverged``. Its amplitude is half the peak-to-peak of each displacement
(``provenance.displacement_names``) over the record, as a chart point's is.

**Resumable.** Each block of members at one value is stored as it finishes in
``<output>.parts`` (``analysis.sweeps.store``); run again with the same definition, only
the missing blocks are computed. Blocks run on any executor of ``analysis.sweeps.executors``
(in this process, processes, Dask). A study written to a file is a study plan
(``UncertaintyPlan``, made by ``plan_uncertainty``: ``analysis.integrate.study``), run by
the one runner (``analysis.sweeps.runner.run_study``), which opens its store and writes its
file.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.inference.simulate import (
    RunSettings,
    check_corner_step,
    classify_member,
    member_record,
    run_engine,
)
from analysis.integrate.kernels.placement import CPU, Placement
from analysis.model import BallCounts, Model, System, as_system, load_model
from analysis.provenance import displacement_names
from analysis.uncertainty.distributions import Dist, check_dists
from analysis.uncertainty.probabilities import probabilities, regime, regime_order
from analysis.uncertainty.sampling import Design, check_samples, draw
from analysis.uncertainty.sobol import indices

if TYPE_CHECKING:
    from analysis.inference.abc import CalibrationCost
    from analysis.integrate.study import Executor, Progress, Say, Store

BLOCK = 256
"""Members per executor task on the CPU (a task is one kernel call at one value)."""
MAX_VALUES = 10_000
"""Swept values at most."""


@dataclass(frozen=True)
class Study:
    """A checked study, before any work."""

    model: Model
    dists: tuple[Dist, ...]
    sets: dict[str, float]
    axis: str
    """The swept name: a parameter, or ``n_balls``."""
    values: tuple[float, ...]
    design: Design
    seed: int
    device: str = "cpu"
    settings: RunSettings = field(default_factory=RunSettings)
    block: int = BLOCK
    balls: int | None = None
    """The balls of a parameter sweep (None: the model's own)."""
    placement: Placement | None = None
    """Where every kernel call runs (``check_kernels``: judged once by ``prepare``); None:
    each call places ``device`` itself."""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(d.name for d in self.dists)

    @property
    def runs(self) -> int:
        """Member runs in all: every row of the design at every value."""
        return self.design.runs * len(self.values)

    def system(self, value: float) -> System:
        """The System at one swept value (the spec's initial state, ``sets`` applied; each
        draw replaces its parameters in it)."""
        if self.axis == "n_balls":
            return as_system(self.model, int(value), **self.sets)
        return as_system(self.model, self.balls, **{**self.sets, self.axis: float(value)})

    def blocks(self) -> list[tuple[int, int]]:
        """(value index, first row) of every task."""
        return [(i, b) for i in range(len(self.values))
                for b in range(0, self.design.runs, self.block)]

    def definition(self) -> dict[str, Any]:
        """What a stored (resumable) study must agree on."""
        return {"analysis": "uncertainty", "model": self.model.name,
                "spec_sha256": self.model.spec_sha256,
                "dists": [d.text() for d in self.dists], "sets": dict(self.sets),
                "axis": self.axis, "values": list(self.values),
                "samples": self.design.samples, "seed": self.seed, "block": self.block,
                "balls": self.balls, "settings": dataclasses.asdict(self.settings)}


def prepare(model: str | Model, dists: Sequence[Dist | str], *,
            sets: dict[str, float] | None = None,
            param: tuple[str, Sequence[float]] | None = None,
            n_balls: Sequence[int] | None = None, samples: int = 64, seed: int = 0,
            device: str = "cpu", settings: RunSettings | None = None,
            block: int | None = None) -> Study:
    """Check every input before any work (``InputError``, one line naming the field): the
    model, the distributions against it (``distributions.check_dists``), ``sets`` (fixed
    values, ``--set``), the swept ``param`` (NAME, values) or ``n_balls`` (exactly one of
    them), ``samples`` >= 1, the run settings, and the RK4 step at both ends of every
    distribution at the first and last swept value; then the device, judged once, and the
    member kernels built on it (``check_kernels``)."""

    mdl = load_model(model) if not isinstance(model, Model) else model
    sets = {str(k): float(v) for k, v in (sets or {}).items()}
    balls = None
    if param is not None and n_balls is not None:
        if len(n_balls) != 1:
            raise InputError("n_balls: with param, give one count (the balls of the "
                             f"sweep), got {len(n_balls)}", field="n_balls")
        balls, n_balls = int(n_balls[0]), None
    if param is None and n_balls is None:
        raise InputError("param/n_balls: give one of them (param = (NAME, values), or "
                         "n_balls = counts)")
    axis, values = ("n_balls", tuple(int(n) for n in n_balls)) if param is None else \
        (str(param[0]), tuple(float(v) for v in param[1]))
    if not 1 <= len(values) <= MAX_VALUES:
        name = "n_balls" if param is None else "param"
        raise InputError(f"{name}: give 1 to {MAX_VALUES} values, got {len(values)}",
                         field=name)
    if axis in sets:
        raise InputError(f"sets {axis}: also the swept parameter", field="sets")
    found = check_dists(dists, mdl, sets, axis)
    check_samples(samples)
    if device not in ("cpu", "gpu", "auto"):
        raise InputError(f"device: must be cpu, gpu or auto, got {device!r}", field="device")
    settings = settings or RunSettings()
    settings.check()
    design = draw(found, samples, seed)
    if block is None:
        block = BLOCK if device == "cpu" else design.runs
    check_count("block", block, 1)
    study = Study(mdl, found, sets, axis, values, design, int(seed), device, settings, block,
                  balls)
    check_size(study)
    ends = [dict(zip(study.names, row, strict=True))
            for row in (design.values.min(axis=0), design.values.max(axis=0))]
    for value in dict.fromkeys((values[0], values[-1])):
        base = study.system(value)
        for end in ends:
            check_corner_step(base, end, settings, "dist", f"{axis} = {value:g}")
    return dataclasses.replace(study, placement=check_kernels(study))


def check_kernels(study: Study) -> Placement:
    """The study's device judged once (``placement.place``: the name, its availability,
    ``auto``'s choice for a kernel call of ``block`` draws of the first value's RK4 steps)
    and the member kernels (tangent variant) of every swept value's balls built, or loaded
    and self-tested, on it: a kernel or a cache that cannot be built is one ``InputError``
    before any work. Every kernel call of the study runs on the ``Placement`` returned."""
    from analysis.integrate.kernels.placement import place

    settings = study.settings
    _, every = settings.steps(study.system(study.values[0]))
    steps = settings.samples_per_revolution * every * (settings.transient_revolutions +
                                                       settings.revolutions)
    values = study.values if study.axis == "n_balls" else study.values[:1]
    return place(study.device, min(study.block, study.design.runs),
                 lambda: [study.system(v) for v in values], "tangent", steps)


def check_size(study: Study) -> None:
    """Refuse, before any work, a study estimated at more CPU time than calibrate allows
    (``inference.abc.MAX_CORE_HOURS`` at ``CPU_RATE`` member steps per second per core)."""
    from analysis.inference.abc import CPU_RATE, MAX_CORE_HOURS

    settings = study.settings
    _, every = settings.steps(study.system(study.values[0]))
    steps = settings.samples_per_revolution * every * (settings.transient_revolutions +
                                                       2 * settings.revolutions)
    hours = study.runs * steps / CPU_RATE / 3600
    if hours > MAX_CORE_HOURS:
        raise InputError(f"samples: {study.runs:,} runs ({study.design.runs} members x "
                         f"{len(study.values)} values) are estimated at {hours:.3g} "
                         f"core-hours, above {MAX_CORE_HOURS:g}; give fewer samples or values",
                         field="samples")


def classify_draw(system: System, samples: np.ndarray, lam: float, ci: float, h: float,
                  every: int, start_step: int, diverged_at: int) -> tuple[str, dict]:
    """(class, amplitudes by displacement in m) of one member's record, classified as
    calibrate classifies its members (``inference.simulate.classify_member``); ``diverged``
    (amplitudes NaN) when it blew up."""
    run = member_record(system, samples, h, every, start_step)
    names = displacement_names(run.attrs)
    if diverged_at >= 0 or not math.isfinite(lam) or not np.all(np.isfinite(samples)):
        return "diverged", {v: math.nan for v in names}
    nature, ptp = classify_member(run, samples, lam, ci)
    return nature, {v: ptp[v] / 2 for v in names}


def evaluate_members(system: System, names: Sequence[str], thetas: np.ndarray,
                     settings: RunSettings, device: str | Placement = CPU,
                     progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Every draw ``thetas`` (M × P, SI units) at ``system``: one kernel call per distinct
    RK4 step (one in all unless the speed is drawn), on ``device`` (the study's placement,
    or a name placed at each call). Returns ``nature`` (M classes),
    ``lambda1``, ``ci95`` (1/s) and ``amplitude_<v>`` (m) arrays."""
    members = [system.replace(**dict(zip(names, map(float, theta), strict=True)))
               for theta in thetas]
    steps = [settings.steps(m) for m in members]
    per = settings.samples_per_revolution
    out: dict[str, Any] = {"nature": [None] * len(members),
                           "lambda1": np.full(len(members), np.nan),
                           "ci95": np.full(len(members), np.nan)}
    done = 0
    for key in dict.fromkeys(steps):
        idx = [i for i, s in enumerate(steps) if s == key]
        h, every = key
        part = None if progress is None else \
            (lambda k, _, before=done: progress(before + k, len(members)))
        result = run_engine(system, np.array([members[i].state for i in idx]),
                            np.array([members[i].p for i in idx]), h, every,
                            settings.transient_revolutions * per, settings.revolutions * per,
                            per, device, part)
        start = settings.transient_revolutions * per * every
        for j, i in enumerate(idx):
            nature, amp = classify_draw(members[i], result.samples[j],
                                        float(result.lambda1[j]), float(result.ci95[j]), h,
                                        every, start, int(result.diverged_at[j]))
            out["nature"][i] = nature
            out["lambda1"][i] = result.lambda1[j]
            out["ci95"][i] = result.ci95[j]
            for v, a in amp.items():
                out.setdefault(f"amplitude_{v}", np.full(len(members), np.nan))[i] = a
        done += len(idx)
    out["nature"] = np.array(out["nature"], dtype=str)
    return out


def _task(item: tuple) -> dict[str, Any]:
    """A picklable executor task: (key, model reference, balls, parameters, names, thetas,
    settings, device)."""
    _, model, balls, values, names, thetas, settings, device = item
    system = as_system(load_model(model), balls, **values)
    return evaluate_members(system, names, thetas, settings, device)


def _balls(system: System) -> BallCounts:
    counts = system.structure
    if len(system.model.bearing_names) <= 1:
        return int(counts[0]) if counts else None
    return dict(zip(system.model.bearing_names, counts, strict=True))


def run(study: Study, *, executor=None, store=None,
        progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """Run a prepared study (``executor``: an ``analysis.sweeps.executors`` executor, None:
    in this process; ``store``: a ``PointStore`` whose stored blocks are reused and to which
    each finished block is saved); ``progress(done, total)`` counts member runs. Returns
    the result dataset (``result_dataset``)."""
    from analysis.inference.abc import model_reference
    from analysis.sweeps.executors import SerialExecutor, run_with_progress

    start = time.perf_counter()
    ref = model_reference(study.model)
    rows = study.design.values
    found: dict[tuple[int, int], dict[str, Any]] = {}
    stored = store.done() if store is not None else set()
    for i, b in study.blocks():
        if f"v{i}-r{b}" in stored:
            found[(i, b)] = store.load(f"v{i}-r{b}")
    counted = [sum(len(v["nature"]) for v in found.values())]
    tasks = []
    for i, b in study.blocks():
        if (i, b) in found:
            continue
        system = study.system(study.values[i])
        tasks.append(((i, b), ref, _balls(system), {**study.sets} if study.axis == "n_balls"
                      else {**study.sets, study.axis: study.values[i]}, study.names,
                      rows[b:b + study.block], study.settings,
                      study.placement if study.placement is not None else study.device))

    def on_result(task, result):
        if store is not None:
            store.save(f"v{task[0][0]}-r{task[0][1]}", result)
        found[task[0]] = result
        counted[0] += len(result["nature"])

    if tasks:
        run_with_progress(executor or SerialExecutor(), _task, tasks, lambda: counted[0],
                          study.runs, progress, on_result)
    results = []
    for i in range(len(study.values)):
        parts = [found[(i, b)] for b in range(0, study.design.runs, study.block)]
        results.append({k: np.concatenate([np.asarray(p[k]) for p in parts])
                        for k in parts[0]})
    return result_dataset(study, results, time.perf_counter() - start)


def uncertainty(model: str | Model, dists: Sequence[Dist | str], *,
                sets: dict[str, float] | None = None,
                param: tuple[str, Sequence[float]] | None = None,
                n_balls: Sequence[int] | None = None, samples: int = 64, seed: int = 0,
                device: str = "cpu", settings: RunSettings | None = None,
                executor=None, store=None,
                progress: Callable[[int, int], None] | None = None) -> xr.Dataset:
    """The regime probabilities, amplitude distribution and Sobol' indices of ``model``
    at each swept value (``param`` = (NAME, values), or ``n_balls`` = counts) under the
    distributions ``dists`` (``Dist`` or ``NAME=uniform:LO:HI`` …; SI units), ``samples``
    base draws (N (P + 2) members per value), seeded; see ``prepare`` and ``run``.

    >>> ds = uncertainty("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6"],
    ...                  n_balls=[8], samples=4)  # doctest: +SKIP
    """
    study = prepare(model, dists, sets=sets, param=param, n_balls=n_balls, samples=samples,
                    seed=seed, device=device, settings=settings)
    return run(study, executor=executor, store=store, progress=progress)


# --- the result ----------------------------------------------------------------------------

def result_dataset(study: Study, results: list[dict[str, Any]],
                   wall_s: float = 0.0) -> xr.Dataset:
    """The study's result: per value and draw the regime (an index into ``regime``), λ1,
    its interval and amplitudes; per value and regime the probability and its Wilson
    interval (over the independent draws); per value and parameter the Sobol' indices of
    the chaotic indicator and of the largest displacement amplitude, with intervals."""
    design = study.design
    regimes = regime_order({regime(str(n)) for r in results for n in r["nature"]} |
                           {"chaotic"})
    code = {name: k for k, name in enumerate(regimes)}
    indep = design.independent
    amp_names = sorted(k for k in results[0] if k.startswith("amplitude_"))
    axis = study.axis
    coords = {axis: (axis, np.array(study.values,
                                    dtype=np.int64 if axis == "n_balls" else float)),
              "draw": np.arange(design.runs), "parameter": list(study.names),
              "regime": regimes, "bound": ["low", "high"]}
    data: dict[str, Any] = {
        "draws": (("draw", "parameter"), design.values),
        "independent": ("draw", np.isin(np.arange(design.runs), indep)),
        "regime_index": ((axis, "draw"), np.array([[code[regime(str(n))] for n in r["nature"]]
                                                   for r in results], dtype=np.int16)),
        "lambda1": ((axis, "draw"), np.array([r["lambda1"] for r in results])),
        "ci95": ((axis, "draw"), np.array([r["ci95"] for r in results])),
    }
    for name in amp_names:
        data[name] = ((axis, "draw"), np.array([r[name] for r in results]))
    prob = np.zeros((len(results), len(regimes)))
    bounds = np.zeros((len(results), len(regimes), 2))
    s_fields = {f"{out}_{kind}": np.full((len(results), len(study.names)), np.nan)
                for out in ("chaotic", "amplitude") for kind in ("S1", "ST")}
    s_bounds = {k: np.full((len(results), len(study.names), 2), np.nan) for k in s_fields}
    for i, r in enumerate(results):
        natures = [str(n) for n in np.asarray(r["nature"])[indep]]
        got = probabilities(natures, regimes)
        prob[i] = [got["probability"][g] for g in regimes]
        bounds[i] = [got["ci95"][g] for g in regimes]
        chaotic = np.array([regime(str(n)) == "chaotic" for n in r["nature"]], dtype=float)
        largest = np.max([r[name] for name in amp_names], axis=0) if amp_names else \
            np.full(design.runs, np.nan)
        for out, y in (("chaotic", chaotic), ("amplitude", largest)):
            found = indices(study.names, y, seed=study.seed)
            for j, name in enumerate(study.names):
                for kind in ("S1", "ST"):
                    s_fields[f"{out}_{kind}"][i, j] = found[name][kind]
                    s_bounds[f"{out}_{kind}"][i, j] = found[name][f"{kind}_ci95"]
    data["probability"] = ((axis, "regime"), prob)
    data["probability_ci95"] = ((axis, "regime", "bound"), bounds)
    for key, values in s_fields.items():
        data[f"sobol_{key}"] = ((axis, "parameter"), values)
        data[f"sobol_{key}_ci95"] = ((axis, "parameter", "bound"), s_bounds[key])
    ds = xr.Dataset(data, coords=coords)
    units = study.model.units
    for name in amp_names:
        ds[name].attrs.update(units="m", long_name=f"amplitude of {name[10:]} (half "
                              "peak-to-peak over the record)")
    ds["lambda1"].attrs["units"] = "1/s"
    ds["probability"].attrs["long_name"] = ("share of the independent draws in each regime "
                                            "(Wilson 95 % interval in probability_ci95)")
    notes = [d.note for d in study.dists if d.note]
    ds.attrs.update({
        "kind": "uncertainty", "model": study.model.name,
        "spec_sha256": study.model.spec_sha256, "axis": axis,
        "axis_units": "" if axis == "n_balls" else units.get(axis, ""),
        "dists": "; ".join(d.text() for d in study.dists),
        "sets": "; ".join(f"{k}={v:g}" for k, v in study.sets.items()),
        "samples": study.design.samples, "runs_per_value": design.runs,
        "independent_draws": len(indep), "seed": study.seed, "device": study.device,
        "transient_revolutions": study.settings.transient_revolutions,
        "revolutions": study.settings.revolutions,
        "samples_per_revolution": study.settings.samples_per_revolution,
        "dt": "" if study.settings.dt is None else study.settings.dt,
        "section": "shaft", "notes": "; ".join(notes), "wall_s": float(wall_s),
        "sobol": "SALib 1.x: Saltelli 2010 (S1), Jansen 1999 (ST); bootstrap 95 %",
    })
    return ds


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(float(x)) else None


def to_json(ds: xr.Dataset, output: str = "") -> dict[str, Any]:
    """The result as plain JSON values: ``values`` (per swept value: ``probability``,
    ``ci95`` per regime, ``amplitude`` per displacement: mean and 5/50/95 % quantiles over
    the independent draws, m), ``sobol`` (per output, per value, per parameter: S1, ST and
    their intervals; null where undefined) and ``provenance``."""
    axis = ds.attrs["axis"]
    indep = ds["independent"].values
    amp_names = [v for v in ds.data_vars if v.startswith("amplitude_")]
    values = []
    for i, v in enumerate(ds[axis].values):
        entry: dict[str, Any] = {axis: v.item()}
        entry["probability"] = {str(g): float(ds["probability"].values[i, k])
                                for k, g in enumerate(ds["regime"].values)}
        entry["ci95"] = {str(g): [float(x) for x in ds["probability_ci95"].values[i, k]]
                         for k, g in enumerate(ds["regime"].values)}
        amplitude = {}
        for name in amp_names:
            a = ds[name].values[i][indep]
            a = a[np.isfinite(a)]
            amplitude[name[10:]] = None if not len(a) else {
                "mean": float(a.mean()), "p05": float(np.quantile(a, 0.05)),
                "p50": float(np.quantile(a, 0.5)), "p95": float(np.quantile(a, 0.95)),
                "units": "m"}
        entry["amplitude"] = amplitude
        values.append(entry)
    sobol: dict[str, Any] = {}
    for out in ("chaotic", "amplitude"):
        sobol[out] = []
        for i, v in enumerate(ds[axis].values):
            per = {axis: v.item()}
            for j, name in enumerate(ds["parameter"].values):
                per[str(name)] = {
                    kind: _finite(ds[f"sobol_{out}_{kind}"].values[i, j])
                    for kind in ("S1", "ST")} | {
                    f"{kind}_ci95": [_finite(x) for x in
                                     ds[f"sobol_{out}_{kind}_ci95"].values[i, j]]
                    for kind in ("S1", "ST")}
            sobol[out].append(per)
    provenance = {k: (v.item() if hasattr(v, "item") else v) for k, v in ds.attrs.items()}
    if output:
        provenance["output"] = output
    return {"values": values, "sobol": sobol, "provenance": provenance}


# --- the cost, said first ------------------------------------------------------------------

def classify_seconds(study: Study) -> float:
    """Seconds the host takes to classify one member's record (the best of two, one
    record run alone at the first value and the distributions' centres)."""
    centre = {d.name: d.centre for d in study.dists}
    system = study.system(study.values[0]).replace(**centre)
    settings = study.settings
    h, every = settings.steps(system)
    per = settings.samples_per_revolution
    result = run_engine(system, system.state[None, :], system.p[None, :], h, every, 0,
                        settings.revolutions * per, per)
    best = math.inf
    for _ in range(2):  # the first also imports and warms what classifying needs
        begin = time.perf_counter()
        classify_draw(system, result.samples[0], float(result.lambda1[0]),
                      float(result.ci95[0]), h, every, 0, int(result.diverged_at[0]))
        best = min(best, time.perf_counter() - begin)
    return best


def study_cost(study: Study, workers: int | None = None, host_workers: int = 1):
    """The cost said before any work (``inference.abc.CalibrationCost``: the member
    kernels' RK4 steps timed on the member kernels by ``analysis.integrate.cost``, and the
    host's classification of each run, probed): every draw at every value, each taking its
    transient and its record, the record's steps with λ1's tangent counted by its measured
    cost (``simulate.run_engine``), at the first value's step; on a pool of
    ``host_workers`` processes (``workers`` None) its tasks (a value's block of draws)
    dealt to them (``cost.busiest_share``), each on cores / ``host_workers`` threads."""
    from analysis.inference.abc import CalibrationCost
    from analysis.integrate.cost import KERNELS, busiest_share, estimate_cost, process_seconds
    from analysis.integrate.kernels.cpu import cores

    centre = {d.name: d.centre for d in study.dists}
    system = study.system(study.values[0]).replace(**centre)
    settings = study.settings
    h, every = settings.steps(system)
    per = settings.samples_per_revolution * every
    record = per * settings.revolutions
    steps = per * settings.transient_revolutions + record
    balance = 1.0
    if workers is None and host_workers > 1:  # a pool: its tasks dealt to its workers
        sizes = [min(study.block, study.design.runs - b) for _, b in study.blocks()]
        workers = max(1, cores() // host_workers) * min(host_workers, len(sizes))
        balance = busiest_share(study.runs, study.block, host_workers, sizes)
    kernels = estimate_cost(system, study.runs, steps, dt=h, workers=workers or cores(),
                            what="draws x values", path=KERNELS, tangent_steps=record)
    host = classify_seconds(study)
    kernels = dataclasses.replace(kernels, spent=process_seconds(), balance=balance)
    return CalibrationCost(kernels, study.runs, host, host_workers)


GPU_NOTE = ("note: the probe times the CPU's RK4; the member kernels on a GPU run faster "
            "than this estimate")
"""Said after the cost of a study whose device is not ``cpu``."""


@dataclass(frozen=True)
class UncertaintyPlan:
    """An uncertainty study as a study plan (``analysis.integrate.study.StudyPlan``): the
    prepared ``study`` (every input checked once by ``prepare``, its device judged once:
    ``study.placement``) and the netCDF file it writes. Its store keeps each block of
    ``block`` draws at one value under ``v<value index>-r<first row>``; its progress counts
    runs (a draw at a value)."""

    study: Study
    output: Path | None
    """None: not written (the command line without ``-o``: its ``run`` alone, no store)."""
    kind: str = "uncertainty"
    unit: str = "runs"

    @property
    def definition(self) -> dict[str, Any]:
        """The store's key: ``Study.definition`` (as before plans: a stored study still
        resumes)."""
        return self.study.definition()

    @property
    def placement(self) -> Placement | None:
        return self.study.placement

    @property
    def total(self) -> int:
        return self.study.runs

    def head(self, executor: Executor) -> str:
        """The lines said before the cost: the runs and the executor that runs them, then
        each distribution's note (a truncation)."""
        study = self.study
        return "\n".join([f"uncertainty: {study.design.samples} draws -> {study.design.runs} "
                          f"members x {len(study.values)} values = {study.runs} runs "
                          f"({executor.name})",
                          *(f"note: {d.note}" for d in study.dists if d.note)])

    def cost(self, workers: int) -> CalibrationCost:
        """The cost said before the work (``study_cost``) with ``workers`` host workers (the
        executor's), and the GPU's note where the device is not ``cpu``."""
        cost = study_cost(self.study, host_workers=workers)
        if self.study.device != "cpu":
            cost = dataclasses.replace(cost, notes=(GPU_NOTE,))
        return cost

    def run(self, store: Store | None, executor: Executor, progress: Progress | None,
            say: Say | None) -> xr.Dataset:
        """The study's blocks (``run``), stored in ``store`` as they finish."""
        return run(self.study, executor=executor, store=store, progress=progress)

    def stopped(self, store, exc: BaseException) -> None:
        """A stopped study counts its stored blocks (``PointStore.stopped``)."""
        store.stopped(exc, len(self.study.blocks()), f"blocks of {self.study.block} draws")


def plan_uncertainty(model: str | Model, dists: Sequence[Dist | str],
                     output: str | Path | None, **options: Any) -> UncertaintyPlan:
    """The plan of a study written to ``output`` (netCDF; None: not written, for its
    ``run`` alone): every input checked once
    (``prepare``, whose ``options`` it takes: sets, param, n_balls, samples, seed, device,
    settings, block), before any work; ``InputError`` naming the field.

    >>> plan = plan_uncertainty("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6"],
    ...                         "u.nc", n_balls=[8], samples=4)  # doctest: +SKIP
    """
    return UncertaintyPlan(prepare(model, dists, **options),
                           None if output is None else Path(output))


def uncertainty_to_file(study: Study, output, *, executor=None,
                        progress: Callable[[int, int], None] | None = None,
                        on_damaged: Callable[[str], None] | None = None) -> xr.Dataset:
    """Run a prepared study resumably (``UncertaintyPlan`` through
    ``analysis.sweeps.runner.run_study``, its cost not said): each finished block stored in
    ``<output>.parts`` (``analysis.sweeps.store``) as it arrives; run again with the same
    definition, only the missing blocks are computed; at the end the netCDF file is
    written atomically and the folder removed."""
    from analysis.sweeps.runner import run_study

    return run_study(UncertaintyPlan(study, Path(output)), executor, progress=progress,
                     on_damaged=on_damaged, cost=False)
