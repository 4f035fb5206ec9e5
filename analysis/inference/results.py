"""A calibration's results: a Dataset (every member of every round, with its weight in the
posterior) and the JSON of issue 30's layout::

    {"target": …,
     "accepted": [{"parameters": {PARAM: value}, "weight": w, "matched": k,
                   "rows": [{…, "class": …, "lambda1": …}]}],
     "best_matched": k,
     "share_of_prior": {"5": s5, "4": s4, …},
     "provenance": {…}}

with ``priors``, ``best`` (the sets of fewest rows missed), ``credible_90`` and ``cost``
beside them; and what the calibration says of itself (issue 41): ``doubtful_share`` (per k,
the share of the prior that matches k rows only with its doubtful rows counted: λ1's
interval reaching zero), ``narrowing`` (per parameter, the posterior's 90 % interval over
the prior's, in the prior's coordinate), ``effective_sample_size`` and ``verdict`` ('' or
why the run is too small to conclude). Parameters are in SI units (speed in rpm), λ1 in 1/s.

A calibration run to a file is a study plan (``CalibrationPlan``, made by
``plan_calibration``: ``analysis.integrate.study``), run by the one runner
(``analysis.sweeps.runner.run_study``), which opens its store and writes its file.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from analysis.inference.abc import (
    RECHECK_SETS,
    Calibration,
    CalibrationCost,
    Problem,
    doubtful_match,
    prepare,
    recheck_halved,
    row_marks,
    run,
)
from analysis.provenance import plain, provenance, run_attrs

if TYPE_CHECKING:
    from analysis.inference.priors import Prior
    from analysis.inference.targets import Target
    from analysis.integrate.kernels.placement import Placement
    from analysis.integrate.study import Executor, Progress, Say, Store
    from analysis.model import Model

BEST = 10
"""Sets listed under ``best``."""


def _attrs(cal: Calibration) -> dict[str, Any]:
    """Provenance of a calibration: the model (spec path and sha256, defaults, versions)
    and how it was calibrated."""
    model = cal.model
    structure = model.default_structure
    attrs = run_attrs(model, structure, dict(model.parameters({})))
    attrs.pop("n_balls", None)
    opts = cal.options
    attrs.update({
        "analysis": "calibration (SMC-ABC)",
        "target": cal.target.name, "target_file": cal.target.path,
        "priors": " ".join(p.text() for p in cal.priors),
        "samples": opts.samples, "rounds": opts.rounds, "seed": opts.seed,
        "quantile": opts.quantile, "device": cal.device,
        "transient_revolutions": opts.settings.transient_revolutions,
        "revolutions": opts.settings.revolutions,
        "samples_per_revolution": opts.settings.samples_per_revolution,
        "dt_max": float(opts.settings.dt or model.simulation_defaults["dt"]),
        "best_matched": cal.best_matched(), "wall_s": round(cal.wall_s, 3),
        "effective_sample_size": cal.effective_sample_size(),
        "verdict": cal.verdict() or "conclusive by its own measures",
    })
    if cal.halved is not None:
        attrs.update(halved_rows_checked=cal.halved[0], halved_rows_changed=cal.halved[1])
    return attrs


def to_dataset(cal: Calibration) -> xr.Dataset:
    """Every member of every round over ``member``, its rows over ``row``; ``weight`` is its
    posterior weight (0 outside the last round's population)."""
    rows = cal.target.rows
    names = [p.name for p in cal.priors]
    units = cal.model.units
    members = [(r, i) for r in cal.rounds for i in range(len(r.values))]
    last = cal.posterior.index
    data: dict[str, Any] = {
        "member_round": ("member", np.array([r.index for r, _ in members]),
                         {"long_name": "round the member ran in (0: the Sobol round)"}),
        "weight": ("member", np.array([r.weights[i] if r.index == last else 0.0
                                       for r, i in members])),
        "discrepancy": ("member", np.array([r.discrepancy[i] for r, i in members]),
                        {"long_name": "class misses + line misses / (rows + 1)"}),
        "matched": ("member", np.array([r.matched[i] for r, i in members]),
                    {"long_name": "rows whose class matches"}),
        "lines_matched": ("member", np.array([r.lines_matched[i] for r, i in members])),
        "epsilon": ("round", np.array([r.epsilon for r in cal.rounds]),
                    {"long_name": "tolerance (rows missed)"}),
        "share_of_prior": ("k", np.array(list(cal.share_of_prior().values())),
                           {"long_name": "share of the prior whose sets match k rows"}),
        "doubtful_share": ("k", np.array(list(cal.doubtful_share().values())),
                           {"long_name": "share of the prior that matches k rows only with "
                                         "its doubtful rows counted (lambda1's 95 % interval "
                                         "reaching zero)"}),
    }
    narrowing = cal.narrowing()
    for j, name in enumerate(names):
        data[name] = ("member", np.array([r.values[i, j] for r, i in members]),
                      {"units": units.get(name, ""), "prior": cal.priors[j].text(),
                       "narrowing": narrowing[name]})
    grid = [[r.rows[i][k] for k in range(len(rows))] for r, i in members]
    data["nature"] = (("member", "row"), np.array([[g.nature for g in m] for m in grid]))
    data["lambda1"] = (("member", "row"), np.array([[g.lambda1 for g in m] for m in grid]),
                       {"units": "1/s"})
    data["ci95"] = (("member", "row"), np.array([[g.ci95 for g in m] for m in grid]),
                    {"units": "1/s"})
    data["class_at_half_step"] = (("member", "row"),
                                  np.array([[g.halved for g in m] for m in grid]),
                                  {"long_name": "the class with the RK4 step halved ('' not "
                                                "checked: only the best sets' matched rows "
                                                "are)"})
    data["diverged_at"] = (("member", "row"),
                           np.array([[g.diverged_at for g in m] for m in grid]),
                           {"units": "s"})
    marks = [[row_marks(row, g) for row, g in zip(rows, m, strict=True)] for m in grid]
    data["class_ok"] = (("member", "row"), np.array([[k for k, _ in m] for m in marks]))
    data["lines_ok"] = (("member", "row"), np.array([[ln for _, ln in m] for m in marks]))
    data["doubtful"] = (("member", "row"),
                        np.array([[doubtful_match(row, g) for row, g in zip(rows, m,
                                                                            strict=True)]
                                  for m in grid]),
                        {"long_name": "the class would match but lambda1's 95 % interval "
                                      "reaches zero: not counted as matched"})
    for c in cal.target.coordinates:
        data[f"major_{c}"] = (("member", "row"),
                              np.array([[g.major.get(c, "") for g in m] for m in grid]))
        data[f"lines_{c}"] = (("member", "row"),
                              np.array([[",".join(g.lines.get(c, [])) for g in m]
                                        for m in grid]))
    coords = {"member": np.arange(len(members)), "row": [r.name() for r in rows],
              "round": np.arange(len(cal.rounds)),
              "k": np.arange(len(rows), -1, -1)}
    return xr.Dataset(data, coords=coords, attrs=_attrs(cal))


def _member_json(cal: Calibration, r, i: int) -> dict[str, Any]:
    rows = []
    for row, res in zip(cal.target.rows, r.rows[i], strict=True):
        klass, lines = row_marks(row, res)
        rows.append({"row": row.name(), "n_balls": row.balls,
                     "wanted": list(row.classes), "class": res.nature,
                     "lambda1": plain(res.lambda1, finite=True),
                     "ci95": plain(res.ci95, finite=True),
                     "major": res.major, "lines": res.lines,
                     "class_ok": bool(klass), "lines_ok": bool(lines),
                     "doubtful": bool(doubtful_match(row, res)),
                     "class_at_half_step": res.halved or None,
                     "diverged_at": plain(res.diverged_at, finite=True)})
    return {"parameters": {p.name: float(r.values[i, j]) for j, p in enumerate(cal.priors)},
            "weight": float(r.weights[i]) if r.weights is not None else 0.0,
            "matched": int(r.matched[i]), "lines_matched": int(r.lines_matched[i]),
            "discrepancy": float(r.discrepancy[i]), "round": r.index, "rows": rows}


def to_json(cal: Calibration, output: str | None = None) -> dict[str, Any]:
    """The issue's JSON layout (see the module docstring); ``output``: the netCDF file."""
    post = cal.posterior
    accepted = [_member_json(cal, post, i) for i in np.flatnonzero(post.weights > 0)]
    accepted.sort(key=lambda m: -m["weight"])
    everyone = [(r, i) for r in cal.rounds for i in range(len(r.values))]
    everyone.sort(key=lambda ri: (ri[0].discrepancy[ri[1]], -ri[0].index))
    best = [_member_json(cal, r, i) for r, i in everyone[:BEST]]
    return {"target": cal.target.as_dict(),
            "priors": [{"name": p.name, "lo": p.lo, "hi": p.hi, "log": p.log,
                        "units": cal.model.units.get(p.name, "")} for p in cal.priors],
            "accepted": accepted,
            "best_matched": cal.best_matched(),
            "share_of_prior": {str(k): v for k, v in cal.share_of_prior().items()},
            "doubtful_share": {str(k): v for k, v in cal.doubtful_share().items()},
            "narrowing": cal.narrowing(),
            "effective_sample_size": cal.effective_sample_size(),
            "verdict": cal.verdict(),
            "halved_step_check": (None if cal.halved is None else
                                  {"rows_checked": cal.halved[0],
                                   "rows_changed": cal.halved[1]}),
            "best": best,
            "credible_90": {k: list(v) for k, v in cal.credible_interval(0.9).items()},
            "tolerances": [r.epsilon for r in cal.rounds],
            "output": output,
            "provenance": provenance(_attrs(cal))}


GPU_NOTE = ("note: the probe times the CPU's RK4; the member kernels on a GPU run faster "
            "than this estimate")
"""Said after the cost of a calibration whose device is not ``cpu``."""


@dataclass(frozen=True)
class CalibrationPlan:
    """A calibration as a study plan (``analysis.integrate.study.StudyPlan``): the prepared
    ``problem`` (every input checked once by ``abc.prepare``, its device judged once:
    ``problem.placement``) and the netCDF file it writes. Its store keeps each finished
    block of ``block`` parameter sets under ``r<round>-b<first set>``; its progress counts
    runs (a set at a row). ``run`` keeps the ``Calibration`` it made (``calibration``)."""

    problem: Problem
    output: Path
    kind: str = "calibrate"
    unit: str = "runs"
    kept: list[Calibration] = field(default_factory=list, compare=False, repr=False)
    """The Calibration of each ``run`` (the runner writes its Dataset; the caller reports
    it)."""

    @property
    def definition(self) -> dict[str, Any]:
        """The store's key: ``Problem.definition`` (as before plans: a stored calibration
        still resumes)."""
        return self.problem.definition()

    @property
    def placement(self) -> Placement | None:
        return self.problem.placement

    @property
    def total(self) -> int:
        """Runs: sets × rounds × target rows."""
        opts = self.problem.options
        return opts.samples * opts.rounds * len(self.problem.target.rows)

    def head(self, executor: Executor) -> str:
        """The line said before the cost: the runs and the executor that runs them."""
        opts, rows = self.problem.options, len(self.problem.target.rows)
        return (f"calibrate: {opts.samples} sets × {opts.rounds} rounds × {rows} rows = "
                f"{self.total} runs ({executor.name})")

    @property
    def calibration(self) -> Calibration:
        """The Calibration of the last ``run``."""
        return self.kept[-1]

    def cost(self, workers: int) -> CalibrationCost:
        """The cost said before the work (``abc.problem_cost``) with ``workers`` host
        workers (the executor's), and the GPU's note where the device is not ``cpu``."""
        cost = self.problem.cost(host_workers=workers)
        if self.problem.options.device != "cpu":
            cost = dataclasses.replace(cost, notes=(GPU_NOTE,))
        return cost

    def run(self, store: Store | None, executor: Executor, progress: Progress | None,
            say: Say | None) -> xr.Dataset:
        """The rounds (``abc.run``: each round's line to ``say``), the best sets rechecked
        with the step halved (``recheck_halved``), and the Dataset (``to_dataset``)."""
        cal = run(self.problem, executor=executor, store=store, progress=progress, log=say)
        checked, changed = recheck_halved(cal, device=self.problem.device)
        if say:
            say(f"step halved at the {RECHECK_SETS} best sets: {changed} of {checked} matched "
                "rows changed class (now doubtful, not matched)")
        self.kept.append(cal)
        return to_dataset(cal)

    def stopped(self, store, exc: BaseException) -> None:
        """A stopped calibration counts its stored blocks (``PointStore.stopped``)."""
        opts = self.problem.options
        store.stopped(exc, opts.rounds * -(-opts.samples // opts.block),
                      f"blocks of {opts.block} parameter sets")


def plan_calibration(model: str | Model, target: str | Target,
                     priors: Sequence[Prior | str], output: str | Path,
                     **options: Any) -> CalibrationPlan:
    """The plan of a calibration written to ``output`` (netCDF): every input checked once
    (``abc.prepare``, whose ``options`` it takes: samples, rounds, seed, quantile,
    settings, device, block), before any work; ``InputError`` naming the field.

    >>> plan = plan_calibration("vakharia2015", "paper-table2", ["damping:10:3162:log"],
    ...                         "cal.nc", samples=8, rounds=1)  # doctest: +SKIP
    """
    return CalibrationPlan(prepare(model, target, priors, **options), Path(output))


def calibrate_to_file(problem: Problem, output: str | Path, *, executor=None,
                      progress: Callable[[int, int], None] | None = None,
                      log: Callable[[str], None] | None = None,
                      on_damaged: Callable[[str], None] | None = None) -> Calibration:
    """Run a prepared calibration resumably (``CalibrationPlan`` through
    ``analysis.sweeps.runner.run_study``, its cost not said): each finished block of
    members is stored in ``<output>.parts`` (``analysis.sweeps.store``) as it arrives, so
    an interrupted calibration run again with the same definition computes only the
    missing blocks; at the end the netCDF file is written atomically and the folder
    removed. ``log(line)``: each round's line and the halved step's."""
    from analysis.sweeps.runner import run_study

    plan = CalibrationPlan(problem, Path(output))
    run_study(plan, executor, progress=progress, say=log, on_damaged=on_damaged, cost=False)
    return plan.calibration
