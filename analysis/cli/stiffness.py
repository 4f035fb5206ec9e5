"""Statics: `stiffness` (static equilibrium and linearised bearing coefficients)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    JsonOption,
    ModelArgument,
    NBallsOption,
    SetOption,
    SpeedOption,
    app,
    echo_json,
    figure_output,
    json_output,
    parameter_values,
    parse_n_balls,
    reports_errors,
    write_figure,
)
from analysis.errors import InputError, check_count


def parse_speeds(text: str) -> list[float]:
    """``"1000:10000:10"`` (10 speeds from 1000 to 10000 rpm) or ``"1000,5000,8000"`` -> rpm."""
    import numpy as np

    try:
        if ":" in text:
            start, stop, count = text.split(":")
            n = int(count)
            if n < 1:
                raise ValueError
            speeds = np.linspace(float(start), float(stop), n).tolist()
        else:
            speeds = [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise InputError(f"--speeds: expected START:STOP:COUNT or a comma list of speeds in "
                         f"rpm, got {text!r}") from None
    if not speeds or any(not math.isfinite(s) or s < 0 for s in speeds):
        raise InputError(f"--speeds: speeds must be finite and >= 0 rpm, got {text!r}")
    return speeds


def stiffness_json(ds) -> dict:
    """The JSON of `bearingdyn stiffness --json`: provenance, the equilibrium and matrices at
    cage angle 0, their cage-angle means, and every cage angle."""
    from analysis.provenance import provenance
    from analysis.stability.statics import bearing_coefficients

    coords = [str(c) for c in ds.row.values]
    data = {
        "provenance": provenance(ds),
        "coordinates": coords,
        "units": {"position": ds.position.attrs["units"], "stiffness": ds.stiffness.attrs["units"],
                  "damping": ds.damping.attrs["units"], "cage_angle": "rad"},
        "cage_pitch": float(ds.attrs["cage_pitch"]),
        "at_cage_angle_0": {
            "position": ds.position.values[0].tolist(),
            "stiffness": ds.stiffness.values[0].tolist(),
            "damping": ds.damping.values[0].tolist(),
            "singular": bool(ds.singular.values[0]),
            "residual": float(ds.residual.values[0])},
        "mean": {"stiffness": ds.stiffness_mean.values.tolist(),
                 "damping": ds.damping_mean.values.tolist()},
        "over_cage_angle": {
            "cage_angle": ds.cage_angle.values.tolist(),
            "position": ds.position.values.tolist(),
            "stiffness": ds.stiffness.values.tolist(),
            "damping": ds.damping.values.tolist(),
            "singular": ds.singular.values.tolist()},
    }
    if coords == ["x", "y"]:
        for key, matrices in (("at_cage_angle_0", (ds.stiffness.values[0], ds.damping.values[0])),
                              ("mean", (ds.stiffness_mean.values, ds.damping_mean.values))):
            data[key].update(bearing_coefficients(matrices[0], coords, "k"))
            data[key].update(bearing_coefficients(matrices[1], coords, "c"))
    return data


@app.command()
@reports_errors
def stiffness(
    model: ModelArgument,
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    angles: Annotated[int, typer.Option(
        help="Cage angles per ball pitch (evenly spaced from 0; with two bearings, per "
             "pitch of the one with more balls).")] = 36,
    as_json: JsonOption = False,
    ross: Annotated[Path | None, typer.Option(
        "--ross", help="Write cage-averaged coefficients over --speeds as the keywords of "
                       "ROSS's BearingElement (JSON; frequency in rad/s).",
        callback=json_output)] = None,
    speeds: Annotated[str | None, typer.Option(
        help="Shaft speeds of --ross, rpm: START:STOP:COUNT or a comma list (default: 10 "
             "speeds from 10 % to 200 % of the model's speed).")] = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Figure of the coefficients over the cage angle.",
        callback=figure_output)] = None,
):
    """Static equilibrium under the constant loads (velocities 0, cage held), and the
    stiffness K = -dF/dq and damping C = -dF/dq' matrices: at cage angle 0, over one ball
    pitch and averaged over it."""
    import numpy as np

    from analysis.model import as_system
    from analysis.stability.statics import (
        balls_in_contact,
        check_planar,
        coefficients,
        ross_coefficients,
        unloaded_note,
    )

    check_count("--angles", angles, 1, 3600)
    system = as_system(model, parse_n_balls(n_balls), **parameter_values(speed_rpm, sets))
    rpm = None
    if speeds is not None and not ross:
        raise InputError("--speeds: only with --ross")
    if ross:  # checked before any work
        check_planar(system.state_names[:system.n_state // 2])
        base = sum(float(system.parameters[n]) for n in system.model.role("speed")[:1])
        rpm = parse_speeds(speeds) if speeds else np.linspace(0.1 * base, 2 * base, 10).tolist()
    ds = coefficients(system, n_angles=angles)
    data = stiffness_json(ds)
    contact = balls_in_contact(system, ds.position.isel(cage_angle=0).values)
    data["balls_in_contact"] = {name: touching for name, (touching, _) in contact.items()}
    if as_json:
        echo_json(data, indent=2)
    else:
        _echo(data)
    if (note := unloaded_note(contact)) is not None:  # the no-load line (issue 32)
        typer.echo(note, err=as_json)
    if ross:
        _write_ross(ross, ross_coefficients(system, rpm, n_angles=angles), rpm, data, as_json)
    if output:
        from analysis.reports.plots import stiffness_figure

        write_figure(stiffness_figure(ds), output, err=as_json)


def _write_ross(path: Path, element: dict, rpm: list[float], data: dict,
                as_json: bool) -> None:
    """`stiffness --ross`: the keywords of ROSS's BearingElement over the speeds (rpm)."""
    from analysis.io import atomic_write

    payload = {"bearing_element": element,
               "speeds_rpm": rpm,
               "units": {"k": "N/m", "c": "N*s/m", "frequency": "rad/s"},
               "note": "cage-averaged coefficients; rs.BearingElement(n=NODE, "
                       "**data['bearing_element'])",
               "provenance": data["provenance"]}
    text = json.dumps(payload, indent=2)
    atomic_write(path, lambda tmp: tmp.write_text(text))
    typer.echo(f"wrote {path}", err=as_json)


def _echo(data: dict) -> None:
    coords = data["coordinates"]
    zero, mean = data["at_cage_angle_0"], data["mean"]
    prov = data["provenance"]
    typer.echo(f"{prov['model']}: static equilibrium and linearised coefficients "
               f"(cage pitch {data['cage_pitch']:.6g} rad, "
               f"{len(data['over_cage_angle']['cage_angle'])} angles)")
    typer.echo("equilibrium at cage angle 0: " + ", ".join(
        f"{c} = {v:.6g}" for c, v in zip(coords, zero["position"], strict=True))
        + f" ({data['units']['position']})")
    tilts = "rad" in data["units"]["position"]
    units = (data["units"]["stiffness"], data["units"]["damping"]) if tilts else \
        ("N/m", "N*s/m")
    for title, block in (("at cage angle 0", zero), ("averaged over the pitch", mean)):
        for name, unit in zip(("stiffness", "damping"), units, strict=True):
            typer.echo(f"{name} {title} ({unit}; rows/columns {', '.join(coords)}):")
            for row in block[name]:
                typer.echo("  " + "  ".join(f"{v + 0.0:13.6g}" for v in row))
    if zero["singular"]:
        typer.echo("note: K is singular at cage angle 0 (e.g. one loaded ball: no stiffness "
                   "across its line); the equilibrium there is not unique along that direction")
