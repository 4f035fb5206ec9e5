"""`bearingdyn diagnose`: which bearing fault a measured record shows, how sure, and why
(``analysis.measured.diagnose``); a folder of records on all cores with a summary table."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, echo_json, figure_output, reports_errors, write_figure
from analysis.cli.compare import ModelCheckOption

BearingOption = Annotated[str, typer.Option(
    "--bearing", metavar="NAME",
    help="The bearing: 6205-cwru, 6203-cwru, 6205-seed (aliases 6205-2rs, 6203-2rs, 6205), "
         "a geometry d=MM,D=MM,z=BALLS[,angle=DEG] (mm, degrees) or a model's name.")]
ChannelOption = Annotated[str | None, typer.Option(
    "--channel", metavar="NAME",
    help="The channel: a name or a pattern (DE picks X105_DE_time); needed when the record "
         "has several.")]
PrewhitenOption = Annotated[str, typer.Option(
    "--prewhiten", metavar="cepstrum|ar|none",
    help="Pre-whitening before the band search: cepstrum (cepstral, the default), ar "
         "(linear prediction) or none.")]
RpmOption = Annotated[float | None, typer.Option(
    "--rpm", metavar="R", help="Shaft speed, rpm (replaces the file's speed).")]
TachoOption = Annotated[str | None, typer.Option(
    "--tacho", metavar="CHANNEL",
    help="A once-per-revolution tacho channel (name or pattern): its pulses give the speed.")]
FsOption = Annotated[float | None, typer.Option(
    "--fs", metavar="HZ",
    help="Sampling rate of a record whose file states none, Hz.")]


@app.command()
@reports_errors
def diagnose(
    record: Annotated[Path, typer.Argument(
        metavar="RECORD", help="A measured record (.csv/.tsv/.txt, .wav, .mat, .uff/.unv, "
                               ".tdms, .nc) or a folder of them.")],
    bearing: BearingOption,
    channel: ChannelOption = None,
    rpm: RpmOption = None,
    tacho: TachoOption = None,
    fs: FsOption = None,
    prewhiten: PrewhitenOption = "cepstrum",
    as_json: Annotated[bool, typer.Option("--json", help="Print the diagnosis as JSON.")] = False,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Figure file: the envelope spectrum and the kurtogram.",
        callback=figure_output)] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", help="Processes for a folder (default: all cores).")] = None,
    model: ModelCheckOption = None,
):
    """Diagnose a bearing from a measured vibration record: the speed refined on the 1X
    line, pre-whitening, the band of the fast kurtogram, the squared envelope spectrum, and
    per fault family (outer-race, inner-race, ball, cage) the lines found against theory.
    Names a fault only when its evidence is clear; otherwise 'none' and why."""
    from analysis.errors import InputError
    from analysis.measured import diagnose as dg

    if record.is_dir():
        if output is not None or model is not None:
            raise InputError(f"{'-o' if output is not None else '--model'}: one per record; "
                             "not with a folder (give a file)")
        _folder(dg.folder_jobs(record, channel=channel, bearing=bearing, rpm=rpm,
                               tacho=tacho, fs=fs, prewhiten=prewhiten), workers, as_json)
        return
    result = dg.diagnose_file(record, channel=channel, bearing=bearing, rpm=rpm, tacho=tacho,
                              fs=fs, prewhiten=prewhiten)
    check = None
    if model is not None:
        from analysis.cli.compare import model_check

        check = model_check(record, result, model, channel=result.channel, fs=fs, rpm=rpm,
                            tacho=tacho)
    if output:
        from analysis.reports.diagnose_plots import diagnose_figure

        write_figure(diagnose_figure(result), output, err=as_json)
    if as_json:
        data = result.as_dict()
        echo_json(data if check is None else {**data, "model_check": check.as_dict()})
        return
    _print(result)
    if check is not None:
        from analysis.cli.compare import print_comparison

        typer.echo(f"model check: {check.provenance['simulation']['model']} at the record's "
                   "speed, rate, bearing and band, against the record:")
        print_comparison(check)


def _folder(jobs: list, workers: int | None, as_json: bool) -> None:
    """Every record of a folder on ``workers`` processes: progress, then the table."""
    from analysis.measured import diagnose as dg

    if workers is not None:
        from analysis.errors import check_count

        check_count("--workers", workers, 1, 1024)
    results = dg.diagnose_folder(jobs, workers, None if as_json else _progress)
    if as_json:
        echo_json({"records": results})
    else:
        _print_folder(results)


def _progress(done: int, total: int, result: dict) -> None:
    name = Path(result["path"]).name
    said = result.get("verdict") or "error"
    typer.echo(f"[{done}/{total}] {name}: {said}", err=True)


def _print(result) -> None:
    """The speed, the bearing's frequencies, the band, each family's lines, the verdict."""
    from analysis.measured.bearings import frequency_table

    speed, band = result.speed, result.band
    where = result.provenance.get("source_file", "")
    typer.echo(f"{where} channel {result.channel} ({result.units}), {result.fs_hz:g} Hz, "
               f"{result.n_samples / result.fs_hz:.3g} s")
    how = (f"1X line, {speed.line_db:.1f} dB over the floor" if speed.refined
           else "nominal")
    typer.echo(f"speed: {speed.rpm:.1f} rpm ({how}; {speed.nominal_hz * 60:.1f} rpm from "
               f"{speed.source})")
    for note in result.notes:
        typer.echo(f"note: {note}")
    for row in frequency_table(result.bearing, speed.hz):
        typer.echo(row)
    typer.echo(f"band {band.low_hz:.0f}-{band.high_hz:.0f} Hz (fast kurtogram, K = "
               f"{band.kurtosis:.2f}), pre-whitening {result.prewhiten}, squared envelope "
               f"spectrum, resolution {result.resolution_hz:.3g} Hz, search window "
               f"±{result.window_relative:.1%}")
    for family in result.families.values():
        _print_family(family)
    typer.echo(f"verdict: {result.verdict} (confidence {result.confidence:.2f}): "
               f"{result.reason}")


def _print_family(family) -> None:
    state = "clear" if family.clear else "not clear"
    typer.echo(f"{family.name}: {state}, {len(family.harmonics_above)} harmonic(s) and "
               f"{len(family.sidebands_above)} sideband(s) over {family.threshold_db:.1f} dB"
               + (f"; {family.note}" if family.note else ""))
    for line in family.lines:
        if line.role == "sideband" and not line.above:
            continue
        if line.found_hz is None:
            typer.echo(f"  {line.name:>10} theory {line.theory_hz:8.2f} Hz "
                       f"({line.theory_multiple:.4f} X): {line.note or 'no line'}")
            continue
        mark = "*" if line.above else " "
        typer.echo(f"{mark} {line.name:>10} theory {line.theory_hz:8.2f} Hz "
                   f"({line.theory_multiple:.4f} X), found {line.found_hz:8.2f} Hz "
                   f"({line.found_multiple:.4f} X), {line.level_db:5.1f} dB")


def _print_folder(results: list[dict]) -> None:
    """One row per record: file, verdict, confidence, speed, band; or the error."""
    width = max(len(Path(r["path"]).name) for r in results)
    typer.echo(f"{'record':<{width}}  {'verdict':<10} {'conf.':>5} {'rpm':>7}  band (Hz)")
    for r in results:
        name = Path(r["path"]).name
        if "error" in r:
            typer.echo(f"{name:<{width}}  error: {r['error']}")
            continue
        band = r["band"]
        typer.echo(f"{name:<{width}}  {r['verdict']:<10} {r['confidence']:5.2f} "
                   f"{r['speed']['rpm']:7.1f}  {band['low_hz']:.0f}-{band['high_hz']:.0f}")
    named = sum(1 for r in results if r.get("verdict") not in (None, "none"))
    errors = sum(1 for r in results if "error" in r)
    typer.echo(f"{len(results)} record(s): {named} with a fault named, "
               f"{len(results) - named - errors} none, {errors} not diagnosed (error)")
