"""`bearingdyn import-ross`: a rotor saved by ROSS as a spec with a finite-element shaft."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, reports_errors


def parse_ball_bearings(items: list[str] | None) -> dict:
    """``NODE=NAME`` items as {node: BallBearing} (the catalogue of analysis.measured)."""
    from analysis.errors import InputError
    from analysis.measured.bearings import lookup
    from modelgen.fe.ross_import import BallBearing

    found = {}
    for item in items or []:
        node, sep, name = str(item).partition("=")
        if not sep or not node.strip().isdigit() or not name.strip():
            raise InputError(f"--ball-bearing: expected NODE=NAME (e.g. 24=6205), got {item!r}")
        if int(node) in found:
            raise InputError(f"--ball-bearing: node {int(node)} given twice")
        try:
            b = lookup(name.strip())
        except InputError as exc:  # the catalogue names its parameter, bearing
            if exc.field != "bearing":
                raise
            raise InputError("--ball-bearing" + str(exc)[len(exc.field):]) from None
        found[int(node)] = BallBearing(b.name, b.ball_diameter_m, b.pitch_diameter_m,
                                       b.n_balls, b.source)
    return found


@app.command("import-ross")
@reports_errors
def import_ross(
    rotor_file: Annotated[Path, typer.Argument(
        help="A rotor saved by ROSS's Rotor.save (.toml or .json).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="The spec to write (.toml; "
                                         "its name is the model's).")],
    ball_bearings: Annotated[list[str] | None, typer.Option(
        "--ball-bearing", help="NODE=NAME: put a nonlinear ball bearing of catalogue "
                               "geometry NAME (6205, 6205-cwru, d=MM,D=MM,z=N …) at NODE "
                               "instead of its linear bearing; repeatable.")] = None,
):
    """Read a ROSS rotor file (needs the [ross] extra) and write a spec with the same shaft
    elements, materials, disks and linear bearings, nodes numbered as ROSS numbers them;
    --ball-bearing swaps a linear bearing for a ball bearing with the seed model's Hertz
    contact, clearance and damping terms."""
    from analysis.io import atomic_write
    from modelgen.fe.ross_import import ross_spec_text

    text = ross_spec_text(rotor_file, output, parse_ball_bearings(ball_bearings))
    atomic_write(output, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    typer.echo(f"wrote {output}")
