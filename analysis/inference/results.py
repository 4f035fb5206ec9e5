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
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.inference.abc import (
    RECHECK_SETS,
    Calibration,
    Problem,
    doubtful_match,
    recheck_halved,
    row_marks,
    run,
)
from analysis.provenance import plain, provenance, run_attrs

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


def write_calibration(cal: Calibration, output: str | Path) -> xr.Dataset:
    """Write the calibration's Dataset to ``output`` (netCDF, atomically); returns it."""
    from analysis.io import save_dataset

    ds = to_dataset(cal)
    save_dataset(ds, output)
    return ds


def calibrate_to_file(problem: Problem, output: str | Path, *, executor=None,
                      progress: Callable[[int, int], None] | None = None,
                      log: Callable[[str], None] | None = None,
                      on_damaged: Callable[[str], None] | None = None) -> Calibration:
    """Run a prepared calibration resumably: each finished block of members is stored in
    ``<output>.parts`` (``analysis.sweeps.store``) as it arrives, so an interrupted
    calibration run again with the same definition computes only the missing blocks; at
    the end the netCDF file is written atomically and the folder removed."""
    from analysis.sweeps.store import PointStore

    store = PointStore(output, problem.definition(), lock=True, on_damaged=on_damaged)
    total = problem.options.rounds * -(-problem.options.samples // problem.options.block)
    try:
        cal = run(problem, executor=executor, store=store, progress=progress, log=log)
        checked, changed = recheck_halved(cal)
        if log:
            log(f"step halved at the {RECHECK_SETS} best sets: {changed} of {checked} matched "
                "rows changed class (now doubtful, not matched)")
        write_calibration(cal, output)
    except BaseException as exc:
        store.stopped(exc, total, f"blocks of {problem.options.block} parameter sets")
        raise
    store.remove()
    return cal
