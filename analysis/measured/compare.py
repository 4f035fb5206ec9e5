"""Model against measurement: a measured record and a simulated run in the order domain.

Both signals are taken to the same quantity and the same axis before they are compared:

1. **Acceleration.** A record in g is taken to m/s² (``records.to_si``); a simulated
   displacement (m) is differentiated twice, a velocity (m/s) once, in the frequency
   domain: the spectrum of the record, continued smoothly to the FFT's length
   (``kurtogram.bridged``: equal value, slope and curvature across the wrap), is multiplied
   by (i·2πf)², so each line's amplitude A becomes A·(2πf)² (x = A sin ωt gives
   a = −A ω² sin ωt). Both signals are then accelerations (m/s²); a channel in V or 1
   (no physical unit) is compared as it is, and the result says so.
2. **Orders.** Every frequency is divided by the signal's own shaft speed: the record's
   (its file, ``--rpm`` or a tacho, refined on its 1X line as ``diagnose`` refines it) and
   the run's (``shaft_hz``). A line that turns with the shaft stands at the same order in
   both whatever their speeds.
3. **Two spectra per signal**: the raw Hann amplitude spectrum, and the squared envelope
   spectrum of the band of largest spectral kurtosis (the fast kurtogram;
   ``diagnose.choose_band`` and ``diagnose.squared_envelope_spectrum``: the envelope of
   ``bearingdyn diagnose``, here without pre-whitening, so that both signals are treated
   alike), each band chosen on its own signal.
4. **Normalised**: each spectrum in dB relative to its own largest line between
   ``MIN_ORDER`` and the largest order shown (the record's g and the model's m differ, and
   a model's level depends on its assumed masses and damping: only the pattern of lines is
   compared, not their absolute levels).

**Lines.** A line of a spectrum is a local maximum between ``MIN_ORDER`` and ``max_order``
that stands ``LINE_DB`` over its local noise floor (the median of ``FLOOR_BINS`` bins each
side, ``analysis.signal.spectrum.noise_floor``) and within ``RANGE_DB`` of the spectrum's
largest line; the ``MAX_LINES`` strongest are kept. Each is named by the nearest line of
its own signal's vocabulary within the order tolerance: the shaft harmonics nX, and the
defect lines (:func:`vocabulary`: BPFO, BPFI, their harmonics and their ±X
sidebands; BSF, 2xBSF, … with ±FTF sidebands; FTF and harmonics; the names of
``bearingdyn diagnose``), from the record's bearing and from the run's own geometry
(:func:`name_lines`). A record line and a model line are **shared** when their orders agree
within the tolerance, max(``ORDER_TOLERANCE``·order, two bins of the coarser spectrum);
every other line is the record's or the model's only.

A model whose bearing geometry is not the record's has its defect lines at other orders: the
result notes each defect line both name at orders that differ by more than the tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.fft
import scipy.signal
import xarray as xr

from analysis.errors import InputError
from analysis.measured.bearings import BSF_CONVENTION, Bearing, lookup
from analysis.measured.records import is_record, pick_channel, record_speed_hz, to_si
from analysis.signal import kurtogram as kg
from analysis.signal.orders import amplitude
from analysis.signal.spectrum import noise_floor

MIN_ORDER = 0.3
"""Lowest order searched for lines and for the normalising largest line (the DC of a
squared envelope and the slow drift of a record lie below; FTF is about 0.4)."""
MAX_ORDER = 12.0
"""Highest order shown and searched by default (2·BPFI of a 6205 is 10.8)."""
LINE_DB = 10.0
"""A line stands at least this far (dB of amplitude, a factor 3.2) over its local floor."""
RANGE_DB = 40.0
"""... and within this far of the spectrum's largest line (a noise-free simulation has
lines of every combination down to round-off: only the ones that matter are compared)."""
MAX_LINES = 12
"""The strongest lines kept per spectrum."""
FLOOR_BINS = 50
"""Bins on each side over which a line's noise floor is the median."""
ORDER_TOLERANCE = 0.015
"""Relative order tolerance of two lines that are the same line (and of a line and its
name): slip and geometry move real bearing lines by a few tenths of a percent."""
SPECTRA = ("envelope", "raw")
"""The two spectra compared, in the order shown."""
DIFFERENTIATIONS = {"m/s^2": 0, "m/s": 1, "m": 2}
"""Time derivatives that take a signal in each SI unit to an acceleration (m/s²)."""


@dataclass(frozen=True)
class Line:
    """A line of one order spectrum: its order, level (dB re the spectrum's largest line),
    height over its local floor (dB) and its name in its signal's vocabulary ('' if none)."""

    order: float
    level_db: float
    over_floor_db: float
    name: str = ""

    @property
    def label(self) -> str:
        return self.name or f"{self.order:.2f}"

    def as_dict(self) -> dict:
        return {"order": self.order, "level_db": self.level_db,
                "over_floor_db": self.over_floor_db, "name": self.name}


@dataclass(frozen=True)
class OrderSpectrum:
    """One signal's spectrum in orders of its shaft speed, in dB re its largest line."""

    kind: str
    """``envelope`` or ``raw``."""
    source: str
    """``record`` or ``model``."""
    orders: np.ndarray
    level_db: np.ndarray
    order_bin: float
    lines: tuple[Line, ...]
    band_hz: tuple[float, float] | None = None
    """The envelope's band (Hz)."""
    kurtosis: float | None = None

    def as_dict(self) -> dict:
        out: dict[str, Any] = {"kind": self.kind, "source": self.source,
                               "order_bin": self.order_bin,
                               "lines": [ln.as_dict() for ln in self.lines]}
        if self.band_hz is not None:
            out.update(band_hz=list(self.band_hz), kurtosis=self.kurtosis)
        return out


@dataclass(frozen=True)
class Match:
    """A line of one spectrum kind in the record, the model or both."""

    kind: str
    record: Line | None
    model: Line | None

    @property
    def status(self) -> str:
        """``both``, ``record only`` or ``model only``."""
        if self.record is not None and self.model is not None:
            return "both"
        return "record only" if self.record is not None else "model only"

    @property
    def name(self) -> str:
        names = [ln.label for ln in (self.record, self.model) if ln is not None]
        return names[0] if len(set(names)) == 1 else " / ".join(names)

    def as_dict(self) -> dict:
        return {"kind": self.kind, "status": self.status, "name": self.name,
                "record": None if self.record is None else self.record.as_dict(),
                "model": None if self.model is None else self.model.as_dict()}


@dataclass(frozen=True)
class Signal:
    """One side of a comparison: an acceleration, its rate, shaft speed and vocabulary."""

    values: np.ndarray
    fs_hz: float
    shaft_hz: float
    units: str
    vocabulary: dict[str, float]
    """Line name -> order."""
    describe: str


@dataclass
class Comparison:
    """A record against a simulated run: the order spectra of both, their lines, and which
    lines both have (``matches``)."""

    record: dict[str, OrderSpectrum]
    model: dict[str, OrderSpectrum]
    matches: list[Match]
    record_shaft_hz: float
    model_shaft_hz: float
    units: dict[str, str]
    tolerance: float
    max_order: float
    notes: list[str] = field(default_factory=list)
    provenance: dict[str, Any] = field(default_factory=dict)

    def lines(self, kind: str, status: str) -> list[Match]:
        """The matches of spectrum ``kind`` with ``status`` (both, record only, model only)."""
        return [m for m in self.matches if m.kind == kind and m.status == status]

    def as_dict(self) -> dict:
        return {"record_shaft_hz": self.record_shaft_hz, "model_shaft_hz": self.model_shaft_hz,
                "units": dict(self.units), "normalisation": "dB re each spectrum's largest line "
                f"between orders {MIN_ORDER:g} and {self.max_order:g}",
                "order_tolerance": f"max({self.tolerance:g} x order, 2 bins)",
                "spectra": {kind: {"record": self.record[kind].as_dict(),
                                   "model": self.model[kind].as_dict()} for kind in SPECTRA},
                "matches": [m.as_dict() for m in self.matches],
                "shared": {kind: [m.name for m in self.lines(kind, "both")] for kind in SPECTRA},
                "record_only": {kind: [m.name for m in self.lines(kind, "record only")]
                                for kind in SPECTRA},
                "model_only": {kind: [m.name for m in self.lines(kind, "model only")]
                               for kind in SPECTRA},
                "ball_convention": BSF_CONVENTION, "notes": list(self.notes),
                "provenance": dict(self.provenance)}


# ----------------------------------------------------------------------- acceleration


def differentiate(values: np.ndarray, fs_hz: float, times: int) -> np.ndarray:
    """The ``times``-th time derivative of ``values`` sampled at ``fs_hz`` (Hz), taken in
    the frequency domain: the mean-free record continued smoothly to the FFT's length
    (``kurtogram.bridged``), its spectrum multiplied by (i·2πf)^times, transformed back and
    cut to the record's length. Units: the record's over s^times. Exact to about 1e-5
    away from the ends; within some tens of samples of them the continuation's slope and
    curvature, taken by finite differences, leave errors up to some 10 % (a sine of 48
    samples per period) that the spectra's windows and the envelope's edges leave out.

    >>> t = np.arange(12000) / 12000.0
    >>> a = differentiate(np.sin(2 * np.pi * 100 * t), 12000.0, 2)
    >>> w2 = (2 * np.pi * 100) ** 2
    >>> bool(np.max(np.abs(a + w2 * np.sin(2 * np.pi * 100 * t))[100:-100]) < 1e-5 * w2)
    True
    """
    x = np.asarray(values, dtype=float)
    if times == 0:
        return x
    n = x.size
    n_fft = scipy.fft.next_fast_len(n + max(kg.BRIDGE, n // 100), real=True)
    spectrum = scipy.fft.rfft(kg.bridged(x - x.mean(), n_fft))
    omega = 2 * np.pi * scipy.fft.rfftfreq(n_fft, 1.0 / fs_hz)
    spectrum *= (1j * omega) ** times
    if n_fft % 2 == 0 and times % 2 == 1:
        spectrum[-1] = 0.0  # the Nyquist bin of an odd derivative is not real
    return scipy.fft.irfft(spectrum, n_fft)[:n]


def acceleration(values: np.ndarray, fs_hz: float, units: str) -> tuple[np.ndarray, str]:
    """``values`` in SI ``units`` as an acceleration (m/s²): displacement (m) twice and
    velocity (m/s) once differentiated (:func:`differentiate`); other units (V, 1) as they
    are, with their unit."""
    times = DIFFERENTIATIONS.get(units)
    if times is None:
        return np.asarray(values, dtype=float), units
    return differentiate(values, fs_hz, times), "m/s^2"


# ------------------------------------------------------------------------ vocabulary


HARMONICS = {"BPFO": 4, "BPFI": 4, "BSF": 6, "FTF": 3}
"""Harmonics of each defect line in the vocabulary."""
SIDEBANDS = {"BPFO": "X", "BPFI": "X", "BSF": "FTF"}
"""The modulation whose sidebands each harmonic of a defect line carries: an inner-race
defect turns through the load zone once per revolution (±X, ±2X, ±3X), a ball defect with
the cage (±FTF, ±2FTF, ±3FTF) (R. B. Randall, J. Antoni, MSSP 25 (2011) 485–520, Sec. 2);
an outer-race defect is not modulated by the load zone, but by a load that turns with the
shaft (unbalance, misalignment: ±X, as the CWRU fan-end outer-race record shows)."""
SIDEBAND_ORDERS = 3
"""Sidebands on each side of a modulated defect line in the vocabulary."""


def vocabulary(table_hz: dict[str, float], shaft_hz: float, max_order: float
               ) -> dict[str, float]:
    """Line name -> order of the shaft harmonics X, 2X, … and the defect lines up to
    ``max_order`` (cycles/rev), from the defect frequencies ``table_hz`` (FTF, BPFO, BPFI,
    BSF; Hz) at shaft frequency ``shaft_hz``: FTF, 2FTF, 3FTF; BPFO … 4BPFO and BPFI …
    4BPFI with ±X, ±2X, ±3X sidebands (``BPFI-X``, ``2BPFO+2X``); BSF, 2xBSF … 6xBSF with
    ±FTF … sidebands.
    The first name of an order wins (a shaft harmonic before a defect line).

    >>> words = vocabulary({"FTF": 0.4, "BPFO": 3.6, "BPFI": 5.4, "BSF": 2.4}, 1.0, 6.0)
    >>> words["BPFI-X"], words["2xBSF"], words["3X"]
    (4.4, 4.8, 3.0)
    """
    out = {("X" if n == 1 else f"{n}X"): float(n) for n in range(1, int(max_order) + 1)}
    modulation = {"X": shaft_hz, "FTF": table_hz["FTF"]}
    for base in ("FTF", "BPFO", "BPFI", "BSF"):
        for h in range(1, HARMONICS[base] + 1):
            f = h * table_hz[base]
            name = base if h == 1 else (f"{h}x{base}" if base == "BSF" else f"{h}{base}")
            rows = [(name, f)]
            if base in SIDEBANDS:
                by = SIDEBANDS[base]
                for k in range(1, SIDEBAND_ORDERS + 1):
                    step = by if k == 1 else f"{k}{by}"
                    rows += [(f"{name}-{step}", f - k * modulation[by]),
                             (f"{name}+{step}", f + k * modulation[by])]
            for label, freq in rows:
                order = freq / shaft_hz
                if MIN_ORDER <= order <= max_order:
                    out.setdefault(label, order)
    return out


def family_of(name: str) -> str:
    """The defect line a vocabulary name belongs to (BPFO, BPFI, BSF, FTF), or X."""
    return next((base for base in ("BPFO", "BPFI", "BSF", "FTF") if base in name), "X")


def is_sideband(name: str) -> bool:
    return "+" in name or "-" in name


def name_lines(orders: list[float], words: dict[str, float], windows: list[float]
               ) -> list[str]:
    """A name for each line at ``orders`` (strongest first) from the vocabulary ``words``,
    within its ``windows`` (orders), '' where none fits. A defect line is *present* when a
    line off the shaft harmonics lies within the window of it or of one of its harmonics
    (a 2X line does not make a BSF of 1.99 orders present); a line is named by the
    nearest of the shaft harmonics, the defect harmonics and the sidebands of the present
    defect lines (a sideband of an absent line is the less likely name), else by the
    nearest name of all; each name goes to one line only, the nearest."""
    harmonics = [w for w in words if not is_sideband(w)]
    shaft = [words[w] for w in harmonics if family_of(w) == "X"]
    free = [i for i, o in enumerate(orders)  # a line on a shaft harmonic is the shaft's
            if not any(abs(f - o) <= windows[i] for f in shaft)]
    present = {family_of(w) for i in free for w in harmonics
               if family_of(w) != "X" and abs(words[w] - orders[i]) <= windows[i]}
    likely = harmonics + [w for w in words if is_sideband(w) and family_of(w) in present]
    names = [""] * len(orders)
    taken: set[str] = set()
    for allowed in (likely, list(words)):
        pairs = sorted((abs(words[w] - o), i, w) for i, o in enumerate(orders) for w in allowed
                       if not names[i] and abs(words[w] - o) <= windows[i])
        for _, i, w in pairs:  # nearest pairs first: each name to the line nearest it
            if not names[i] and w not in taken:
                names[i] = w
                taken.add(w)
    return names


def _window(order: float, tolerance: float, order_bin: float) -> float:
    return max(tolerance * order, 2 * order_bin)


# --------------------------------------------------------------------------- spectra


def order_spectrum(signal: Signal, kind: str, source: str, table_hz: dict[str, float],
                   max_order: float, tolerance: float,
                   band_hz: tuple[float, float] | None = None) -> OrderSpectrum:
    """The ``kind`` (envelope or raw) spectrum of ``signal`` in orders, normalised, with its
    lines named (module docstring)."""
    from analysis.measured.diagnose import BandChoice, choose_band, squared_envelope_spectrum

    x = signal.values - signal.values.mean()
    band, kurt = None, None
    if kind == "envelope":
        spectrum = kg.Spectrum(x, signal.fs_hz)
        if band_hz is None:
            chosen, _ = choose_band(spectrum, table_hz)
        else:
            chosen = BandChoice(band_hz[0], band_hz[1], math.nan, math.nan, "given")
        freq, amp = squared_envelope_spectrum(spectrum, chosen)
        band, kurt = (chosen.low_hz, chosen.high_hz), chosen.kurtosis
    else:
        amp = amplitude(x)
        freq = np.arange(amp.size) * signal.fs_hz / x.size
    orders = freq / signal.shaft_hz
    order_bin = float(orders[1] - orders[0])
    inside = (orders >= MIN_ORDER) & (orders <= max_order)
    top = float(amp[inside].max()) if inside.any() else 0.0
    if not top > 0:
        raise InputError(f"compare: the {source}'s {kind} spectrum holds no line between "
                         f"orders {MIN_ORDER:g} and {max_order:g}")
    with np.errstate(divide="ignore"):
        level = 20 * np.log10(np.maximum(amp, top * 1e-15) / top)
    keep = np.flatnonzero(inside)
    lines = find_lines(amp, orders, keep, top, signal.vocabulary, tolerance, order_bin)
    return OrderSpectrum(kind, source, orders[keep], level[keep], order_bin, lines, band, kurt)


def find_lines(amp: np.ndarray, orders: np.ndarray, keep: np.ndarray, top: float,
               words: dict[str, float], tolerance: float, order_bin: float
               ) -> tuple[Line, ...]:
    """The lines of the spectrum ``amp`` over ``orders`` among the bins ``keep`` (module
    docstring), strongest first, named from ``words``."""
    peaks, _ = scipy.signal.find_peaks(amp[keep[0]:keep[-1] + 1])
    found = []
    for i in peaks + keep[0]:
        floor = noise_floor(amp, int(i), FLOOR_BINS)
        if not floor > 0:
            continue
        over = 20 * math.log10(amp[i] / floor)
        level = 20 * math.log10(amp[i] / top)
        if over >= LINE_DB and level >= -RANGE_DB:
            a, b, c = np.log(np.maximum(amp[i - 1:i + 2], 1e-300))
            denom = a - 2 * b + c
            shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
            found.append((float(orders[i] + shift * order_bin), level, over))
    found = sorted(found, key=lambda row: -row[1])[:MAX_LINES]
    names = name_lines([o for o, _, _ in found], words,
                       [_window(o, tolerance, order_bin) for o, _, _ in found])
    return tuple(Line(o, level, over, name)
                 for (o, level, over), name in zip(found, names, strict=True))


def match_lines(kind: str, record: OrderSpectrum, model: OrderSpectrum, tolerance: float
                ) -> list[Match]:
    """Pair each record line with the nearest unpaired model line within the tolerance
    (strongest record lines first); the rest are one side's only. By order."""
    coarse = max(record.order_bin, model.order_bin)
    free = list(model.lines)
    out = []
    for line in record.lines:
        window = _window(line.order, tolerance, coarse)
        near = [m for m in free if abs(m.order - line.order) <= window]
        if near:
            other = min(near, key=lambda m: abs(m.order - line.order))
            free.remove(other)
            out.append(Match(kind, line, other))
        else:
            out.append(Match(kind, line, None))
    out += [Match(kind, None, m) for m in free]
    return sorted(out, key=lambda m: (m.record or m.model).order)


# ----------------------------------------------------------------------------- inputs


def record_signal(record: xr.Dataset, channel: str | None, bearing: Bearing,
                  rpm: float | None, max_order: float) -> tuple[Signal, dict[str, float]]:
    """The record's channel as an acceleration, its rate, refined shaft speed and the
    vocabulary of ``bearing``; and the bearing's defect frequencies (Hz)."""
    from analysis.measured.diagnose import refine_speed

    if not is_record(record):
        raise InputError("record: not a measured record (read it with read_record)")
    name = pick_channel(record, channel)
    values, units = to_si(record, name)
    fs = float(record.attrs["sample_rate_hz"])
    if rpm is not None:
        if not (math.isfinite(rpm) and rpm > 0):
            raise InputError(f"rpm: the shaft speed must be a finite number > 0 rpm, got "
                             f"{rpm}", field="rpm")
        nominal, source = rpm / 60.0, "--rpm"
    else:
        nominal = record_speed_hz(record)
        source = str(record.attrs.get("speed_source", "record"))
        if nominal is None:
            raise InputError("record: it has no shaft speed; give --rpm (or read it with "
                             "--tacho)")
    speed = refine_speed(values - values.mean(), fs, nominal, source)
    accel, units = acceleration(values, fs, units)
    table = bearing.frequencies(speed.hz)
    words = vocabulary(table, speed.hz, max_order)
    how = (f"{speed.hz * 60:.1f} rpm (1X line; nominal {nominal * 60:.1f} rpm, {source})"
           if speed.refined else f"{speed.hz * 60:.1f} rpm ({source})")
    return Signal(accel, fs, speed.hz, units, words,
                  f"record channel {name}, {how}, bearing {bearing.name}"), table


def model_signal(result: xr.Dataset, var: str | None, max_order: float
                 ) -> tuple[Signal, dict[str, float], str]:
    """The run's variable ``var`` (default: its first displacement) as an acceleration,
    its sample rate and shaft speed, its own bearing's vocabulary and defect frequencies
    (Hz), and the variable's name."""
    from analysis.provenance import displacement_names, state_names
    from analysis.signal.spectrum import fault_frequencies

    if "speed_profile" in result.attrs:
        raise InputError("result: its speed follows a profile (a run-up); compare a run at "
                         "constant speed")
    names = state_names(result)
    var = displacement_names(result)[0] if var is None else var
    if var not in names:
        raise InputError(f"var: the run has no state '{var}'; states: {', '.join(names)}",
                         field="var")
    shaft = float(result.attrs.get("shaft_hz", 0.0))
    if not shaft > 0:
        raise InputError("result: the run has no turning shaft (shaft_hz 0); orders need one")
    faults = fault_frequencies(dict(result.attrs))
    if not faults:
        raise InputError(f"result: model {result.attrs.get('model')} has no bearing whose "
                         "defect lines could be named")
    table = dict(next(iter(faults.values())))
    t = np.asarray(result["t"].values, dtype=float)
    fs = 1.0 / float(np.mean(np.diff(t)))
    units = str(result[var].attrs.get("units", "1"))
    accel, units = acceleration(np.asarray(result[var].values, dtype=float), fs, units)
    table["2xBSF"] = 2 * table["BSF"]
    describe = (f"model {result.attrs.get('model')} {var}, {shaft * 60:.1f} rpm, "
                f"{int(result.attrs.get('n_balls', 0))} balls")
    return Signal(accel, fs, shaft, units, vocabulary(table, shaft, max_order),
                  describe), table, var


def compare(record: xr.Dataset, result: xr.Dataset, *, channel: str | None = None,
            result_var: str | None = None, bearing: str | Bearing | None = None,
            rpm: float | None = None, max_order: float = MAX_ORDER,
            tolerance: float = ORDER_TOLERANCE,
            band_hz: tuple[float, float] | None = None) -> Comparison:
    """The record's ``channel`` against the run's ``result_var`` in the order domain
    (module docstring): envelope and raw order spectra, their lines, and the lines both
    have. ``bearing``: the record's bearing (a catalogue name, ``d=…,D=…,z=…``, a model name
    or a :class:`Bearing`; default: the run's model's); ``rpm``: the record's speed
    (default: its own); ``max_order``: the highest order shown and searched;
    ``tolerance``: the relative order tolerance; ``band_hz``: one envelope band (Hz) for
    both signals instead of each one's kurtogram band.

    >>> compare(xr.Dataset(), xr.Dataset())
    Traceback (most recent call last):
    ...
    analysis.errors.InputError: record: not a measured record (read it with read_record)
    """
    if not (math.isfinite(max_order) and 1.0 <= max_order <= 1000.0):
        raise InputError(f"max_order: must be in [1, 1000], got {max_order}", field="max_order")
    if not (math.isfinite(tolerance) and 0 < tolerance < 0.5):
        raise InputError(f"tolerance: must be in (0, 0.5), got {tolerance}")
    if not is_record(record):
        raise InputError("record: not a measured record (read it with read_record)")
    if bearing is None:
        bearing = run_bearing(result)
    elif isinstance(bearing, str):
        bearing = lookup(bearing)
    rec, rec_table = record_signal(record, channel, bearing, rpm, max_order)
    mod, mod_table, var = model_signal(result, result_var, max_order)
    spectra: dict[str, dict[str, OrderSpectrum]] = {"record": {}, "model": {}}
    for kind in SPECTRA:
        spectra["record"][kind] = order_spectrum(rec, kind, "record", rec_table, max_order,
                                                 tolerance, band_hz)
        spectra["model"][kind] = order_spectrum(mod, kind, "model", mod_table, max_order,
                                                tolerance, band_hz)
    matches = [m for kind in SPECTRA
               for m in match_lines(kind, spectra["record"][kind], spectra["model"][kind],
                                    tolerance)]
    notes = geometry_notes(rec.vocabulary, mod.vocabulary, tolerance)
    notes += [f"{label} in {units}: compared as it is (no acceleration)"
              for label, units in (("the record", rec.units), ("the model", mod.units))
              if units != "m/s^2"]
    provenance = {"record": {k: record.attrs.get(k) for k in ("source_file", "sha256", "reader")
                             if k in record.attrs},
                  "model": {k: result.attrs.get(k) for k in ("model", "spec_sha256")
                            if k in result.attrs},
                  "record_signal": rec.describe, "model_signal": mod.describe,
                  "record_bearing": bearing.as_dict(), "model_var": var}
    return Comparison(spectra["record"], spectra["model"], matches, rec.shaft_hz,
                      mod.shaft_hz, {"record": rec.units, "model": mod.units}, tolerance,
                      max_order, notes, provenance)


def run_bearing(result: xr.Dataset) -> Bearing:
    """The bearing of a run as it ran (its attrs: ``ball_diameter``, ``pitch_diameter``,
    ``n_balls``, ``contact_angle``, set with --set or the spec's), else its model's."""
    a = result.attrs
    model = str(a.get("model", ""))
    if all(k in a for k in ("ball_diameter", "pitch_diameter", "n_balls")):
        return Bearing(f"{model} (the run's geometry)", float(a["ball_diameter"]),
                       float(a["pitch_diameter"]), int(a["n_balls"]),
                       float(a.get("contact_angle", 0.0)), f"result of {model}")
    return lookup(model)


def geometry_notes(record_words: dict[str, float], model_words: dict[str, float],
                   tolerance: float) -> list[str]:
    """One note naming the defect lines whose orders differ between the record's bearing
    and the model's by more than ``tolerance`` (relative): their geometries differ."""
    differ = [f"{name} {record_words[name]:.3f} (record) / {model_words[name]:.3f} (model)"
              for name in ("FTF", "BPFO", "BPFI", "BSF", "2xBSF")
              if name in record_words and name in model_words
              and abs(record_words[name] - model_words[name]) > tolerance * record_words[name]]
    if not differ:
        return []
    return ["the record's bearing and the model's differ: defect orders " + ", ".join(differ)
            + "; the same fault makes its lines at other orders in each (set the model's "
            "geometry with --set to compare them line by line)"]
