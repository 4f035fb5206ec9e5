"""`bearingdyn waterfall`: short-time spectra of a run-up against speed, and order tracking."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, echo_json, figure_output, reports_errors, write_figure
from analysis.cli.records import (
    BearingOption,
    ChannelOption,
    FsOption,
    RpmOption,
    TachoOption,
    record_options,
    run_or_record,
)


@app.command()
@reports_errors
def waterfall(
    run_file: Annotated[Path, typer.Argument(
        help="netCDF file of a run whose speed changes (`bearingdyn simulate --speed-rpm "
             "A:B` or a speed table), or a measured run-up (--channel, with --tacho or --rpm "
             "TABLE.csv).", metavar="RUN|RECORD")],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.",
                                                callback=figure_output)] = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the named lines' amplitudes against speed (and with --orders "
                       "the order peaks) as JSON.")] = False,
    orders: Annotated[bool, typer.Option(
        "--orders", help="Order tracking: also the spectrum of the run resampled in shaft "
                         "angle, whose lines stand at fixed orders.")] = False,
    var: Annotated[str | None, typer.Option(
        "--var", help="State variable (default: the first body's x).")] = None,
    window: Annotated[float | None, typer.Option(
        "--window", help="Window of the short-time spectra, s (default: the smear of the "
                         "VC+X line one bin).")] = None,
    samples_per_rev: Annotated[int | None, typer.Option(
        "--samples-per-rev", help="Angle samples per revolution of --orders (default: as "
                                  "many as the record has at its top speed).")] = None,
    channel: ChannelOption = None,
    tacho: TachoOption = None,
    rpm: RpmOption = None,
    bearing: BearingOption = None,
    fs: FsOption = None,
):
    """Waterfall of a run-up or coast-down: short-time amplitude spectra against speed with
    the X, 2X, VC, VC±X, 2VC… and defect-order lines (FTF, BPFI, BSF) drawn and named;
    --orders adds the order spectrum. Without -o or --json, prints each line's largest
    amplitude and the speed where it occurs. A measured record's channel (--channel) runs
    at the speed of its tacho (--tacho) or a speed table (--rpm TABLE.csv); --bearing
    draws its defect orders."""
    from analysis.signal.orders import order_peaks, order_spectrum
    from analysis.signal.waterfall import line_tracks
    from analysis.signal.waterfall import waterfall as compute

    ds, chosen = run_or_record(run_file, record_options(channel, fs, rpm, tacho, bearing),
                               var, command="waterfall", changing_speed=True)
    var = var or (chosen[0] if chosen else None)
    if orders:  # the angle grid's size judged before any spectrum is computed
        from analysis.signal.orders import check_samples_per_rev

        check_samples_per_rev(ds, samples_per_rev)
    wf = compute(ds, var, window)
    spectrum = order_spectrum(ds, wf.attrs["variable"], samples_per_rev) if orders else None
    tracks = line_tracks(wf)
    peaks = order_peaks(spectrum) if spectrum is not None else []
    if output:
        from analysis.reports.waterfall_plots import waterfall_figure

        write_figure(waterfall_figure(wf, spectrum), output, err=as_json)
    if as_json:
        _json(ds, wf, tracks, spectrum, peaks)
    else:
        _print(wf, tracks, spectrum, peaks)


def _json(ds, wf, tracks: dict, spectrum, peaks) -> None:
    """`waterfall --json`: the lines' amplitudes against speed (and the order peaks)."""
    from analysis.provenance import provenance

    report = {"variable": wf.attrs["variable"], "units": wf.attrs["units"],
              "window_s": wf.attrs["window_s"], "bin_hz": wf.attrs["bin_hz"],
              "lines": [{"name": name, **track} for name, track in tracks.items()]}
    if spectrum is not None:
        report["orders"] = {"order_bin": spectrum.attrs["order_bin"],
                            "samples_per_rev": spectrum.attrs["samples_per_rev"],
                            "peaks": [p.as_dict() for p in peaks]}
    echo_json({**report, "provenance": provenance(ds)}, indent=2)


def _print(wf, tracks: dict, spectrum, peaks) -> None:
    """Each line's largest amplitude and the speed where it occurs; the order peaks."""
    unit = wf.attrs["units"]
    typer.echo(f"waterfall of {wf.attrs['variable']}: {len(wf['time'])} windows of "
               f"{wf.attrs['window_s'] * 1e3:.3g} ms, bin {wf.attrs['bin_hz']:.3g} Hz, "
               f"{float(wf['speed_rpm'].min()):.0f}…{float(wf['speed_rpm'].max()):.0f} rpm")
    width = max((len(name) for name in tracks), default=4)
    typer.echo(f"{'line':>{width}} {'order':>8} {'largest':>11}       at (rpm)")
    for name, track in tracks.items():
        k = max(range(len(track["amplitude"])), key=track["amplitude"].__getitem__)
        typer.echo(f"{name:>{width}} {track['order']:8.4f} {track['amplitude'][k]:11.3e} {unit:<4} "
                   f"{track['speed_rpm'][k]:8.0f}")
    if spectrum is not None:
        typer.echo(f"order spectrum ({spectrum.attrs['samples_per_rev']} samples/rev, bin "
                   f"{spectrum.attrs['order_bin']:.3g}):")
        for p in peaks:
            typer.echo(f"{'':>{width}} {p.order:8.4f} {p.amplitude:11.3e} {unit:<4} "
                       f"{p.text}")
