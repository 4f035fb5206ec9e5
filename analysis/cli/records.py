"""`bearingdyn record`: measured records (``analysis.measured.records``): `record info`, and
the options every command that reads a record shares (``--channel``, ``--fs``, ``--rpm``,
``--tacho``, ``--bearing``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, reports_errors

record_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, add_completion=False,
                         help="Measured records (CSV/TSV, WAV, MAT, UFF 58, TDMS, netCDF): "
                              "what a file holds (record info).")
app.add_typer(record_app, name="record")

RECORD_HELP = ("A measured record (.csv/.tsv/.txt, .wav, .mat, .uff/.unv, .tdms, .nc; "
               "docs: Measured records) or a netCDF file from `bearingdyn simulate`.")
FsOption = Annotated[float | None, typer.Option(
    "--fs", metavar="HZ", help="Sampling rate of a record whose file states none, Hz (a CSV without a time "
                 "column, a MAT-file; replaces a rate the file name states, 12k_...).")]
RpmOption = Annotated[str | None, typer.Option(
    "--rpm", metavar="RPM|TABLE.csv", help="A record's shaft speed, rpm, or a CSV speed table t_s,speed_rpm (replaces "
                  "the file's speed).")]
TachoOption = Annotated[str | None, typer.Option(
    "--tacho", metavar="CHANNEL", help="A record's once-per-revolution tacho channel (name or pattern): its "
                    "pulses give the speed.")]
ScaleOption = Annotated[float | None, typer.Option(
    "--scale", help="Multiply a record's channels by this (a WAV file's units per full "
                    "scale; integer samples are first scaled to [-1, 1)).")]
UnitsOption = Annotated[str | None, typer.Option(
    "--units", help="Units of a record's channels: g, m/s^2, m/s, m, um, V or 1.")]


@record_app.command("info")
@reports_errors
def info(
    record: Annotated[Path, typer.Argument(help=RECORD_HELP.split(" or a netCDF")[0] + ".",
                                           metavar="RECORD")],
    fs: FsOption = None,
    rpm: RpmOption = None,
    tacho: TachoOption = None,
    scale: ScaleOption = None,
    units: UnitsOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print it as JSON.")] = False,
):
    """A record's channels (units, range), sampling rate, length, speed and its source, and
    provenance (sha256, reader, the file's own channel names)."""
    from analysis.measured.records import read_record, record_summary

    data = read_record(record, fs=fs, rpm=rpm, tacho=tacho, scale=scale, units=units)
    summary = record_summary(data)
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    typer.echo(f"{summary['source_file']}: {len(summary['channels'])} channel(s), "
               f"{summary['sample_rate_hz']:g} Hz ({summary['sample_rate_source']}), "
               f"{summary['samples']} samples = {summary['duration_s']:.4g} s")
    typer.echo(f"speed: {summary['speed']}")
    width = max(len(c["name"]) for c in summary["channels"])
    for c in summary["channels"]:
        typer.echo(f"  {c['name']:<{width}}  {c['units']:<6} {c['original_name']:<16} "
                   f"rms {c['rms']:.4g}, range {c['min']:.4g} … {c['max']:.4g}")
    typer.echo(f"reader {summary['reader']}, sha256 {summary['sha256']}")
