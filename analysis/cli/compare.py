"""`bearingdyn compare`: a measured record against a simulated run, in the order domain."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, echo_json, figure_output, reports_errors, write_figure


@app.command()
@reports_errors
def compare(
    record_file: Annotated[Path, typer.Argument(
        metavar="RECORD", help="Measured record (MAT, CSV/TSV, WAV, UFF, TDMS, netCDF).")],
    run_file: Annotated[Path, typer.Argument(
        metavar="RESULT", help="netCDF file of a simulated run (`bearingdyn simulate`).")],
    channel: Annotated[str | None, typer.Option(
        "--channel", help="The record's channel: a name or a pattern (DE picks X105_DE_time); "
                          "default: its only channel.")] = None,
    var: Annotated[str | None, typer.Option(
        "--var", help="The run's state variable (default: its first body's x).")] = None,
    bearing: Annotated[str | None, typer.Option(
        "--bearing", help="The record's bearing: a catalogue name (6205-cwru, 6203-cwru, "
                          "6205-seed), d=MM,D=MM,z=N[,angle=DEG] or a model name (default: "
                          "the run's geometry).")] = None,
    rpm: Annotated[float | None, typer.Option(
        "--rpm", help="The record's shaft speed, rpm (default: the record's own).")] = None,
    fs: Annotated[float | None, typer.Option(
        "--fs", help="The record's sampling rate, Hz, where its file states none.")] = None,
    max_order: Annotated[float, typer.Option(
        "--max-order", help="Highest order shown and searched for lines.")] = 12.0,
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the comparison (lines, spectra's bands, provenance) as "
                       "JSON.")] = False,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Figure file: the envelope and raw order spectra of both.",
        callback=figure_output)] = None,
):
    """Overlay a measured record and a simulated run in the order domain: envelope order
    spectra and raw spectra in orders of each one's shaft speed, both as accelerations in
    dB re their largest line; name the lines both have and those only one has."""
    from analysis.measured.compare import compare as run_compare
    from analysis.measured.records import read_record
    from analysis.provenance import load_dataset

    record = read_record(record_file, fs=fs, channel=channel)
    result = load_dataset(run_file)
    comparison = run_compare(record, result, channel=channel, result_var=var,
                             bearing=bearing, rpm=rpm, max_order=max_order)
    if output:
        from analysis.reports.compare_plots import compare_figure

        write_figure(compare_figure(comparison), output, err=as_json)
    if as_json:
        echo_json(comparison.as_dict())
    else:
        print_comparison(comparison)


def print_comparison(comparison) -> None:
    """The speeds, bands and each spectrum's lines: both, record only, model only."""
    from analysis.measured.compare import SPECTRA

    prov = comparison.provenance
    typer.echo(f"record: {prov['record_signal']}")
    typer.echo(f"model:  {prov['model_signal']}")
    typer.echo(f"both as {' / '.join(sorted(set(comparison.units.values())))}, in orders of "
               f"each one's shaft speed, dB re each spectrum's largest line; lines the same "
               f"within max({comparison.tolerance:g} x order, 2 bins)")
    for kind in SPECTRA:
        rec, mod = comparison.record[kind], comparison.model[kind]
        band = ""
        if rec.band_hz is not None and mod.band_hz is not None:
            band = (f" (bands: record {rec.band_hz[0]:.0f}-{rec.band_hz[1]:.0f} Hz, model "
                    f"{mod.band_hz[0]:.0f}-{mod.band_hz[1]:.0f} Hz)")
        typer.echo(f"{kind} spectrum{band}:")
        typer.echo(f"  {'line':<18}{'record':>16}{'model':>16}  status")
        for m in (m for m in comparison.matches if m.kind == kind):
            cells = [f"{ln.order:7.3f} {ln.level_db:6.1f} dB" if ln is not None else "-"
                     for ln in (m.record, m.model)]
            typer.echo(f"  {m.name:<18}{cells[0]:>16}{cells[1]:>16}  {m.status}")
    for note in comparison.notes:
        typer.echo(f"note: {note}")


def model_check(record_file: Path, diagnosis, model: str, *, channel: str | None,
                fs: float | None, rpm: float | None, tacho: str | None):
    """``diagnose --model MODEL``: the defect model (``auto``: the verdict's) simulated at
    the record's speed, rate, bearing and band and compared with it
    (``analysis.measured.model_check.simulate_matching``)."""
    from analysis.measured.model_check import simulate_matching
    from analysis.measured.records import read_record

    record = read_record(record_file, fs=fs, channel=channel, rpm=rpm, tacho=tacho)
    return simulate_matching(diagnosis, record, None if model == "auto" else model,
                             channel=channel)


ModelCheckOption = Annotated[str | None, typer.Option(
    "--model", metavar="MODEL|auto",
    help="Also simulate a defect model at the record's speed, sample rate, bearing and band "
         "and compare it with the record (bearingdyn compare); auto: the verdict's "
         "(6205-outer-defect, 6205-inner-defect, 6205-ball-defect).")]
"""``diagnose --model``."""
