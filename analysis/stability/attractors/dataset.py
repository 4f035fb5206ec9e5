"""Attractor studies as Datasets (netCDF with provenance) and as JSON.

Three kinds (attr ``kind``):

- ``basins``: ``basin`` (Y, X), the attractor id of every initial state of a grid over two
  state coordinates (dims named after them), and the attractors' table; the boundary
  measures (``boundary``): the attrs ``basin_entropy``, ``boundary_basin_entropy`` (nats),
  ``boundary_boxes``, ``entropy_box`` (cells) and ``uncertainty_exponent``, and
  ``uncertain_fraction`` over ``epsilon`` (grid cells);
- ``attractors``: the table with each attractor's basin fraction among ``samples`` random
  initial states of a box, ``label`` (sample) and ``initial_state`` (sample, state);
- ``attractor-continuation``: the table at every value of a parameter (dims ``value``,
  ``attractor``), ids matched across values; ``transition`` (value, attractor, to): the
  fraction of the random states of each basin at a value that reach attractor ``to`` at
  the next value (NaN at the last value and for rows without states); ``match_notes``
  (value): the doubts about the matches at that value (``continuation``, one per line), and
  the attr ``match_distance`` (the matching threshold, orbit sizes);

The table (dim ``attractor``, coordinate ``attractor`` = the id; ``DIVERGED`` = −1 and
``UNDECIDED`` = −2 when such states occur): ``nature`` (periodic-n, quasi-periodic, chaotic,
diverged, undecided), ``period`` (forcing periods; 0: not periodic), ``lambda1`` and
``lambda1_ci95`` (1/s), ``fraction`` and ``fraction_stderr``, ``amplitude`` (attractor,
state; (max − min)/2 in the state's unit), ``representative`` (attractor, state) and
``section_points`` (attractor, point, state; NaN-padded).

The studies (``studies``) add ``label_periods`` (the forcing periods each initial state was
integrated before it was labelled), the attr ``block`` (states per block, part of the
result's definition) and, when a block failed, ``failed_blocks`` (its states are labelled
``failed``, −3).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict
from itertools import pairwise

import numpy as np
import xarray as xr

from analysis.model import System
from analysis.provenance import completed_attrs, plain, provenance, state_variable_attrs
from analysis.stability.attractors.boundary import Boundary, boundary_measures
from analysis.stability.attractors.continuation import Step, transitions
from analysis.stability.attractors.label import Attractor
from analysis.stability.attractors.mapper import SPECIAL_LABELS
from analysis.stability.attractors.sampling import Box, Range
from analysis.stability.attractors.study import AttractorStudy, Result

KINDS = ("basins", "attractors", "attractor-continuation")


def study_attrs(study: AttractorStudy, kind: str, **extra) -> dict:
    """Provenance of a study: the System's run attrs, the map (period, section, its RK4
    step ``dt`` in s and steps per period), the mapper's and the description's settings,
    ``kind`` and ``extra``."""
    smap = study.map
    attrs = completed_attrs(study.system, method="rk4", dt=smap.dt, save_every=smap.steps,
                            duration=0.0, transient=0.0)
    for key in ("duration", "transient"):
        attrs.pop(key)
    attrs.update(kind=kind, period=str(study.period), section=study.section,
                 period_s=smap.period_s, steps_per_period=smap.steps,
                 one_forcing=int(study.autonomous),
                 cell_scale=study.scale.size,
                 **{f"mapper_{k}": v for k, v in asdict(study.options).items()},
                 **{f"label_{k}": v for k, v in asdict(study.label_options).items()})
    attrs.update(extra)
    return attrs


def _rows(attractors: Sequence[Attractor], ids: Sequence[int],
          fractions: Mapping[int, tuple[float, float]], n: int) -> dict[str, list]:
    """Column lists of the table: the attractors (with their ``ids``), then the special
    labels that have a fraction."""
    cols: dict[str, list] = {k: [] for k in ("id", "nature", "period", "lambda1",
                                              "lambda1_ci95", "fraction", "fraction_stderr",
                                              "amplitude", "representative", "points")}
    nan = np.full(n, np.nan)
    rows = [(i, a) for i, a in zip(ids, attractors, strict=True)]
    rows += [(k, None) for k in SPECIAL_LABELS if k in fractions]
    for i, a in rows:
        f, e = fractions.get(i, (0.0, 0.0))
        cols["id"].append(i)
        cols["nature"].append(SPECIAL_LABELS[i] if a is None else a.nature)
        cols["period"].append(0 if a is None or a.period is None else a.period)
        cols["lambda1"].append(np.nan if a is None else a.lambda1)
        cols["lambda1_ci95"].append(np.nan if a is None else a.lambda1_ci95)
        cols["fraction"].append(f)
        cols["fraction_stderr"].append(e)
        names = None if a is None else list(a.amplitude)
        cols["amplitude"].append(nan if a is None else np.array([a.amplitude[k] for k in names]))
        cols["representative"].append(nan if a is None else a.representative)
        cols["points"].append(np.empty((0, n)) if a is None else a.points)
    return cols


def table(system: System, attractors: Sequence[Attractor], ids: Sequence[int],
          fractions: Mapping[int, tuple[float, float]], longest: int = 1) -> xr.Dataset:
    """The attractors' table (see the module) over dimension ``attractor``; the section
    points padded to at least ``longest`` rows."""
    n, names = system.n_state, list(system.state_names)
    cols = _rows(attractors, ids, fractions, n)
    longest = max([len(p) for p in cols["points"]] + [longest])
    points = np.full((len(cols["id"]), longest, n), np.nan)
    for k, p in enumerate(cols["points"]):
        points[k, :len(p)] = p
    ds = xr.Dataset(
        {"nature": ("attractor", np.array(cols["nature"], dtype=str)),
         "period": ("attractor", np.array(cols["period"], dtype=np.int64),
                    {"units": "forcing periods", "long_name": "period (0: not periodic)"}),
         "lambda1": ("attractor", np.array(cols["lambda1"]),
                     {"units": "1/s", "long_name": "largest Lyapunov exponent"}),
         "lambda1_ci95": ("attractor", np.array(cols["lambda1_ci95"]),
                          {"units": "1/s", "long_name": "95 % half-width of lambda1"}),
         "fraction": ("attractor", np.array(cols["fraction"]),
                      {"long_name": "basin fraction"}),
         "fraction_stderr": ("attractor", np.array(cols["fraction_stderr"]),
                             {"long_name": "standard error of the basin fraction"}),
         "amplitude": (("attractor", "state"), np.array(cols["amplitude"]).reshape(-1, n),
                       {"long_name": "(max - min)/2 of each state on the attractor"}),
         "representative": (("attractor", "state"),
                            np.array(cols["representative"]).reshape(-1, n),
                            {"long_name": "a state on the attractor at a section time"}),
         "section_points": (("attractor", "point", "state"), points,
                            {"long_name": "section points recorded by the mapper"})},
        coords={"attractor": np.array(cols["id"], dtype=np.int64), "state": names})
    ds["state_units"] = ("state", [system.model.state_units[k] for k in names])
    return ds


def basins_dataset(study: AttractorStudy, result: Result, x: Range, y: Range) -> xr.Dataset:
    """The ``basins`` Dataset of a grid study (``result.labels`` in grid order, x
    fastest)."""
    system = study.system
    ds = table(system, result.attractors, [a.id for a in result.attractors],
               result.fractions())
    grid = result.labels.reshape(y.num, x.num).astype(np.int32)
    ds[y.coordinate + "_grid"] = (y.coordinate + "_grid", y.points,
                                  state_variable_attrs(system.model, y.coordinate))
    ds[x.coordinate + "_grid"] = (x.coordinate + "_grid", x.points,
                                  state_variable_attrs(system.model, x.coordinate))
    ds["basin"] = ((y.coordinate + "_grid", x.coordinate + "_grid"), grid,
                   {"long_name": "attractor id (-1 diverged, -2 undecided)"})
    ds.attrs = study_attrs(study, "basins", basin_x=x.coordinate, basin_y=y.coordinate,
                           periods_integrated=result.periods)
    if min(grid.shape) >= 2:
        add_boundary(ds, boundary_measures(grid))
    return ds


def add_boundary(ds: xr.Dataset, b: Boundary) -> None:
    """The boundary measures of a basins Dataset, stored in it (see the module)."""
    ds["uncertain_fraction"] = ("epsilon", b.uncertain,
                                {"long_name": "fraction of epsilon-uncertain initial states"})
    ds["epsilon"] = ("epsilon", b.epsilons, {"units": "grid cells"})
    ds.uncertain_fraction.attrs["counted"] = ("interior states only: those whose four "
                                              "neighbours epsilon cells away lie on the grid")
    ds.attrs.update(basin_entropy=b.basin_entropy, boundary_basin_entropy=b.boundary_entropy,
                    boundary_boxes=b.boundary_boxes, entropy_box=b.box,
                    uncertainty_exponent=b.exponent)
    if b.uncertain_edges is not None:
        ds["uncertain_fraction_edges"] = (
            "epsilon", b.uncertain_edges,
            {"long_name": "fraction of epsilon-uncertain initial states, every state "
                          "against the neighbours it has on the grid"})
        ds.attrs["uncertainty_exponent_edges"] = b.exponent_edges


def boundary_json(ds: xr.Dataset) -> dict | None:
    """A basins Dataset's boundary measures as JSON (None when it has none)."""
    if "basin_entropy" not in ds.attrs:
        return None
    return {"basin_entropy": plain(float(ds.attrs["basin_entropy"]), finite=True),
            "boundary_basin_entropy": plain(float(ds.attrs["boundary_basin_entropy"]),
                                            finite=True),
            "boundary_boxes": plain(float(ds.attrs["boundary_boxes"]), finite=True),
            "box_cells": int(ds.attrs["entropy_box"]),
            "uncertainty_exponent": plain(float(ds.attrs["uncertainty_exponent"]),
                                          finite=True),
            "uncertainty_exponent_counts": "interior states only",
            "uncertainty_exponent_edges": plain(float(ds.attrs.get(
                "uncertainty_exponent_edges", float("nan"))), finite=True),
            "uncertain_fraction": {str(int(e)): float(f) for e, f in
                                   zip(ds.epsilon.values, ds.uncertain_fraction.values,
                                       strict=True)}}


def fractions_dataset(study: AttractorStudy, result: Result, states: np.ndarray, box: Box,
                      seed: int) -> xr.Dataset:
    """The ``attractors`` Dataset of random initial states."""
    system = study.system
    ds = table(system, result.attractors, [a.id for a in result.attractors],
               result.fractions())
    ds["label"] = ("sample", result.labels.astype(np.int32))
    ds["initial_state"] = (("sample", "state"), states)
    ds.attrs = study_attrs(study, "attractors", samples=len(states), seed=seed,
                           box=box.text,
                           periods_integrated=result.periods)
    return ds


def transition_array(steps: Sequence[Step], ids: Sequence[int]) -> np.ndarray:
    """(value, attractor, to): the tipping probabilities from each value to the next
    (``continuation.transitions`` of the random states' labels; NaN where none)."""
    index = {i: k for k, i in enumerate(ids)}
    out = np.full((len(steps), len(ids), len(ids)), np.nan)
    for k, (here, there) in enumerate(pairwise(steps)):
        for a, row in transitions(here.random_labels(), there.random_labels()).items():
            if a not in index:
                continue
            out[k, index[a]] = 0.0
            for b, p in row.items():
                if b in index:
                    out[k, index[a], index[b]] = p
    return out


def continuation_dataset(study: AttractorStudy, steps: Sequence[Step], parameter: str,
                         box: Box, samples: int, seed: int,
                         match_distance: float | None = None) -> xr.Dataset:
    """The ``attractor-continuation`` Dataset: the table at each value, one id axis, the
    transitions between consecutive values and the notes on the matches."""
    system = study.system
    longest = max([len(a.points) for s in steps for a in s.result.attractors] + [1])
    tables = [table(system, [a for _, a in s.attractors()],
                    [g for g, _ in s.attractors()], s.fractions(), longest) for s in steps]
    ids = sorted({int(i) for t in tables for i in t.attractor.values},
                 key=lambda i: (i < 0, abs(i)))
    merged = xr.concat([t.drop_vars("state_units").reindex(attractor=ids) for t in tables],
                       dim="value", join="outer")
    merged["nature"] = merged.nature.fillna("").astype(str)
    merged["period"] = merged.period.fillna(0).astype(np.int64)
    merged["present"] = (("value", "attractor"),
                         np.array([[i in set(t.attractor.values.tolist()) for i in ids]
                                   for t in tables]))
    merged = merged.assign_coords(value=[s.value for s in steps])
    merged = merged.assign_coords(to=np.array(ids, dtype=np.int64))
    merged["transition"] = (("value", "attractor", "to"), transition_array(steps, ids),
                            {"long_name": "fraction of the basin's random states that reach "
                                          "attractor 'to' at the next value"})
    merged["match_notes"] = ("value", np.array(["\n".join(s.notes) for s in steps],
                                               dtype=str))
    merged["value"].attrs = {"long_name": parameter,
                             "units": system.model.units.get(parameter, "")}
    merged["state_units"] = ("state", [system.model.state_units[k]
                                       for k in system.state_names])
    merged.attrs = study_attrs(study, "attractor-continuation", param=parameter,
                               samples=samples, seed=seed,
                               box=box.text,
                               periods_integrated=sum(s.result.periods for s in steps))
    if match_distance is not None:
        merged.attrs["match_distance"] = float(match_distance)
    return merged


def attractor_json(ds: xr.Dataset) -> list[dict]:
    """The table's rows as JSON: ``{"id", "class", "period", "fraction",
    "fraction_stderr", "lambda1", "lambda1_ci95", "amplitude": {state: value}}`` (period
    null unless periodic; NaN as null)."""
    rows = []
    for i in ds.attractor.values:
        row = ds.sel(attractor=i)
        period = int(row.period)
        rows.append({
            "id": int(i), "class": str(row.nature.values),
            "period": period if period > 0 else None,
            "fraction": plain(float(row.fraction), finite=True),
            "fraction_stderr": plain(float(row.fraction_stderr), finite=True),
            "lambda1": plain(float(row.lambda1), finite=True),
            "lambda1_ci95": plain(float(row.lambda1_ci95), finite=True),
            "amplitude": {str(k): plain(float(v), finite=True)
                          for k, v in zip(ds.state.values, row.amplitude.values,
                                          strict=True)}})
    return rows


def study_json(ds: xr.Dataset) -> dict:
    """The ``--json`` of ``basins`` and ``attractors`` (``{"attractors": [...],
    "provenance": {...}}``; basins add ``"boundary"``, ``boundary_json``) and of a
    continuation (``{"values": [{PARAM: value, "attractors": [...], "transitions": {FROM:
    {TO: fraction}}, "notes": [...]}, ...], "provenance": {...}}``: at each value the
    attractors present there, where their basins' states go at the next value (none at
    the last) and the doubts about the matches)."""
    if ds.attrs.get("kind") != "attractor-continuation":
        out = {"attractors": attractor_json(ds), "provenance": provenance(ds)}
        if ds.attrs.get("kind") == "basins":
            out["boundary"] = boundary_json(ds)
        out["settled"] = settled_json(ds)
        return out
    param = str(ds.attrs["param"])
    values = []
    for k, value in enumerate(ds.value.values):
        here = ds.isel(value=k)
        here = here.sel(attractor=here.attractor[here.present.values])
        notes = str(ds.match_notes.values[k]) if "match_notes" in ds else ""
        values.append({param: float(value), "attractors": attractor_json(here),
                       "transitions": transition_json(ds, k),
                       "notes": notes.split("\n") if notes else []})
    return {"values": values, "provenance": provenance(ds)}


def transition_json(ds: xr.Dataset, k: int) -> dict[str, dict[str, float]]:
    """Row ``k`` of a continuation's ``transition``: ``{FROM: {TO: fraction}}`` (ids as
    strings; rows and entries without states left out)."""
    if "transition" not in ds:
        return {}
    out = {}
    for a, row in zip(ds.attractor.values, ds.transition.values[k], strict=True):
        kept = {str(int(b)): float(p) for b, p in zip(ds.to.values, row, strict=True)
                if np.isfinite(p) and p > 0}
        if kept:
            out[str(int(a))] = kept
    return out


def existence(ds: xr.Dataset) -> dict[int, tuple[float, float]]:
    """Attractor id -> (first, last) parameter value at which a continuation found it."""
    out = {}
    for i in ds.attractor.values:
        where = ds.value.values[ds.present.sel(attractor=i).values]
        if int(i) > 0 and len(where):
            out[int(i)] = (float(where.min()), float(where.max()))
    return out


UNSETTLED = 0.5
"""Share of undecided initial states from which a study says that most did not settle."""


def unsettled(ds: xr.Dataset) -> list[str]:
    """Sentences for a ``basins`` or ``attractors`` Dataset in which at least ``UNSETTLED``
    of the states stayed undecided (none otherwise): how many, why where it can be known
    (a section that is not a map: more than one forcing frequency) and which setting to
    raise."""
    from analysis.stability.attractors.mapper import UNDECIDED

    if UNDECIDED not in ds.attractor.values:
        return []
    share = float(ds.fraction.sel(attractor=UNDECIDED))
    if share < UNSETTLED:
        return []
    attrs = ds.attrs
    found = int((ds.attractor.values > 0).sum())
    head = ("nothing settled" if found == 0 or share >= 0.999
            else "most initial states did not settle")
    out = [f"{head}: {100 * share:.1f} % of the initial states were still searching after "
           f"{attrs.get('mapper_max_periods', '?')} forcing periods (undecided)"
           + (f"; the {found} attractor(s) found hold the rest" if found else "")]
    if str(attrs.get("mapper", "recurrence")) == "features":
        out.append("raise --transient-periods (the states are still moving when recorded) "
                   "or --sections")
        return out
    if not int(attrs.get("one_forcing", 1)):
        out.append(f"why: the {attrs.get('section', '')} section is not a map of this "
                   "system (it has more than one forcing frequency: unbalance and cage, or "
                   "several bearings, in general incommensurate), so a trajectory's "
                   "section points drift and rarely revisit their cells; a quasi-periodic "
                   "motion needs many periods to recur")
        out.append("use --mapper features (needs no recurrence), or raise --max-periods "
                   f"(now {attrs.get('mapper_max_periods', '?')}) and lower --resolution "
                   f"(now {attrs.get('mapper_resolution', '?')}: coarser cells recur "
                   "sooner)")
        return out
    out.append(f"raise --max-periods (now {attrs.get('mapper_max_periods', '?')}), or lower "
               f"--resolution (now {attrs.get('mapper_resolution', '?')}: coarser cells "
               f"recur sooner) or --revisits (now {attrs.get('mapper_revisits', '?')})")
    return out


def settled_json(ds: xr.Dataset) -> dict:
    """``{"settled": bool, "advice": [...]}`` of ``unsettled``."""
    advice = unsettled(ds)
    return {"settled": not advice, "advice": advice}
