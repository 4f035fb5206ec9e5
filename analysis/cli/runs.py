"""Commands on one run: `simulate`, `spectrum`, `poincare` and `plot`."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    DtOption,
    ModelArgument,
    NBallsOption,
    SetOption,
    SpeedOption,
    app,
    echo_json,
    figure_output,
    frequency_words,
    netcdf_output,
    parse_n_balls,
    reports_errors,
    run_speed,
    write_figure,
)
from analysis.cli.records import (
    BearingOption,
    ChannelsOption,
    FsOption,
    RpmOption,
    TachoOption,
    record_figure,
    record_options,
    run_or_record,
)
from analysis.errors import InputError, check_count


@app.command()
@reports_errors
def simulate(
    model: ModelArgument,
    output: Annotated[Path, typer.Option("-o", "--output", help="netCDF file to write.",
                                         callback=netcdf_output)],
    n_balls: NBallsOption = None,
    speed_rpm: SpeedOption = None,
    sets: SetOption = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time, s.")] = None,
    transient: Annotated[float | None, typer.Option(help="Dropped initial time, s.")] = None,
    dt: DtOption = None,
    method: Annotated[str, typer.Option(help="rk4 (fixed step) or cvodes.")] = "rk4",
    save_every: Annotated[int, typer.Option(help="Keep every n-th step.")] = 1,
    sample_rate: Annotated[float | None, typer.Option(
        "--sample-rate", help="Save at this rate, Hz (a record's, e.g. 12000): sets the step "
                              "(at most --dt or the spec's) and --save-every so that their "
                              "product is 1/rate.")] = None,
    no_compile: Annotated[bool, typer.Option(
        "--no-compile", help="Run RK4 in the CasADi VM instead of compiled C.")] = False,
):
    """Integrate a model and write its motion (every state variable over t) to netCDF.

    RK4 runs stream to the file block by block (any length in constant memory; --save-every
    decimates on write); CVODES runs are written when done. --sample-rate HZ picks dt <= the
    largest step and save_every with dt * save_every = 1/HZ exactly (a record's rate)."""
    import h5netcdf

    from analysis.integrate.simulate import simulate as run
    from analysis.integrate.simulate import simulate_to_file
    from analysis.integrate.speed_profile import describe_speed
    from analysis.io import save_dataset
    from analysis.model import balls_text
    from analysis.provenance import state_names

    params, profile = run_speed(speed_rpm, sets)
    if sample_rate is not None:
        dt, save_every = rate_steps(model, sample_rate, dt, save_every)
    start = time.perf_counter()
    options = dict(duration=duration, transient=transient, dt=dt, save_every=save_every,
                   compiled=not no_compile, speed_profile=profile, **params)
    balls = parse_n_balls(n_balls)
    if method == "rk4":
        simulate_to_file(model, output, balls, **options)
    else:
        save_dataset(run(model, balls, method=method, **options), output)
    wall = time.perf_counter() - start
    with h5netcdf.File(output, "r") as f:  # the file's ends only: a long run stays on disk
        attrs, times = dict(f.attrs), f.variables["t"]
        t = float(times[0]), float(times[-1])
        speed = describe_speed(attrs)
        typer.echo(f"wrote {output}: {attrs['model']}, {balls_text(attrs)}, {speed}"
                   f"t = {t[0]:g}…{t[1]:g} s ({times.shape[0]} samples), {method} dt = "
                   f"{attrs['dt']:g} s, wall {wall:.2f} s; variables "
                   f"{', '.join(state_names(attrs))}")
    if sample_rate is not None:
        typer.echo(f"saved at {sample_rate:g} Hz: every {save_every} steps of {dt:.7g} s")
    if profile is not None:
        typer.echo(kept_speeds(attrs, t))
    if profile is None:  # a bearing that carries no load (issue 32)
        from analysis.stability.statics import static_load_note

        if (note := static_load_note(model, balls, **params)) is not None:
            typer.echo(note)


def rate_steps(model: str, rate_hz: float, dt: float | None,
               save_every: int) -> tuple[float, int]:
    """``(dt, save_every)`` of ``--sample-rate``: a step at most ``--dt`` (default the spec's)."""
    from analysis.integrate.plan import steps_for_rate
    from analysis.model import load_model

    if save_every != 1:
        raise InputError("--sample-rate: sets --save-every itself; give one of them, got "
                         f"--save-every {save_every}")
    largest = load_model(model).simulation_defaults["dt"] if dt is None else dt
    try:
        return steps_for_rate(rate_hz, largest)
    except InputError as err:
        raise InputError(f"--{err}".replace("--sample_rate", "--sample-rate")) from None


def kept_speeds(attrs, t: tuple[float, float]) -> str:
    """One line: the speeds (rpm) a ramped run's file holds over its times ``t`` (s), and
    those its transient dropped (issue 32: a 1 s transient silently dropped 1000–3250 rpm
    of a run-up)."""
    from analysis.integrate.speed_profile import profile_of

    profile = profile_of(attrs)
    knots = attrs["speed_profile_t"]
    n = profile.speed([0.0, t[0], t[1]], float(knots[-1]))
    line = f"kept speeds {n[1]:.0f} → {n[2]:.0f} rpm (t = {t[0]:g}…{t[1]:g} s)"
    if t[0] > 0:
        line += (f"; the transient dropped {n[0]:.0f} → {n[1]:.0f} rpm (--transient 0 "
                 "keeps the whole ramp)")
    return line


EnvelopeOption = Annotated[bool, typer.Option(
    "--envelope", help="Envelope spectrum: band-pass, Hilbert envelope, peaks named by the "
                       "defect frequencies (BPFO, BPFI, 2BSF, BPFI-X, …).")]
BandOption = Annotated[str | None, typer.Option(
    "--band", help="Pass band LO:HI in Hz of --envelope (default: the band of largest "
                   "spectral kurtosis), or 'resonance': the band of largest kurtosis among "
                   "those holding a structural resonance of the model.")]
FaultsOption = Annotated[bool, typer.Option(
    "--faults", help="Name the peaks by the defect frequencies (FTF, BPFO, BPFI, BSF, "
                     "harmonics, sidebands) instead of X and VC.")]
NoiseOption = Annotated[float | None, typer.Option(
    "--noise", metavar="SNR_DB",
    help="Add white Gaussian noise to the analysed variables first, SNR_DB below each one's "
         "power (0: noise std equal to the signal's); seeded, recorded in the JSON "
         "provenance.")]
NoiseSeedOption = Annotated[int, typer.Option(
    "--noise-seed", help="Seed of --noise's generator (numpy default_rng).")]


@app.command()
@reports_errors
def spectrum(
    run_file: Annotated[Path, typer.Argument(
        help="netCDF file from `bearingdyn simulate`, or a measured record (--channel).",
        metavar="RUN|RECORD")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the peaks as JSON.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.",
                                                callback=figure_output)] = None,
    max_peaks: Annotated[int, typer.Option(help="Peaks per variable.")] = 8,
    var: Annotated[list[str] | None, typer.Option(
        "--var", help="State variable to analyse, repeatable (default: the first body's "
                      "displacements, x and y).")] = None,
    envelope: EnvelopeOption = False,
    band: BandOption = None,
    faults: FaultsOption = False,
    noise: NoiseOption = None,
    noise_seed: NoiseSeedOption = 0,
    channel: ChannelsOption = None,
    bearing: BearingOption = None,
    rpm: RpmOption = None,
    tacho: TachoOption = None,
    fs: FsOption = None,
):
    """Labelled spectral peaks (X, VC, VC−X, …; VC[left], VC[right] for several bearings)
    of a run's displacements or of any state variables; with --envelope the envelope
    spectrum, named by the defect frequencies; with --noise SNR_DB after adding seeded
    white noise. A measured record's channels (--channel) are named by --bearing's defect
    frequencies at the record's speed (--rpm, --tacho)."""
    from analysis.provenance import displacement_names
    from analysis.signal.spectrum import peak_table

    passband = _spectrum_options(band, envelope, noise, noise_seed)
    ds, chosen = run_or_record(run_file, record_options(channel, fs, rpm, tacho, bearing), var,
                               command="spectrum", needs_bearing=envelope or faults)
    variables = tuple(var) if var else chosen or displacement_names(ds)
    for name in variables:
        if name not in ds.data_vars:
            raise InputError(f"--var: no state variable {name!r} in this run; variables: "
                             f"{', '.join(map(str, ds.data_vars))}")
    if noise is not None:
        from analysis.signal.noise import add_noise

        ds = add_noise(ds, noise, noise_seed, variables)
        if not as_json:
            typer.echo(f"white noise added to {', '.join(variables)}: SNR {noise:g} dB, "
                       f"seed {noise_seed}")
    if envelope:
        _envelope_spectrum(ds, variables, passband, max_peaks, as_json, output)
        return
    peaks = peak_table(ds, variables, max_peaks=max_peaks,
                       vocabulary="fault" if faults else "shaft")
    _say_peaks(ds, variables, peaks, faults, as_json)
    if output:
        from analysis.reports.plots import save_figure, spectrum_figure

        save_figure(spectrum_figure(ds, variables, peaks=peaks), output)
        typer.echo(f"wrote {output}", err=as_json)


def _say_peaks(ds, variables, peaks, faults: bool, as_json: bool) -> None:
    """The frequencies and the named peaks of `spectrum`, as lines or as JSON."""
    if not as_json:
        typer.echo(frequency_words(ds.attrs))
        _print_peaks(ds, variables, peaks)
        return
    from analysis.provenance import cage_frequencies, provenance, vc_frequencies
    from analysis.signal.spectrum import fault_frequencies

    report = {"shaft_hz": ds.attrs.get("shaft_hz"), "vc_hz": ds.attrs.get("vc_hz"),
              "vc": vc_frequencies(ds.attrs), "cage": cage_frequencies(ds.attrs)}
    if faults:
        report["faults"] = fault_frequencies(ds.attrs)
    echo_json({**report, "peaks": [p.as_dict() for p in peaks],
               "provenance": provenance(ds)}, indent=2)


def _typed(name: str) -> bool:
    """Whether the option ``name`` (its parameter name) was typed on the command line."""
    from analysis.cli.common import click

    context = click.globals.get_current_context(silent=True)
    return context is not None and context.get_parameter_source(name) \
        == click.core.ParameterSource.COMMANDLINE


def _spectrum_options(band: str | None, envelope: bool, noise: float | None,
                      noise_seed: int) -> tuple[float, float] | str | None:
    """The pass band of ``--band`` (None: chosen by kurtosis), every option of ``spectrum``
    checked before the run is read."""
    passband = None
    if noise is None and _typed("noise_seed"):
        raise InputError(f"--noise-seed: only with --noise SNR_DB (it seeds that noise), got "
                         f"--noise-seed {noise_seed} without --noise")
    if band is not None:
        from analysis.signal.envelope import parse_band

        if not envelope:
            raise InputError("--band: only with --envelope")
        passband = parse_band(band)
    if noise is not None:
        from analysis.signal.noise import check_snr

        check_snr(noise)
        check_count("--noise-seed", noise_seed, 0)
    return passband


def _print_peaks(ds, variables, peaks) -> None:
    width = max(3, *(len(v) for v in variables), *(len(p.direction) for p in peaks))
    typer.echo(f"{'var':>{width}} {'frequency (Hz)':>15} {'amplitude':>14}  label")
    for p in peaks:
        source = p.direction.removesuffix("_envelope")
        unit = ds[source].attrs.get("units", "") if source in ds else ""
        also = f" (ambiguous: also {', '.join(p.also)}, within one bin)" if p.also else ""
        typer.echo(f"{p.direction:>{width}} {p.frequency_hz:15.2f} "
                   f"{p.amplitude:10.3e} {unit:<4} {p.name}{also}")


def _note_matters(peaks, note: str) -> bool:
    """Whether the band's note is printed: a BPFO or VC line named, a structural resonance
    in the band, or a band of round-off."""
    return any(w in n for p in peaks for n in (p.label or "", *p.also)
               for w in ("BPFO", "VC")) or "holds the structural" in note \
        or "round-off, not the response" in note


def _envelope_spectrum(ds, variables, passband, max_peaks, as_json, output) -> None:
    """`spectrum --envelope`: per variable the band, then the named envelope peaks."""
    from analysis.signal.envelope import envelope_peaks, envelope_spectrum, names_withheld
    from analysis.signal.spectrum import fault_frequencies

    faults = fault_frequencies(ds.attrs)
    if not faults:
        raise InputError(f"{ds.attrs.get('model', 'run')}: --envelope needs a bearing's defect "
                         "frequencies (FTF, BPFO, BPFI, BSF); this run has no bearing")
    results = []
    for name in variables:
        peaks, chosen = envelope_peaks(ds, name, passband, max_peaks=max_peaks)
        results.append((name, peaks, chosen))
    if as_json:
        from analysis.provenance import provenance

        echo_json({
            "shaft_hz": ds.attrs.get("shaft_hz"), "faults": faults,
            "provenance": provenance(ds),
            "envelopes": [{"var": name, "band_hz": [chosen.low_hz, chosen.high_hz],
                           "band_chosen": chosen.chosen, "kurtosis": chosen.kurtosis,
                           "edge_s": chosen.edge_s, "resonances_hz": list(chosen.resonances_hz),
                           "note": chosen.note, "peaks": [p.as_dict() for p in peaks]}
                          for name, peaks, chosen in results]}, indent=2)
    else:
        from analysis.reports.fault_plots import fault_words

        typer.echo(f"X = {float(ds.attrs['shaft_hz']):.2f} Hz, {fault_words(ds.attrs)}")
        for name, peaks, chosen in results:
            how = {"kurtosis": "spectral kurtosis", "user": "given",
                   "resonance": "spectral kurtosis, among the bands holding a structural "
                                "resonance"}[chosen.chosen]
            typer.echo(f"envelope of {name}: band {chosen.low_hz:g}:{chosen.high_hz:g} Hz "
                       f"({how}, kurtosis {chosen.kurtosis:.3g}, {chosen.edge_s * 1e3:.3g} ms "
                       "of filter start-up left out at each end)")
            _print_peaks(ds, variables, peaks)
            if withheld := names_withheld(chosen, ds.attrs):
                typer.echo(withheld)
            elif _note_matters(peaks, chosen.note):
                typer.echo(f"note: {chosen.note}")
        typer.echo("lines are named only 15 dB or more above the median of the 100 bins "
                   "on either side (the noise floor)")
    if output:
        from analysis.reports.fault_plots import envelope_figure
        from analysis.reports.plots import save_figure

        name, peaks, chosen = results[0]
        spectrum = envelope_spectrum(ds, name, (chosen.low_hz, chosen.high_hz))
        save_figure(envelope_figure(spectrum, peaks, chosen), output)
        typer.echo(f"wrote {output} (envelope of {name})", err=as_json)


@app.command()
@reports_errors
def poincare(
    run_file: Annotated[Path, typer.Argument(help="netCDF file from `bearingdyn simulate`.")],
    section: Annotated[str, typer.Option(
        help="shaft, cage or vc period (of the first bearing), cage[BEARING], vc[BEARING], "
             "or param:NAME (the period in s held by parameter NAME, e.g. "
             "param:forcing_period).")] = "shaft",
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Figure file.",
                                                callback=figure_output)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the points as JSON.")] = False,
    x: Annotated[str | None, typer.Option(
        "--x", help="State variable on the figure's horizontal axis (default: each "
                    "displacement of the first body, against its velocity).")] = None,
    y: Annotated[str | None, typer.Option(
        "--y", help="State variable on the vertical axis (default: the velocity of --x).")
    ] = None,
):
    """Stroboscopic Poincaré section of a run (once per shaft, cage, VC or parameter
    period); every state variable is sampled."""
    from analysis.provenance import displacement_names, load_dataset, state_names
    from analysis.signal.poincare import SECTION_SYNTAX, parse_section, poincare_section

    try:
        parse_section(section)  # the syntax, before the file is read
    except InputError:
        raise InputError(f"--section: must be {SECTION_SYNTAX}, got {section!r}") from None
    ds = load_dataset(run_file)
    names = state_names(ds)
    _check_axes(names, x, y)
    try:
        pts = poincare_section(ds, section)
    except InputError as exc:
        if str(exc).startswith("section: must be"):
            raise InputError(f"--section: must be {SECTION_SYNTAX}, got {section!r}") from None
        raise
    shown = (x, y) if x else displacement_names(ds)
    if as_json:
        from analysis.provenance import provenance

        echo_json({**{v: pts[v].values.tolist() for v in ("t", *names)},
                   "provenance": provenance(ds)}, indent=None)
    else:
        ranges = ", ".join(f"{v} in [{float(pts[v].min()):.4e}, {float(pts[v].max()):.4e}] "
                           f"{pts[v].attrs.get('units', '')}".rstrip()
                           for v in shown if v is not None)
        typer.echo(f"{pts.sizes['k']} points on the {section} section "
                   f"(period {pts.attrs['section_period_s'] * 1e3:.4f} ms); {ranges}")
    if output:
        from analysis.reports.plots import poincare_figure, save_figure

        save_figure(poincare_figure(ds, section, [(x, y)] if x else None), output)
        typer.echo(f"wrote {output}", err=as_json)


def _check_axes(names: list[str], x: str | None, y: str | None) -> None:
    """``--x`` and ``--y`` name state variables of the run, and ``--y`` comes with ``--x``."""
    for option, name in (("--x", x), ("--y", y)):
        if name is not None and name not in names:
            raise InputError(f"{option}: no state variable {name!r} in this run; "
                             f"variables: {', '.join(names)}")
    if y is not None and x is None:
        raise InputError("--y: give --x too")


@app.command()
@reports_errors
def plot(
    result: Annotated[Path, typer.Argument(
        help="Any bearingdyn netCDF result, or a measured record (--orbit or --full-spectrum "
             "of --channel X --channel Y).", metavar="RESULT|RECORD")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Figure file (PNG, PDF, SVG).",
                                         callback=figure_output)],
    var: Annotated[list[str] | None, typer.Option(
        "--var", help="State variable to draw, repeatable (a diagram's section points, or a "
                      "run's spectra; default: the first body's displacements; with --orbit "
                      "or --full-spectrum two: X and Y).")] = None,
    orbit: Annotated[bool, typer.Option(
        "--orbit", help="A run's orbits: each body's centre and each bearing's relative "
                        "displacement (µm), the clearance circle, a mark once per "
                        "revolution.")] = False,
    full_spectrum: Annotated[bool, typer.Option(
        "--full-spectrum", help="A run's full spectrum of x + i·y: forward whirl at "
                                "positive frequencies, backward at negative; prints its "
                                "named lines.")] = False,
    bode: Annotated[bool, typer.Option(
        "--bode", help="A sweep's Bode plot: 1X amplitude and phase lag against the "
                       "swept parameter.")] = False,
    polar: Annotated[bool, typer.Option(
        "--polar", help="A sweep's polar plot of the 1X amplitude and phase lag.")] = False,
    node: Annotated[int | None, typer.Option(
        "--node", help="With --orbit, a flexible model's run: the orbit of this shaft node "
                       "(0 at the left end), from the reduced state.")] = None,
    channel: ChannelsOption = None,
    rpm: RpmOption = None,
    tacho: TachoOption = None,
    fs: FsOption = None,
):
    """Draw the natural figure of a result file (run, branch, diagram or chart), or a run's
    orbits (at any shaft node of a flexible model: --node) or full spectrum, or a sweep's
    Bode or polar plot; a measured record's orbit or full spectrum of two channels
    (--channel X --channel Y: proximity probes)."""
    from analysis.io import open_result
    from analysis.measured.runs import is_record_file
    from analysis.reports.plots import any_figure

    chosen = [name for name, on in (("--orbit", orbit), ("--full-spectrum", full_spectrum),
                                    ("--bode", bode), ("--polar", polar)) if on]
    if len(chosen) > 1:
        raise InputError(f"{chosen[1]}: give one of --orbit, --full-spectrum, --bode, "
                         f"--polar, got {' and '.join(chosen)}")
    if node is not None and chosen != ["--orbit"]:
        raise InputError(f"--node: only with --orbit (a flexible model's shaft node), got "
                         f"--node {node} with {' and '.join(chosen) or 'no --orbit'}")
    options = record_options(channel, fs, rpm, tacho, None)
    if options.given() or is_record_file(result, foreign=False):
        if node is not None:
            raise InputError(f"--node: only for a flexible model's run, '{result}' is a "
                             "measured record")
        write_figure(record_figure(chosen[0] if chosen else None, result, options), output)
        return
    if not chosen:
        write_figure(any_figure(open_result(result), var, result), output)
        return
    write_figure(_special_figure(chosen[0], result, var, node), output)


def _special_figure(option: str, result: Path, var: list[str] | None,
                    node: int | None = None):
    """The figure of `plot --orbit`, `--full-spectrum`, `--bode` or `--polar` (lines of a
    full spectrum printed); every input checked before the figure is drawn."""
    from analysis.io import open_result

    data = open_result(result)
    if option in ("--bode", "--polar"):
        from analysis.reports.bode_plots import bode_figure, polar_figure

        draw = bode_figure if option == "--bode" else polar_figure
        return draw(data, var, str(result))
    from analysis.provenance import as_run

    kind = data.attrs.get("kind")
    if isinstance(kind, str) and "model" in data.attrs:
        raise InputError(f"{option}: needs a run (from `bearingdyn simulate`), got a {kind} "
                         f"result: '{result}'")
    ds = as_run(data, result)
    if var is not None and len(var) != 2:
        raise InputError(f"--var: {option} takes two coordinates (--var X --var Y), got "
                         f"{len(var)}")
    x, y = var if var else (None, None)
    if option == "--orbit":
        from analysis.reports.orbit_plots import orbit_figure

        return orbit_figure(ds, x, y, node)
    from analysis.reports.orbit_plots import full_spectrum_figure
    from analysis.signal.full_spectrum import full_spectrum_peaks, orbit_pair

    x, y = orbit_pair(ds, x, y)
    peaks = full_spectrum_peaks(ds, x, y)
    typer.echo(f"full spectrum of {x} + i·{y} ({frequency_words(ds.attrs)}): "
               f"+ forward whirl, - backward")
    typer.echo(f"{'whirl':>8} {'frequency (Hz)':>15} {'amplitude':>14}  label")
    unit = ds[x].attrs.get("units", "")
    for p in peaks:
        typer.echo(f"{p.whirl:>8} {p.signed_frequency_hz:15.2f} {p.amplitude:10.3e} "
                   f"{unit:<4} {p.name}")
    _echo_unnamed(ds, x, y, unit)
    return full_spectrum_figure(ds, x, y, peaks)


def _echo_unnamed(ds, x: str, y: str, unit: str) -> None:
    """The strongest unnamed lines of a full spectrum and why they have no name."""
    from analysis.signal.full_spectrum import unnamed_lines, unnamed_reason

    by_reason: dict[str, list[str]] = {}
    for p in unnamed_lines(ds, x, y):
        by_reason.setdefault(str(unnamed_reason(p, ds)), []).append(
            f"{p.signed_frequency_hz:.2f} Hz ({p.amplitude:.3g} {unit})")
    for reason, lines in by_reason.items():
        typer.echo(f"strongest unnamed lines: {', '.join(lines)}: {reason}")
