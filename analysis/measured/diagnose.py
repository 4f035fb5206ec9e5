"""Bearing-fault diagnosis of a measured vibration record: which fault, how sure, and why.

The method is the one of the diagnostics literature (R. B. Randall, J. Antoni, "Rolling
element bearing diagnostics—A tutorial", MSSP 25 (2011) 485–520; W. A. Smith, R. B. Randall,
"Rolling element bearing diagnostics using the Case Western Reserve University data: a
benchmark study", MSSP 64–65 (2015) 100–131):

1. **Speed.** The shaft speed from the record (its file, ``--rpm`` or a tacho), refined on
   the 1X line of the raw spectrum: the largest line within ±``SPEED_SEARCH`` of the
   nominal speed, its frequency interpolated (log-parabolic, Hann), taken when it stands
   ``SPEED_LINE_DB`` over the local floor. A nominal speed and a 1X line more than
   ``DISAGREEMENT`` apart are reported (an induction motor slips under load: the CWRU
   records' 1797 rpm is the speed noted during the test).
2. **Pre-whitening** (:mod:`analysis.measured.prewhiten`; cepstral by default).
3. **Band** of largest spectral kurtosis in the fast kurtogram
   (:mod:`analysis.signal.kurtogram`), at least 2.5 times the highest of BPFO, BPFI and
   2xBSF wide (it passes the fault's sidebands).
4. **Squared envelope spectrum** of the band: the band's analytic signal (the kurtogram's
   own filter, ``kurtogram.Spectrum.analytic``), its squared modulus with the filter's
   edges left out, and its Hann amplitude spectrum
   (:func:`analysis.signal.spectrum.amplitude_spectrum`).
5. **Evidence** per family (:mod:`analysis.measured.evidence`) and the **verdict**: a fault
   is named only when its family is clear (``evidence.MIN_HARMONICS`` harmonics above the
   family's threshold, whose false-alarm probability in noise is
   ``evidence.FAMILY_FALSE_ALARM``) and no other family is nearly as strong
   (``DOMINANCE``); otherwise "none" with the reason. A wrong name is worse than none.

Confidence (in [0, 1]) of a named fault: (1 − p)·S₁/(S₁ + S₂), p the probability that noise
alone gives the family's two strongest harmonics (``Family.false_alarm``), S₁ the family's
score (dB over the threshold, summed over its lines above it) and S₂ the next family's.
Of "none": 1 when no line of any family passes its threshold, 0.5 when some does but no
family is clear or two are equally clear (the evidence is weak or ambiguous).

The core, :func:`diagnose_signal`, takes an array, its sampling rate, the shaft speed and
a :class:`analysis.measured.bearings.Bearing`; :func:`diagnose` takes a record
(``analysis.measured.records``) and a channel.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import BearingdynError, InputError
from analysis.measured import evidence as ev
from analysis.measured import prewhiten as pw
from analysis.measured.bearings import BSF_CONVENTION, Bearing, lookup
from analysis.signal import kurtogram as kg
from analysis.signal.spectrum import amplitude_spectrum, noise_floor

SPEED_SEARCH = 0.05
"""Relative half width of the search for the 1X line around the nominal speed."""
SPEED_LINE_DB = 10.0
"""A 1X line is taken as the speed when it stands this far over the median floor of the raw
spectrum (an amplitude 3.2 times the floor: a noise bin does so with probability 2^(−10))."""
DISAGREEMENT = 0.01
"""Relative difference of the nominal speed and the 1X line that is reported."""
BAND_WIDTH_FACTOR = 2.5
"""The narrowest band searched, times the highest of BPFO, BPFI and 2xBSF."""
RESOLUTIONS_PER_FTF = 4
"""The envelope spectrum must resolve FTF/4 (FTF sidebands apart from their line, and BPFI
from BPFI ± X): a record needs at least 4/FTF seconds clear of the filter's edges."""
DOMINANCE = 2.0
"""Of two clear families, the stronger is named only when its score is this many times the
other's; otherwise none (ambiguous)."""
VERDICTS = ("outer-race", "inner-race", "ball", "cage", "none")
"""The verdicts."""


@dataclass(frozen=True)
class Speed:
    """The shaft speed used and where it comes from."""

    hz: float
    source: str
    nominal_hz: float
    refined: bool
    """Taken from the 1X line of the raw spectrum."""
    line_hz: float | None = None
    """The 1X line found (Hz), None when none stands out."""
    line_db: float | None = None
    """Its level over the local floor (dB)."""
    disagreement: float | None = None
    """(1X line − nominal)/nominal, when a 1X line was found."""
    note: str = ""

    @property
    def rpm(self) -> float:
        return self.hz * 60.0

    def as_dict(self) -> dict:
        return {"rpm": self.rpm, "hz": self.hz, "source": self.source,
                "nominal_rpm": self.nominal_hz * 60.0, "refined": self.refined,
                "line_hz": self.line_hz, "line_db": self.line_db,
                "disagreement": self.disagreement, "note": self.note}


@dataclass(frozen=True)
class BandChoice:
    """The band of the envelope (Hz), its spectral kurtosis and how it was chosen."""

    low_hz: float
    high_hz: float
    kurtosis: float
    level: float
    """log2(Nyquist/width) of the band."""
    chosen: str = "kurtogram"

    def as_dict(self) -> dict:
        return {"low_hz": self.low_hz, "high_hz": self.high_hz, "kurtosis": self.kurtosis,
                "level": self.level, "chosen": self.chosen}


@dataclass
class Diagnosis:
    """The verdict on one channel of a record and everything it rests on."""

    verdict: str
    confidence: float
    reason: str
    families: dict[str, ev.Family]
    band: BandChoice
    speed: Speed
    bearing: Bearing
    frequencies: dict[str, float]
    prewhiten: str
    fs_hz: float
    n_samples: int
    resolution_hz: float
    channel: str = ""
    units: str = ""
    provenance: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    envelope_hz: np.ndarray | None = field(default=None, repr=False)
    envelope_amplitude: np.ndarray | None = field(default=None, repr=False)
    kurtogram: kg.Kurtogram | None = field(default=None, repr=False)

    def as_dict(self) -> dict:
        """JSON-ready: verdict, confidence, reason, per-family evidence, band, speed,
        bearing (geometry, frequencies, BSF convention), provenance."""
        return _jsonable({
            "verdict": self.verdict, "confidence": round(self.confidence, 4),
            "reason": self.reason, "channel": self.channel, "units": self.units,
            "families": {name: fam.as_dict() for name, fam in self.families.items()},
            "band": self.band.as_dict(), "speed": self.speed.as_dict(),
            "bearing": {**self.bearing.as_dict(), "frequencies_hz": self.frequencies,
                        "bsf_convention": BSF_CONVENTION},
            "method": {"prewhiten": self.prewhiten, "envelope": "squared envelope spectrum",
                       "window_relative": self.window_relative,
                       "family_false_alarm": ev.FAMILY_FALSE_ALARM,
                       "min_harmonics": ev.MIN_HARMONICS, "dominance": DOMINANCE},
            "sample_rate_hz": self.fs_hz, "n_samples": self.n_samples,
            "duration_s": self.n_samples / self.fs_hz, "resolution_hz": self.resolution_hz,
            "notes": list(self.notes), "provenance": dict(self.provenance)})

    @property
    def window_relative(self) -> float:
        return ev.REL_WINDOW + (0.0 if self.speed.refined else ev.SPEED_UNCERTAINTY)


def _jsonable(value: Any) -> Any:
    """Numpy scalars and arrays inside dicts, lists and tuples as Python values."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _raw_spectrum(values: np.ndarray, fs: float) -> tuple[np.ndarray, float]:
    """Hann amplitude spectrum of a record (unit of the record) and its bin width (Hz)."""
    ds = xr.Dataset({"v": ("t", values)}, coords={"t": np.arange(values.size) / fs})
    spectrum = amplitude_spectrum(ds, "v")
    return np.asarray(spectrum.values), float(fs / values.size)


def refine_speed(values: np.ndarray, fs: float, nominal_hz: float, source: str) -> Speed:
    """The shaft speed: the 1X line of the raw spectrum within ±``SPEED_SEARCH`` of
    ``nominal_hz`` when it stands ``SPEED_LINE_DB`` over the floor, else the nominal."""
    amplitude, df = _raw_spectrum(values, fs)
    lo = max(1, math.floor(nominal_hz * (1 - SPEED_SEARCH) / df))
    hi = min(amplitude.size - 2, math.ceil(nominal_hz * (1 + SPEED_SEARCH) / df))
    if hi - lo < 2:
        return Speed(nominal_hz, source, nominal_hz, False,
                     note="the record is too short to resolve the 1X line")
    i = lo + int(np.argmax(amplitude[lo:hi + 1]))
    floor = noise_floor(amplitude, i, ev.FLOOR_BINS)
    level = 20 * math.log10(amplitude[i] / floor) if floor > 0 and amplitude[i] > 0 else None
    local = amplitude[i] > amplitude[i - 1] and amplitude[i] >= amplitude[i + 1]
    if level is None or level < SPEED_LINE_DB or not local:
        return Speed(nominal_hz, source, nominal_hz, False, None, level,
                     note=f"no 1X line stands {SPEED_LINE_DB:g} dB over the floor within "
                          f"±{SPEED_SEARCH:.0%} of {nominal_hz * 60:.1f} rpm: the nominal "
                          f"speed is used")
    a, b, c = np.log(amplitude[i - 1:i + 2])
    denom = a - 2 * b + c
    line = (i + (0.5 * (a - c) / denom if denom < 0 else 0.0)) * df
    gap = (line - nominal_hz) / nominal_hz
    note = ""
    if abs(gap) > DISAGREEMENT:
        note = (f"the nominal speed {nominal_hz * 60:.1f} rpm ({source}) and the 1X line "
                f"({line * 60:.1f} rpm) differ by {gap:+.1%}: the 1X line is used")
    return Speed(line, source, nominal_hz, True, line, level, gap, note)


def required_seconds(bearing: Bearing, shaft_hz: float, fs: float) -> float:
    """The shortest record (s) whose envelope resolves FTF/``RESOLUTIONS_PER_FTF`` once the
    filter's edges of the narrowest band are left out."""
    table = bearing.frequencies(shaft_hz)
    narrowest = min(BAND_WIDTH_FACTOR * max(table["BPFO"], table["BPFI"], table["2xBSF"]),
                    fs / 4)
    return RESOLUTIONS_PER_FTF / table["FTF"] + 2 * kg.edge_seconds(0.0, narrowest)


def check_inputs(values: np.ndarray, fs: float, shaft_hz: float, bearing: Bearing) -> None:
    """InputError for a rate or speed that is not a positive number, a record with
    non-finite values, or one too short to resolve the defect lines at this speed."""
    if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
        raise InputError(f"--fs: the sampling rate must be a finite number > 0 Hz, got {fs}")
    if not (isinstance(shaft_hz, (int, float)) and math.isfinite(shaft_hz) and shaft_hz > 0):
        raise InputError(f"--rpm: the shaft speed must be a finite number > 0 rpm, got "
                         f"{shaft_hz * 60 if isinstance(shaft_hz, (int, float)) else shaft_hz}")
    if values.ndim != 1 or values.size < 16:
        raise InputError(f"record: a channel needs at least 16 samples, got {values.size}")
    if not np.isfinite(values).all():
        raise InputError("record: the channel holds NaN or infinite values")
    if not np.ptp(values) > 0:
        raise InputError("record: the channel is constant (no vibration to diagnose)")
    table = bearing.frequencies(shaft_hz)
    top = BAND_WIDTH_FACTOR * max(table["BPFO"], table["BPFI"], table["2xBSF"])
    if top > fs / 2:
        raise InputError(f"--fs: {fs:g} Hz cannot hold a band of {top:.0f} Hz (2.5 x the "
                         f"highest defect frequency) at {shaft_hz * 60:.0f} rpm: the "
                         f"Nyquist frequency must be at least that")
    needed = required_seconds(bearing, shaft_hz, fs)
    have = values.size / fs
    if have < needed:
        raise InputError(f"record: {have:.3g} s is too short to resolve the defect lines of "
                         f"{bearing.name} at {shaft_hz * 60:.0f} rpm: the envelope spectrum "
                         f"must resolve FTF/{RESOLUTIONS_PER_FTF} = "
                         f"{table['FTF'] / RESOLUTIONS_PER_FTF:.3g} Hz, which needs at least "
                         f"{needed:.3g} s ({math.ceil(needed * fs)} samples)")


def choose_band(spectrum: kg.Spectrum, table: dict[str, float]
                ) -> tuple[BandChoice, kg.Kurtogram]:
    """The band of largest kurtosis of the fast kurtogram, at least ``BAND_WIDTH_FACTOR``
    times the highest of BPFO, BPFI, 2xBSF wide (at most a quarter of the rate)."""
    floor = min(BAND_WIDTH_FACTOR * max(table["BPFO"], table["BPFI"], table["2xBSF"]),
                spectrum.fs / 4)
    gram = kg.kurtogram(np.zeros(0), spectrum.fs, floor, spectrum=spectrum)
    if len(gram) == 0:
        nyquist = spectrum.fs / 2
        return BandChoice(0.0, nyquist, 0.0, 0.0, "whole (no band fits)"), gram
    i = gram.best()
    return (BandChoice(float(gram.low_hz[i]), float(gram.high_hz[i]), float(gram.kurtosis[i]),
                       float(gram.level[i])), gram)


def squared_envelope_spectrum(spectrum: kg.Spectrum, band: BandChoice
                              ) -> tuple[np.ndarray, np.ndarray]:
    """(frequency Hz, amplitude) of the squared envelope of ``band``: the kurtogram's own
    filter's analytic signal, the edges left out, the Hann amplitude spectrum."""
    analytic = spectrum.analytic(band.low_hz, band.high_hz)
    edge = math.ceil(kg.edge_seconds(band.low_hz, band.high_hz) * spectrum.fs) \
        if band.high_hz - band.low_hz < spectrum.fs / 2 else 0
    squared = np.abs(analytic[edge:analytic.size - edge]) ** 2
    amplitude, df = _raw_spectrum(squared, spectrum.fs)
    return np.arange(amplitude.size) * df, amplitude


def verdict_of(families: dict[str, ev.Family]) -> tuple[str, float, str]:
    """(verdict, confidence, reason) from the families' evidence (module docstring). FTF
    lines beside ball lines are the cage's modulation of a ball defect: the cage is named
    only when no ball harmonic stands over the noise (``evidence.above_noise``)."""
    clear = sorted((f for f in families.values() if f.clear), key=lambda f: -f.score)
    ball = families.get("ball")
    audible = [] if ball is None else ev.above_noise(ball)
    blind = [] if ball is None else [ln.name for ln in ball.lines if ln.note == ev.MASKED
                                      and ln.name in ("BSF", "2BSF")]
    if any(f.name == "cage" for f in clear) and (audible or blind):
        clear = [f for f in clear if f.name != "cage"]
        if not clear:
            why = (f"ball lines over the noise ({', '.join(ln.name for ln in audible)})"
                   if audible else f"{' and '.join(blind)} on shaft harmonics, where a ball "
                   "defect's lines cannot be seen")
            return "none", 0.5, (f"no clear fault: FTF lines beside {why}: the cage's "
                                 "modulation of a ball defect, or a cage fault; not named")
    if not clear:
        best = max(families.values(), key=lambda f: (len(f.harmonics_above), f.score),
                   default=None)
        if best is None or not best.harmonics_above:
            return "none", 1.0, ("no clear fault: no defect line of any family stands over "
                                 "its threshold")
        return "none", 0.5, (f"no clear fault: the strongest evidence, {best.name} "
                             f"({', '.join(ln.name for ln in best.harmonics_above)} over "
                             f"{best.threshold_db:.1f} dB), has fewer than "
                             f"{ev.MIN_HARMONICS} consistent harmonics above its threshold")
    winner = clear[0]
    runner = clear[1].score if len(clear) > 1 else 0.0
    if len(clear) > 1 and winner.score < DOMINANCE * runner:
        return "none", 0.5, (f"no clear fault: both {winner.name} (score "
                             f"{winner.score:.1f} dB) and {clear[1].name} ({runner:.1f} dB) "
                             f"are clear, neither {DOMINANCE:g} times the other")
    total = winner.score + runner
    confidence = (1.0 - winner.false_alarm) * (winner.score / total if total > 0 else 1.0)
    lines = ", ".join(f"{ln.name} {ln.level_db:.1f} dB" for ln in winner.harmonics_above)
    side = winner.sidebands_above
    extra = f"; sidebands {', '.join(ln.name for ln in side)}" if side else ""
    other = (f"; {clear[1].name} also clear, {winner.score / runner:.1f} times weaker"
             if len(clear) > 1 else "")
    return winner.name, float(confidence), (f"{winner.name}: {lines} over the threshold "
                                            f"{winner.threshold_db:.1f} dB{extra}{other}")


def diagnose_signal(values: np.ndarray, fs_hz: float, shaft_hz: float, bearing: Bearing, *,
                    prewhiten: str = pw.DEFAULT, speed_source: str = "given",
                    refine: bool = True) -> Diagnosis:
    """The diagnosis of one channel ``values`` sampled at ``fs_hz`` (Hz) of a machine whose
    shaft turns at ``shaft_hz`` (Hz, nominal; refined on the 1X line when ``refine``) in
    ``bearing``: see the module docstring."""
    pw.check_method(prewhiten)
    x = np.asarray(values, dtype=float)
    fs, nominal = float(fs_hz), float(shaft_hz)
    check_inputs(x, fs, nominal, bearing)
    x = x - x.mean()
    speed = (refine_speed(x, fs, nominal, speed_source) if refine
             else Speed(nominal, speed_source, nominal, False, note="not refined"))
    table = bearing.frequencies(speed.hz)
    whitened = pw.prewhiten(x, fs, prewhiten)
    spectrum = kg.Spectrum(whitened, fs)
    band, gram = choose_band(spectrum, table)
    freq, amplitude = squared_envelope_spectrum(spectrum, band)
    df = float(freq[1] - freq[0])
    rel = ev.REL_WINDOW + (0.0 if speed.refined else ev.SPEED_UNCERTAINTY)
    families = ev.all_families(amplitude, df, table, speed.hz, rel,
                               0.001 if speed.refined else ev.SPEED_UNCERTAINTY)
    verdict, confidence, reason = verdict_of(families)
    notes = [n for n in (speed.note,) if n]
    for family in families.values():
        hidden = [f"{ln.name} ({ln.theory_multiple:.4f} X)" for ln in family.lines
                  if ln.note == ev.MASKED]
        if hidden:
            notes.append(f"{family.name}: {', '.join(hidden)} on a shaft harmonic or a "
                         "clearer family's line: not searched")
    return Diagnosis(verdict, confidence, reason, families, band, speed, bearing, table,
                     prewhiten, fs, int(x.size), df, notes=notes, envelope_hz=freq,
                     envelope_amplitude=amplitude, kurtogram=gram)


def _record_speed(record: xr.Dataset, rpm: float | None) -> tuple[float, str]:
    """(nominal shaft speed Hz, its source) of a record: ``rpm`` when given, else the
    record's own speed; InputError saying which option gives it."""
    if rpm is not None:
        value = float(rpm)
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"rpm: the shaft speed must be a finite number > 0 rpm, "
                             f"got {rpm}", field="rpm")
        return value / 60.0, "--rpm"
    from analysis.measured.records import record_speed_hz

    hz = record_speed_hz(record)
    if hz is None:
        raise InputError("--rpm: the record holds no shaft speed; give --rpm R or --tacho "
                         "CHANNEL")
    if not (math.isfinite(hz) and hz > 0):
        raise InputError(f"--rpm: the record's shaft speed must be > 0 rpm, got {hz * 60:g}; "
                         "give --rpm R")
    return hz, str(record.attrs.get("speed_source", "record"))


SPEED_VARIATION = 0.02
"""A speed over ``t`` that varies more than this (relative, max − min over the mean) is
said: the defect lines smear over the record (order tracking would gather them)."""


def diagnose(record: xr.Dataset, *, channel: str | None, bearing: str | Bearing,
             rpm: float | None = None, tacho: str | None = None,
             prewhiten: str = pw.DEFAULT) -> Diagnosis:
    """The diagnosis of ``record``'s ``channel`` (a name or pattern,
    ``records.pick_channel``) for ``bearing`` (a :class:`Bearing` or a name for
    ``bearings.lookup``), at ``rpm``, the speed of the once-per-revolution ``tacho``
    channel, or the record's own speed (file, tacho, table), in that order."""
    from analysis.measured.records import SPEED, pick_channel, tacho_speed

    bearing = lookup(bearing) if isinstance(bearing, str) else bearing
    pw.check_method(prewhiten)
    if rpm is not None and tacho is not None:
        raise InputError("tacho: give --rpm or --tacho, not both", field="tacho")
    name = pick_channel(record, channel)
    if tacho is not None:
        record = tacho_speed(record.copy(), pick_channel(record, tacho, "tacho"))
    shaft_hz, source = _record_speed(record, rpm)
    values = np.asarray(record[name].values, dtype=float)
    fs = float(record.attrs.get("sample_rate_hz", 0.0))
    result = diagnose_signal(values, fs, shaft_hz, bearing, prewhiten=prewhiten,
                             speed_source=source)
    if rpm is None and SPEED in record.data_vars:
        speeds = np.asarray(record[SPEED].values, dtype=float)
        spread = float(np.ptp(speeds) / np.mean(speeds))
        if spread > SPEED_VARIATION:
            result.notes.append(f"the speed varies by {spread:.1%} over the record "
                                f"({speeds.min():.0f}…{speeds.max():.0f} rpm): the defect "
                                "lines smear; the mean speed is used")
    result.channel = name
    result.units = str(record[name].attrs.get("units", ""))
    result.provenance = {k: record.attrs[k] for k in
                         ("source_file", "sha256", "reader", "original_names",
                          "sample_rate_hz", "sample_rate_source", "speed_rpm",
                          "speed_source", "tacho_channel") if k in record.attrs}
    result.provenance["original_name"] = str(record[name].attrs.get("original_name", name))
    return result


@dataclass(frozen=True)
class Job:
    """One record of a folder to diagnose (picklable: it crosses to a worker process)."""

    path: str
    channel: str | None
    bearing: str
    rpm: float | None = None
    tacho: str | None = None
    fs: float | None = None
    prewhiten: str = pw.DEFAULT


def diagnose_file(path: str | Path, *, channel: str | None, bearing: str,
                  rpm: float | None = None, tacho: str | None = None,
                  fs: float | None = None, prewhiten: str = pw.DEFAULT) -> Diagnosis:
    """Read the record at ``path`` (``records.read_record`` with ``fs``, ``rpm``,
    ``tacho``) and diagnose it; the bearing and method are judged before the file is
    read."""
    from analysis.measured.records import read_record

    lookup(bearing)
    pw.check_method(prewhiten)
    if rpm is not None:
        _record_speed(xr.Dataset(), rpm)
    record = read_record(path, fs=fs, rpm=rpm, tacho=tacho)
    return diagnose(record, channel=channel, bearing=bearing, prewhiten=prewhiten)


def folder_jobs(folder: str | Path, *, channel: str | None, bearing: str,
                rpm: float | None = None, tacho: str | None = None, fs: float | None = None,
                prewhiten: str = pw.DEFAULT) -> list[Job]:
    """A :class:`Job` for every file in ``folder`` (not its subfolders) whose suffix a
    reader knows (``analysis.measured.readers.READERS``), by name; InputError for a folder
    without one, an impossible bearing or an unknown method (judged before any file is
    read)."""
    from analysis.measured.readers import READERS

    lookup(bearing)
    pw.check_method(prewhiten)
    path = Path(folder)
    files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in READERS)
    if not files:
        raise InputError(f"record: folder '{path}' holds no record ({', '.join(READERS)})")
    return [Job(str(p), channel, bearing, rpm, tacho, fs, prewhiten) for p in files]


def run_job(job: Job) -> dict:
    """A folder's task: the diagnosis as a dict (``as_dict``), or ``{"error": line}``."""
    try:
        result = diagnose_file(job.path, channel=job.channel, bearing=job.bearing,
                               rpm=job.rpm, tacho=job.tacho, fs=job.fs,
                               prewhiten=job.prewhiten)
    except BearingdynError as err:
        return {"path": job.path, "error": str(err)}
    return {"path": job.path, **result.as_dict()}


def _indexed_job(task: tuple[int, Job]) -> dict:
    """A folder's task with its place in the folder (``run_job``)."""
    return run_job(task[1])


def diagnose_folder(jobs: Sequence[Job], workers: int | None = None,
                    progress: Callable[[int, int, dict], None] | None = None) -> list[dict]:
    """Each job's ``run_job`` result, in the jobs' order, on ``workers`` processes (default:
    all cores; one: in this process) through the project's executors
    (``analysis.sweeps.executors``: the workers ignore SIGINT, so the parent reports a
    Ctrl-C once, and end with the parent; on an interruption the records not yet started
    are dropped); ``progress(done, total, result)`` after each."""
    from analysis.sweeps.executors import ProcessExecutor, SerialExecutor
    from analysis.threads import blas_threads

    count = min(len(jobs), workers or os.cpu_count() or 1)
    results: list[dict | None] = [None] * len(jobs)
    executor = SerialExecutor() if count <= 1 else ProcessExecutor(count)
    with blas_threads():
        for done, ((i, _), result) in enumerate(
                executor.run(_indexed_job, list(enumerate(jobs))), 1):
            results[i] = result
            if progress:
                progress(done, len(jobs), result)
    return results  # type: ignore[return-value]
