"""`bearingdyn record`: measured records (``analysis.measured.records``): `record info`,
`record save`, and the options every command that reads a record shares (``--channel``,
``--fs``, ``--rpm``, ``--tacho``, ``--bearing``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import app, echo_json, netcdf_output, reports_errors
from analysis.errors import InputError

record_app = typer.Typer(no_args_is_help=True, rich_markup_mode=None, add_completion=False,
                         help="Measured records (CSV/TSV, WAV, MAT, UFF 58, TDMS, netCDF): "
                              "what a file holds (record info), and the file as a netCDF "
                              "record (record save).")
app.add_typer(record_app, name="record")

RECORD_HELP = ("A measured record (.csv/.tsv/.txt, .wav, .mat, .uff/.unv, .tdms, .nc; "
               "docs: Measured records) or a netCDF file from `bearingdyn simulate`.")
FsOption = Annotated[float | None, typer.Option(
    "--fs", metavar="HZ",
    help="Sampling rate of a record whose file states none, Hz (a CSV without a time column, a "
         "MAT-file; replaces a rate the file name states, 12k_...).")]
RpmOption = Annotated[str | None, typer.Option(
    "--rpm", metavar="RPM|TABLE.csv",
    help="A record's shaft speed, rpm, or a CSV speed table t_s,speed_rpm (replaces the "
         "file's speed).")]
TachoOption = Annotated[str | None, typer.Option(
    "--tacho", metavar="CHANNEL",
    help="A record's once-per-revolution tacho channel (name or pattern): its pulses give the "
         "speed.")]
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
        echo_json(summary, indent=2)
        return
    saved = "" if summary["file"] == summary["source_file"] else \
        f" (saved from {summary['source_file']})"
    typer.echo(f"{summary['file']}{saved}: {len(summary['channels'])} channel(s), "
               f"{summary['sample_rate_hz']:g} Hz ({summary['sample_rate_source']}), "
               f"{summary['samples']} samples = {summary['duration_s']:.4g} s")
    typer.echo(f"speed: {summary['speed']}")
    width = max(len(c["name"]) for c in summary["channels"])
    for c in summary["channels"]:
        typer.echo(f"  {c['name']:<{width}}  {c['units']:<6} {c['original_name']:<16} "
                   f"rms {c['rms']:.4g}, range {c['min']:.4g} … {c['max']:.4g}")
    typer.echo(f"reader {summary['reader']}, sha256 {summary['sha256']}")


@record_app.command("save")
@reports_errors
def save(
    record: Annotated[Path, typer.Argument(help=RECORD_HELP.split(" or a netCDF")[0] + ".",
                                           metavar="RECORD")],
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                         callback=netcdf_output)],
    channel: Annotated[list[str] | None, typer.Option(
        "--channel", metavar="CHANNEL", help="Keep only these channels (name or pattern), "
                                             "repeatable (default: all).")] = None,
    fs: FsOption = None,
    rpm: RpmOption = None,
    tacho: TachoOption = None,
    scale: ScaleOption = None,
    units: UnitsOption = None,
):
    """Write a record as bearingdyn's netCDF record (rate, units, scale and speed given once,
    provenance kept): every command, and the API's read_record, reads it back as it is."""
    from analysis.io import save_dataset
    from analysis.measured.records import SPEED, pick_channel, read_record

    data = read_record(record, fs=fs, rpm=rpm, tacho=tacho, scale=scale, units=units)
    if channel:
        keep = [pick_channel(data, c) for c in channel]
        keep += [data.attrs["tacho_channel"]] if "tacho_channel" in data.attrs else []
        data = data[list(dict.fromkeys(keep)) + ([SPEED] if SPEED in data else [])]
    save_dataset(data, output)
    typer.echo(f"wrote {output}: {', '.join(n for n in data.data_vars if n != SPEED)} at "
               f"{data.attrs['sample_rate_hz']:g} Hz, {data.sizes['t']} samples")


ChannelsOption = Annotated[list[str] | None, typer.Option(
    "--channel", metavar="CHANNEL", help="A measured record's channel, by name or pattern "
                                         "(--channel DE picks X105_DE_time), repeatable.")]
ChannelOption = Annotated[str | None, typer.Option(
    "--channel", metavar="CHANNEL", help="A measured record's channel, by name or pattern "
                                         "(--channel DE picks X105_DE_time).")]
BearingOption = Annotated[str | None, typer.Option(
    "--bearing", help="A measured record's bearing, whose defect frequencies name the lines: "
                      "a catalogue name (6205-cwru, 6203-cwru, 6205-seed), "
                      "d=MM,D=MM,z=BALLS[,angle=DEG] or a model's name.")]


@dataclass(frozen=True)
class RecordOptions:
    """The record options a command was given (None: not given)."""

    channel: tuple[str, ...] = ()
    fs: float | None = None
    rpm: str | None = None
    tacho: str | None = None
    bearing: str | None = None

    def given(self) -> list[str]:
        """The options given, as typed (``--channel``, ``--rpm``, …)."""
        return [f"--{name}" for name in ("channel", "fs", "rpm", "tacho", "bearing")
                if getattr(self, name) not in (None, ())]


def record_options(channel: list[str] | str | None, fs: float | None, rpm: str | None,
                   tacho: str | None, bearing: str | None) -> RecordOptions:
    """The record options of a command's arguments."""
    chosen = () if channel is None else ((channel,) if isinstance(channel, str)
                                         else tuple(channel))
    return RecordOptions(chosen, fs, rpm, tacho, bearing)


def run_or_record(path: Path, options: RecordOptions, var: list[str] | str | None, *,
                  command: str, needs_bearing: bool = False, si: bool = False,
                  changing_speed: bool | None = False):
    """``(dataset, channels)`` of a command's file: a simulated run as before
    (``load_dataset``; channels ``()``: the run's ``--var``), refused with a record option;
    or a measured record (``analysis.measured.runs.record_run``) with its channels chosen
    by ``--channel``, its speed and ``--bearing`` (needed with ``needs_bearing``), refused
    with ``--var``."""
    from analysis.measured.runs import is_record_file, open_record_run

    if not is_record_file(path):
        if options.given():
            raise InputError(f"{options.given()[0]}: only for a measured record; '{path}' is "
                             "a simulated run (choose its variables with --var)")
        from analysis.provenance import load_dataset

        return load_dataset(path), ()
    if var:
        raise InputError(f"--var: '{path}' is a measured record: choose its channels with "
                         "--channel")
    if needs_bearing and options.bearing is None:
        raise InputError(f"--bearing: {command} names a measured record's lines by a "
                         "bearing's defect frequencies; give --bearing NAME (6205-cwru, "
                         "6203-cwru, 6205-seed, d=MM,D=MM,z=BALLS or a model's name)")
    ds = open_record_run(path, options.channel or None, fs=options.fs, rpm=options.rpm,
                         tacho=options.tacho, bearing=options.bearing, si=si,
                         changing_speed=changing_speed, what=command)
    return ds, tuple(str(ds.attrs["state_names"]).split())


def record_figure(option: str | None, path: Path, options: RecordOptions):
    """The figure of `plot --orbit` or `plot --full-spectrum` of a measured record's two
    channels (proximity probes, in SI: µm drawn as a run's m), with its full spectrum's
    lines printed; any other figure of a record refused."""
    if option not in ("--orbit", "--full-spectrum"):
        raise InputError(f"plot: '{path}' is a measured record: draw two of its channels with "
                         "--orbit or --full-spectrum (--channel X --channel Y); its spectrum "
                         "is `bearingdyn spectrum`")
    if len(options.channel) != 2:
        raise InputError(f"--channel: {option} of a measured record takes two channels "
                         f"(--channel X --channel Y), got {len(options.channel)}")
    ds, (x, y) = run_or_record(path, options, None, command=f"plot {option}", si=True,
                               changing_speed=None if option == "--orbit" else False)
    if option == "--orbit":
        from analysis.reports.orbit_plots import orbit_figure

        return orbit_figure(ds, x, y)
    from analysis.reports.orbit_plots import full_spectrum_figure
    from analysis.signal.full_spectrum import full_spectrum_peaks

    peaks = full_spectrum_peaks(ds, x, y)
    typer.echo(f"full spectrum of {x} + i·{y}: + forward whirl, - backward")
    for p in peaks:
        typer.echo(f"{p.whirl:>8} {p.signed_frequency_hz:15.2f} {p.amplitude:10.3e} "
                   f"{ds[x].attrs.get('units', '')} {p.name}")
    return full_spectrum_figure(ds, x, y, peaks)
