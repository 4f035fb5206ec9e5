"""A branch as a Dataset, and what it says: its special points and its summary."""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.model import Model
from analysis.provenance import run_attrs
from analysis.stability.continuation.problem import BranchPoint, ContinuedParameter


def branch_dataset(model: Model, prob: ContinuedParameter, branch: list[BranchPoint], param: str,
                   status: str, label: str = "", **extra: object) -> xr.Dataset:
    """The branch as a Dataset: ``param`` value, amplitude (of the first state variable),
    z0 (dims ``point`` × ``state``, the model's state names), the n multipliers (real and
    imaginary parts, dim ``k``), stability and special-point labels along ``point``; what a
    restart needs (``continue_from_branch``): the tangent (dim ``w``: the scaled state, then
    the parameter) and the planned step ``ds`` at each point, the scales ``state_scale``
    (the states' units) and attr ``param_scale`` (the parameter's unit), attrs ``t0`` (s),
    ``period`` and ``steps_per_period``; the guards' measures ``tangent_angle`` (deg) and
    ``newton_contraction``; attrs from ``run_attrs`` (model, spec, balls per bearing,
    parameters, state names) and ``extra``."""
    mult = np.array([p.multipliers for p in branch])
    attrs = run_attrs(model, prob.structure, prob.values)
    attrs.update(param=param, period=str(prob.period), steps_per_period=prob.n_steps,
                 t0=prob.t0, status=status, branch=label or f"period {prob.period}",
                 param_scale=prob.s_lam, **extra)
    attrs.pop(param, None)
    units = model.state_units
    return xr.Dataset(
        {param: ("point", np.array([p.lam for p in branch]),
                 {"units": model.units[param]}),
         "amplitude": ("point", np.array([p.amplitude for p in branch]),
                       {"units": units[model.state_names[0]],
                        "long_name": f"half peak-to-peak {model.state_names[0]} over one "
                                     "period"}),
         "z0": (("point", "state"), np.array([p.z0 for p in branch])),
         "multiplier_real": (("point", "k"), mult.real),
         "multiplier_imag": (("point", "k"), mult.imag),
         "multiplier_abs": (("point", "k"), np.abs(mult)),
         "stable": ("point", np.array([int(p.stable) for p in branch])),
         "special": ("point", np.array([p.special for p in branch], dtype=object)),
         "newton_iterations": ("point", np.array([p.newton_iterations for p in branch])),
         "tangent": (("point", "w"), np.array([p.tangent for p in branch]),
                     {"long_name": "unit tangent in the scaled variables (z0 / state_scale, "
                                   f"{param} / param_scale)"}),
         "ds": ("point", np.array([p.ds for p in branch]),
                {"long_name": "scaled arclength step planned from the point"}),
         "tangent_angle": ("point", np.array([p.angle for p in branch]),
                           {"units": "deg", "long_name": "angle from the previous tangent"}),
         "newton_contraction": ("point", np.array([p.contraction for p in branch])),
         "state_scale": ("state", np.asarray(prob.s_z, dtype=float),
                         {"long_name": "scale of each state in the unknowns"})},
        coords={"point": np.arange(len(branch)), "state": list(model.state_names),
                "k": np.arange(1, model.n_state + 1)},
        attrs=attrs)


def with_normal_forms(branch: xr.Dataset, prob: ContinuedParameter,
                      points: list[BranchPoint]) -> xr.Dataset:
    """``branch`` with the normal forms of its LP, PD and NS points
    (``normal_form.branch_normal_forms``): ``normal_form_coefficient`` (the fold's a, the
    flip's c, the Neimark–Sacker d in the scaled states; NaN elsewhere) and
    ``criticality`` ("supercritical", "subcritical", "fold", "nonsmooth" or "";
    "nonsmooth supercritical" or "nonsmooth subcritical" where a non-smooth PD's period-2
    orbit decides, ``normal_form.orbit_criticality``)."""
    from analysis.stability.continuation.normal_form import branch_normal_forms

    coefficient, label = branch_normal_forms(prob, points)
    branch["normal_form_coefficient"] = ("point", coefficient, {
        "long_name": "normal-form coefficient (fold a, flip c, Neimark-Sacker d) of the "
                     "period map in z / state_scale; flip: c > 0 supercritical; NS: d < 0 "
                     "supercritical"})
    branch["criticality"] = ("point", label)
    return branch


def normal_form_of(branch: xr.Dataset, j: int) -> dict | None:
    """``{"coefficient": c, "criticality": …}`` of point ``j`` (``"nonsmooth": true`` and
    no coefficient where a ball is at the contact threshold; then the criticality, when
    known, comes from the period-2 orbit: ``"criticality_from": "period-2 orbit"``), or
    None: no normal form there, or a branch file written before normal forms were
    stored."""
    if "criticality" not in branch or not branch.criticality.values[j]:
        return None
    label = str(branch.criticality.values[j])
    if label.startswith("nonsmooth"):
        words = label.split()
        if len(words) == 1:
            return {"coefficient": None, "criticality": None, "nonsmooth": True}
        return {"coefficient": None, "criticality": words[1], "nonsmooth": True,
                "criticality_from": "period-2 orbit"}
    return {"coefficient": float(branch.normal_form_coefficient.values[j]),
            "criticality": None if label == "fold" else label}


def first_point(branch: xr.Dataset, kind: str) -> int | None:
    """Index of the first point labelled ``kind`` (LP, PD, BP, NS) on ``branch``, or None."""
    found = np.nonzero(branch.special.values == kind)[0]
    return int(found[0]) if len(found) else None


def special_points(branch: xr.Dataset) -> list[dict]:
    """The labelled points of a branch: label, point index, the parameter value (its unit),
    the n multipliers (real and imaginary parts) and, at LP, PD and NS points, the
    ``normal_form`` (``normal_form_of``)."""
    param = branch.attrs["param"]
    out = []
    for j, kind in enumerate(branch.special.values):
        if not kind:
            continue
        entry = {"kind": str(kind), "point": int(j), "value": float(branch[param].values[j]),
                 "multipliers_real": branch.multiplier_real.values[j].tolist(),
                 "multipliers_imag": branch.multiplier_imag.values[j].tolist()}
        form = normal_form_of(branch, j)
        if form is not None:
            entry["normal_form"] = form
        out.append(entry)
    return out


def special_point_lines(branch: xr.Dataset) -> list[str]:
    """One line per special point in the parameter's own unit, e.g.
    ``LP  speed_rpm = 7871.75 rpm  (point 41)``."""
    param = branch.attrs["param"]
    unit = str(branch[param].attrs.get("units", ""))
    return [f"{p['kind']}  {param} = {p['value']:.6g} {unit}".rstrip() + f"  (point {p['point']})"
            for p in special_points(branch)]


def special_point_notes(branch: xr.Dataset) -> list[str]:
    """Per special point (as ``special_point_lines``), its criticality in words, or "":
    ``supercritical (flip coefficient c = 113)``, ``subcritical (…)``, ``fold (quadratic
    coefficient a = …)`` or ``non-smooth: a ball at the contact threshold, no normal
    form``."""
    names = {"LP": "quadratic coefficient a", "PD": "flip coefficient c",
             "NS": "first Lyapunov coefficient d"}
    notes = []
    for p in special_points(branch):
        form = p.get("normal_form")
        if form is None:
            notes.append("")
        elif form.get("nonsmooth"):
            notes.append("non-smooth: a ball at the contact threshold, no normal form"
                         + (f"; {form['criticality']} by its period-2 orbit"
                            if form["criticality"] else ""))
        else:
            notes.append(f"{form['criticality'] or 'fold'} ({names[p['kind']]} = "
                         f"{form['coefficient']:.4g})")
    return notes


def branch_summary(branch: xr.Dataset) -> dict:
    """What a branch is, in plain types (``bearingdyn continue --json``): model, parameter
    and its unit, period, points, parameter range covered, stable points, status, refused
    steps, the special points (``special_points``) and where it restarted from."""
    attrs, param = branch.attrs, branch.attrs["param"]
    values = branch[param].values
    return {"branch": str(attrs.get("branch", "")), "model": str(attrs["model"]),
            "param": param, "units": str(branch[param].attrs.get("units", "")),
            "period": str(attrs["period"]), "points": int(branch.sizes["point"]),
            "range": [float(values.min()), float(values.max())],
            "stable_points": int(branch.stable.values.sum()),
            "status": str(attrs["status"]),
            "refused_steps": int(attrs.get("refused_steps", 0)),
            "restarted_from": str(attrs.get("restarted_from", "")) or None,
            "special_points": special_points(branch)}
