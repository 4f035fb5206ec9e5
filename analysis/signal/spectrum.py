"""Amplitude spectra of simulated responses and their labelled peaks.

A simulation result is an ``xarray.Dataset`` on a uniform time coordinate ``t`` (s) with one
variable per state (``x``, ``y`` (m), ``vx``, ``vy`` (m/s) for the paper's rotor; the names
are in the ``state_names`` attr); its attrs carry the shaft frequency ``shaft_hz`` (X) and
each bearing's varying-compliance frequency (VC), in Hz: ``vc_hz`` for a model with one
bearing, ``vc_hz_<bearing>`` for several.

Spectral peaks are named as combinations m·X + n·VC: "X", "VC-X", "2VC+X" for one bearing;
"VC[left]", "2VC[right]-X" for several, each combination over one bearing's VC (mixtures
of two bearings' VC are not tried). A model without bearings has no VC term: peaks are
named by X only; a model that has no shaft either (``shaft_hz`` 0) but is forced at the
period held by a parameter ``forcing_period`` (s) is labelled with F = 1/forcing_period in
place of X ("F", "2F"). In the defect vocabulary (``vocabulary = "fault"``, and in envelope
spectra, ``analysis.signal.envelope``) peaks are named by the defect frequencies FTF, BPFO,
BPFI, BSF of each bearing, their harmonics and their sidebands at ±X and ±FTF ("BPFO",
"2BSF", "BPFI-X", "BSF+FTF"). A peak keeps every other name within its tolerance in
``also`` (two lines in one bin).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.fft
import scipy.signal
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.forcing import run_period_parameter
from analysis.integrate.speed_profile import refuse_profile
from analysis.provenance import displacement_names, vc_frequencies

_DEFAULT_UNITS = {"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"}

# A peak must rise above the higher of its two bases by at least this fraction of the height
# threshold (``min_relative_height`` × largest amplitude): it rejects ripples on the flank of a
# larger peak while keeping small lines that stand clear of the surrounding spectrum.
_PROMINENCE_FRACTION = 0.5

# Lower bound of the Hann window's scalloping factor (worst case half a bin: 0.849).
_SCALLOPING_BOUND = 0.84

# Frequency tolerance of the labels, in frequency bins 1/(N·dt).
_LABEL_TOLERANCE_BINS = 1.5


def time_step(ds: xr.Dataset) -> float:
    """The uniform time step of ``ds.t`` (s); raises InputError if ``t`` is not uniform."""
    t = np.asarray(ds["t"].values, dtype=float)
    if t.size < 3:
        raise InputError(f"t: need at least 3 time samples, got {t.size}")
    dt = (t[-1] - t[0]) / (t.size - 1)
    if not dt > 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=0.0):
        raise InputError("t: time samples must be increasing and uniformly spaced")
    return float(dt)


def _units(ds: xr.Dataset, var: str) -> str:
    return str(ds[var].attrs.get("units", _DEFAULT_UNITS.get(var, "")))


@functools.lru_cache(maxsize=8)
def window_of(window: str, n: int) -> np.ndarray:
    """``scipy.signal.get_window(window, n)`` (periodic form), made once per name and length
    and shared read-only: a chart's or an explorer's records repeat their lengths."""
    w = scipy.signal.get_window(window, n)
    w.setflags(write=False)
    return w


def amplitude_spectrum(ds: xr.Dataset, var: str = "x", window: str = "hann") -> xr.DataArray:
    """Single-sided amplitude spectrum of ``ds[var]`` (unit of the variable: m or m/s).

    The mean is removed and the record multiplied by ``scipy.signal.get_window(window, N)``
    (periodic form). The magnitude of the real FFT is scaled by 2 / sum(window), so that a
    sinusoid of amplitude A at a bin frequency shows a peak of height A (between bins the
    window's scalloping loss lowers it, by up to 15 % for Hann). The DC and Nyquist bins are not
    doubled. Coordinate ``frequency`` in Hz, bin width 1/(N·dt).
    """
    if var not in ds.data_vars:
        raise InputError(f"var: no variable '{var}' in the dataset; "
                         f"variables: {', '.join(map(str, ds.data_vars))}")
    refuse_profile(ds.attrs, "spectrum")  # a run-up: bearingdyn waterfall
    dt = time_step(ds)
    values = np.asarray(ds[var].values, dtype=float)
    n = values.size
    w = window_of(window, n)
    # scipy.fft: the same values as numpy.fft to the bit here, faster on record lengths
    # with large prime factors (N = k + 1 samples)
    amplitude = 2.0 * np.abs(scipy.fft.rfft((values - values.mean()) * w)) / w.sum()
    amplitude[0] /= 2.0
    if n % 2 == 0:
        amplitude[-1] /= 2.0
    frequency = np.fft.rfftfreq(n, d=dt)
    attrs = dict(ds.attrs)
    attrs.update(units=_units(ds, var), window=str(window))
    return xr.DataArray(
        amplitude,
        dims="frequency",
        coords={"frequency": ("frequency", frequency, {"units": "Hz"})},
        name=f"{var}_amplitude",
        attrs=attrs,
    )


BEAT_BELOW = 0.25
"""A difference kX − n·VC is named (a beat) only below this fraction of the shaft frequency:
a slow modulation of two nearly equal lines, not any difference of two forcings."""


def _combination_label(m: int, n: int, bearing: str = "", base: str = "X") -> str:
    shaft = base if abs(m) == 1 else f"{abs(m)}{base}"
    if n == 0:
        return shaft
    symbol = f"VC[{bearing}]" if bearing else "VC"
    vc = symbol if abs(n) == 1 else f"{abs(n)}{symbol}"
    if m == 0:
        return vc
    if n < 0:  # the beat of a shaft harmonic just above a VC harmonic: 4X-VC
        return f"{shaft}-{vc}"
    return f"{vc}{'+' if m > 0 else '-'}{shaft}"


def frequency_names(f_hz: float, shaft_hz: float, vc_hz: float | dict[str, float],
                    tol_hz: float, max_shaft_order: int = 4, max_vc_order: int = 3,
                    base: str = "X") -> list[tuple[str, int, int, str | None]]:
    """Every name m·X + n·VC of ``f_hz`` within ``tol_hz`` (Hz), best first: the candidates
    and their order are those of :func:`name_frequency`, which returns the first.

    n may be negative when m is positive for a beat: ``kX-nVC`` below ``BEAT_BELOW`` of the
    shaft frequency, a shaft harmonic and a VC harmonic close to each other (at N_b = 10,
    4X − VC = 1.1 Hz on the paper's model: a slow modulation, not a forcing of its own)."""
    vcs = vc_hz if isinstance(vc_hz, dict) else ({"": float(vc_hz)} if vc_hz else {})
    vcs = {name: float(f) for name, f in vcs.items() if f > 0}
    found: list[tuple[tuple, str, int, int, str | None]] = []
    for rank, (bearing, vc) in enumerate(vcs.items() or [("", 0.0)]):
        for n in range(-max_vc_order if vc > 0 else 0, max_vc_order + 1 if vc > 0 else 1):
            for m in range(-max_shaft_order, max_shaft_order + 1):
                combination = m * shaft_hz + n * vc
                if combination <= 0 or (n < 0 and combination >= BEAT_BELOW * shaft_hz):
                    continue
                distance = abs(f_hz - combination)
                if distance > tol_hz:
                    continue
                key = (abs(m) + abs(n), distance, abs(n), abs(m), rank if n else 0)
                found.append((key, _combination_label(m, n, bearing, base), m, n,
                              (bearing or None) if n else None))
    found.sort(key=lambda item: item[0])
    unique, seen = [], set()
    for _, label, m, n, bearing in found:
        if label not in seen:
            seen.add(label)
            unique.append((label, m, n, bearing))
    return unique


FAULT_NAMES = ("FTF", "BPFO", "BPFI", "BSF")
"""The characteristic defect frequencies, as labelled (DESIGN.md): fundamental train (cage),
ball pass outer race, ball pass inner race, ball spin."""


def fault_frequencies(attrs: dict) -> dict[str, dict[str, float]]:
    """Each bearing's defect frequencies (Hz) from a run's attrs (``ftf_hz``, ``bpfo_hz``,
    ``bpfi_hz``, ``bsf_hz``; ``…_hz_<bearing>`` for several bearings), keyed like
    :func:`analysis.signal.vc_frequencies` (``""`` for the only bearing). A one-bearing run
    written before these attrs existed gets them from ``shaft_hz``, ``cage_hz``, ``n_balls``
    (and ``contact_angle``) by the same relations; ``{}`` for a run without a bearing."""
    out: dict[str, dict[str, float]] = {}
    for key, value in attrs.items():
        head, sep, bearing = str(key).partition("_hz")
        if sep and head.upper() in FAULT_NAMES and (bearing == "" or bearing.startswith("_")):
            out.setdefault(bearing[1:], {})[head.upper()] = float(value)
    out = {b: f for b, f in out.items() if len(f) == len(FAULT_NAMES) and f["FTF"] > 0}
    if out or "n_balls" not in attrs or float(attrs.get("cage_hz", 0.0)) <= 0:
        return out
    from analysis.model import FaultFrequencies  # a file written before the defect attrs

    table = FaultFrequencies.from_kinematics(
        float(attrs["shaft_hz"]), float(attrs["cage_hz"]), int(attrs["n_balls"]),
        float(attrs.get("contact_angle", 0.0)))
    return {"": table.as_dict()}


DEFECT_FAMILIES = {"outer": ("BPFO",), "inner": ("BPFI",), "ball": ("BSF", "FTF")}
"""The lines each kind of defect makes: an outer-race defect BPFO, an inner-race one BPFI
(with X sidebands), a ball defect BSF and its harmonics with FTF sidebands, and FTF."""
SIGNIFICANCE_DB = 15.0
"""A line of the fault vocabulary is named only when it stands this far (dB of amplitude,
a factor 5.6) above the noise floor, the median amplitude of the ``FLOOR_BINS`` bins on
either side of it. In a Hann spectrum of white noise a bin's amplitude is Rayleigh
distributed and exceeds 5.6 times its median with probability 2^(−5.6²) ≈ 3e-10."""
FLOOR_BINS = 100
"""Bins on each side of a line over which its noise floor (the median amplitude) is taken."""
_TIE = 1e-6
"""Distances to a line within this fraction of the tolerance are equal (then the lower order
names it): exact coincidences such as 9·FTF = BPFO stay with the simpler name."""


HALF_ORDERS = (1, 3, 5)
"""Odd multiples of half a defect frequency named in the fault vocabulary (``BPFO/2``,
``3BPFO/2``, ``5BPFO/2``; ``VC/2``, … without a defect): the lines of a period-2 response,
the period doubling by which the paper's model goes to chaos (each ball pass alternates
between two loads, so the envelope repeats every second pass). A half-order line is never
a defect's own frequency; it says the response has doubled its period."""


def fault_names(f_hz: float, shaft_hz: float, faults: dict[str, dict[str, float]],
                tol_hz: float, max_harmonic: int = 4, max_sideband: int = 2,
                defects: tuple[str, ...] | None = None) -> list[tuple[str, int | None]]:
    """Every defect-vocabulary name of ``f_hz`` within ``tol_hz`` (Hz), nearest first.

    Candidates: the shaft harmonics ``kX`` (k = 1 … max(4, ``max_harmonic``)); per bearing
    (``faults`` as from :func:`fault_frequencies`) the harmonics ``nF`` (n = 1 …
    ``max_harmonic``) of F in BPFO, BPFI, BSF with their sidebands ``nF±mX`` and ``nF±mFTF``
    (m = 1 … ``max_sideband``) and ``FTF``, ``2FTF``, ``3FTF``: ``BPFO``, ``2BPFO``,
    ``BPFI+X``, ``BPFI-X``, ``2BSF``, ``BSF+FTF``, … With several bearings each name carries
    its bearing: ``BPFO[left]``. ``defects`` limits the families to the run's defects
    (:data:`DEFECT_FAMILIES`; None: every family); with no defect (``()``) the lines that
    exist are the varying compliance VC (= BPFO for a fixed outer race) and its combinations
    with X, named ``VC``, ``2VC``, ``VC+X``, … and ``kX``. The nearest candidate names the
    line (distances equal within 1e-6 of the tolerance: the lower order n + m, k for kX).
    The odd half orders ``F/2``, ``3F/2``, ``5F/2`` of each family (:data:`HALF_ORDERS`, of
    order n + 1) name the lines of a period-2 response.
    Returns (label, shaft order k for a pure shaft harmonic else None).
    """
    found: list[tuple[tuple, str, int | None]] = []

    def consider(order: int, freq: float, label: str, shaft_order: int | None) -> None:
        if freq > 0 and abs(f_hz - freq) <= tol_hz:
            found.append(((round(abs(f_hz - freq) / (_TIE * tol_hz)) if tol_hz > 0 else 0,
                           order), label, shaft_order))

    def orders(base: float, reach: float) -> range:
        """Harmonics n <= max_harmonic whose sidebands can come within tol of f_hz."""
        if base <= 0:
            return range(0)
        low = max(1, math.floor((f_hz - reach - tol_hz) / base))
        return range(low, min(max_harmonic, math.ceil((f_hz + reach + tol_hz) / base)) + 1)

    if shaft_hz > 0:
        for k in orders(shaft_hz, 0.0) if max_harmonic > 4 else range(1, 5):
            consider(k, k * shaft_hz, "X" if k == 1 else f"{k}X", k)
    families = {name for d in (DEFECT_FAMILIES if defects is None else defects)
                for name in DEFECT_FAMILIES.get(d, ())}
    for bearing, table in faults.items():
        tag = f"[{bearing}]" if bearing else ""
        ftf = table["FTF"]
        if "FTF" in families:
            for n in range(1, 4):
                consider(n, n * ftf, f"{'' if n == 1 else n}FTF{tag}", None)
        named = [(name, name) for name in ("BPFO", "BPFI", "BSF") if name in families]
        mods = [("X", shaft_hz), ("FTF", ftf)]
        if defects is not None and not defects:  # no defect: VC and its X combinations
            named, mods = [("BPFO", "VC")], [("X", shaft_hz)]
        reach = max_sideband * max(shaft_hz, ftf)
        for name, symbol in named:
            for n in HALF_ORDERS:  # a period-2 response: BPFO/2, 3BPFO/2, 5BPFO/2
                consider(n + 1, n * table[name] / 2, f"{'' if n == 1 else n}{symbol}{tag}/2",
                         None)
            for n in orders(table[name], reach):
                centre = n * table[name]
                head = f"{'' if n == 1 else n}{symbol}{tag}"
                consider(n, centre, head, None)
                for mod_name, mod in mods:
                    for m in range(1, max_sideband + 1):
                        side = mod_name if m == 1 else f"{m}{mod_name}"
                        consider(n + m, centre + m * mod, f"{head}+{side}", None)
                        consider(n + m, centre - m * mod, f"{head}-{side}", None)
    found.sort(key=lambda item: item[0])
    unique, seen = [], set()
    for _, label, k in found:
        if label not in seen:
            seen.add(label)
            unique.append((label, k))
    return unique


def run_defects(attrs: dict) -> tuple[str, ...] | None:
    """The defects of a run's model (``outer``, ``inner``, ``ball``; ``()`` for none), from
    the terms of its generated model: a localized defect of nonzero ``defect_depth`` and any
    waviness term (as the terms describe themselves, ``modelgen/terms/defects.py`` and
    ``waviness.py``). None when the model cannot be loaded (every family is then named)."""
    from analysis.model import load_model

    try:
        module = load_model(str(attrs.get("spec_file") or attrs["model"])).module
    except Exception:  # a moved or foreign model: no vocabulary limit
        try:
            module = load_model(str(attrs["model"])).module
        except Exception:
            return None
    depth = max((float(v) for k, v in attrs.items() if str(k).startswith("defect_depth")),
                default=0.0)
    found = []
    for text in getattr(module, "TERMS", ()):
        for race, marks in (("outer", ("localized defect on the outer race",
                                       "outer-race waviness")),
                            ("inner", ("localized defect on the inner race",
                                       "inner-race waviness")),
                            ("ball", ("localized defect on ball", "ball waviness"))):
            for mark in marks:
                if str(text).startswith(mark) and (depth > 0 or "waviness" in mark):
                    found.append(race)
    return tuple(dict.fromkeys(found))


def noise_floor(amplitude: np.ndarray, index: int, bins: int = FLOOR_BINS) -> float:
    """The median of ``amplitude`` over the ``bins`` bins on either side of ``index`` (the
    line's own three bins left out): the noise floor a line is judged against."""
    lo, hi = max(1, index - bins), min(amplitude.size, index + bins + 1)
    around = np.concatenate([amplitude[lo:max(lo, index - 1)], amplitude[index + 2:hi]])
    return float(np.median(around)) if around.size else 0.0


def name_frequency(f_hz: float, shaft_hz: float, vc_hz: float | dict[str, float],
                   tol_hz: float, max_shaft_order: int = 4, max_vc_order: int = 3,
                   base: str = "X") -> tuple[str, int, int, str | None] | None:
    """Name ``f_hz`` (Hz) as m·X + n·VC of one bearing, within ``tol_hz`` (Hz).

    ``vc_hz`` is the VC frequency of a model's only bearing (Hz), or a mapping bearing name
    -> VC frequency (Hz) for several (labels ``VC[name]``; the key ``""`` means the only
    bearing, labelled ``VC``; an empty mapping or 0: no VC term). Candidates have integers
    |m| <= ``max_shaft_order``, 0 <= n <= ``max_vc_order``, (m, n) not both zero and a
    positive combination frequency (so no "-X"). Among the candidates within the tolerance
    the lowest order |m| + n wins, ties go to the smallest distance |f - f_mn|, then to the
    first bearing. ``base`` names the shaft frequency in labels (``X``, or ``F`` for a
    forcing period). Returns ``(label, m, n, bearing)`` (bearing None for a pure shaft
    harmonic or the only bearing) or None when no candidate is within the tolerance.
    """
    names = frequency_names(f_hz, shaft_hz, vc_hz, tol_hz, max_shaft_order, max_vc_order,
                            base)
    return names[0] if names else None


def label_frequency(f_hz: float, shaft_hz: float, vc_hz: float | dict[str, float],
                    tol_hz: float, max_shaft_order: int = 4,
                    max_vc_order: int = 3) -> tuple[str, int, int] | None:
    """Name ``f_hz`` (Hz) as the combination m·X + n·VC within ``tol_hz`` (Hz).

    :func:`name_frequency` without the bearing: returns ``(label, m, n)`` with an ASCII
    label such as "X", "2X", "VC", "VC-2X", "2VC+X" ("VC[left]-X" for a mapping of several
    bearings' VC), or None when no candidate is within the tolerance.
    """
    named = name_frequency(f_hz, shaft_hz, vc_hz, tol_hz, max_shaft_order, max_vc_order)
    return None if named is None else named[:3]


@dataclass(frozen=True)
class Peak:
    """A spectral line: ``direction`` is the variable ("x", "y", "x_rotor", …),
    ``frequency_hz`` in Hz, ``amplitude`` in the variable's unit (m for x, y), and its
    combination label m·X + n·VC (``shaft_order`` m, ``vc_order`` n; all None when
    unlabelled); ``bearing`` names the bearing whose VC the label uses, when the model has
    several (else None). ``also``: the other names within the label
    tolerance (near-commensurate X and VC, e.g. 2X and VC−2X when VC ≈ 4X): the label is
    then ambiguous."""

    direction: str
    frequency_hz: float
    amplitude: float
    label: str | None
    shaft_order: int | None
    vc_order: int | None
    bearing: str | None = None
    also: tuple[str, ...] = ()
    """Other names within the label tolerance (one bin): frequencies that coincide, e.g.
    ``VC`` and ``4X`` at N_b = 10, or ``BPFO`` and ``VC``."""

    @property
    def ambiguous(self) -> bool:
        """Another combination names this frequency within the tolerance as well."""
        return bool(self.also)

    @property
    def name(self) -> str:
        """The label, or for an unnamed peak its frequency (``140.2 Hz``): how every table,
        text and figure shows a peak."""
        return self.label if self.label else f"{self.frequency_hz:.1f} Hz"

    def as_dict(self) -> dict[str, Any]:
        """The fields as a dict (``bearing`` and ``also`` only when set)."""
        out = dataclasses.asdict(self)
        if out["bearing"] is None:
            del out["bearing"]
        if not out["also"]:
            del out["also"]
        else:
            out["also"] = list(out["also"])
        return out


def label_frequencies(attrs: dict) -> tuple[float, dict[str, float], str]:
    """What peaks of a run are named by: (base frequency Hz, VC per bearing Hz, base
    symbol). The base is the shaft frequency X, or F = 1/``forcing_period`` for a model
    without a shaft forced at a parameter's period."""
    if "shaft_hz" not in attrs:
        raise InputError("shaft_hz: missing from the dataset attrs")
    shaft = float(attrs["shaft_hz"])
    vcs = vc_frequencies(attrs)
    forcing = run_period_parameter(attrs)  # the forcing_period role
    if not shaft > 0 and forcing is not None and float(attrs[forcing]) > 0:
        return 1.0 / float(attrs[forcing]), vcs, "F"
    return shaft, vcs, "X"


def find_peaks(ds: xr.Dataset, var: str | None = None, max_peaks: int = 8,
               min_relative_height: float = 0.02, vocabulary: str = "shaft",
               spectrum: xr.DataArray | None = None) -> list[Peak]:
    """The ``max_peaks`` largest peaks of the Hann amplitude spectrum of ``ds[var]`` (any
    state variable; default: the run's first displacement, ``x`` or ``x_rotor``).

    Peaks come from ``scipy.signal.find_peaks`` on the spectrum without its DC bin, with height
    >= ``min_relative_height`` × the largest amplitude and a prominence of at least half that
    height threshold. Each peak frequency is refined by fitting a parabola to the logarithm of
    the amplitude in the three bins around the maximum (Gaussian interpolation,
    f = (k + p)·df with p = (a - c) / (2 (a - 2b + c)), a, b, c the log-amplitudes of bins
    k-1, k, k+1; bias below 0.02 bin for Hann). The amplitude (unit of the variable) is the
    window-corrected magnitude of the windowed record's Fourier transform evaluated at that
    refined frequency, so it is free of the window's scalloping loss between bins.
    Peaks are labelled with :func:`name_frequency` (``shaft_hz`` and each bearing's VC from
    ``ds.attrs``, see :func:`label_frequencies`; tolerance 1.5 bins) and returned by
    descending amplitude. With ``vocabulary = "fault"`` they are named by the defect
    frequencies instead (:func:`fault_names`: ``BPFO``, ``2BSF``, ``BPFI+X``, …; the run needs
    ``ftf_hz`` … in its attrs): the nearest name within the tolerance, harmonics up to the
    highest order the record resolves (below the Nyquist frequency, or below the band's
    width for an envelope, attr ``band_hz``), only the families of the run's defects
    (:func:`run_defects`; VC and its X combinations without a defect), and only for a line
    ``SIGNIFICANCE_DB`` above its noise floor (:func:`noise_floor`); the envelope of a
    dataset whose attrs hold ``label_tolerance_rel`` (a measured record's: its defect lines
    sit off their nominal frequencies by the bearing's slip) names within that fraction of
    the frequency where it is wider than 1.5 bins. Every other name
    within the tolerance is kept in ``also`` (an ambiguous label: ``Peak.ambiguous``).
    ``spectrum``: ``amplitude_spectrum(ds, var)`` when the caller has it already (it is not
    computed again).
    """
    if vocabulary not in ("shaft", "fault"):
        raise InputError(f"vocabulary: must be 'shaft' or 'fault', got {vocabulary!r}")
    var = displacement_names(ds)[0] if var is None else var
    check_count("max_peaks", max_peaks, 1)
    if not 0 < min_relative_height <= 1:
        raise InputError(f"min_relative_height: must be in (0, 1], got {min_relative_height!r}")
    base_hz, vcs, base = label_frequencies(ds.attrs)
    spectrum = amplitude_spectrum(ds, var) if spectrum is None else spectrum
    amplitude = spectrum.values
    df = float(spectrum["frequency"].values[1])
    search = amplitude[1:]
    largest = float(search.max())
    if not largest > 0:
        return []
    threshold = min_relative_height * largest
    found, properties = scipy.signal.find_peaks(
        search, height=threshold, prominence=_PROMINENCE_FRACTION * threshold)
    if found.size == 0:
        return []
    # Only peaks that can rank among the ``max_peaks`` largest after refinement: the refined
    # amplitude is at most 1/0.85 of the highest bin (Hann scalloping loss <= 1.42 dB).
    heights = properties["peak_heights"]
    if found.size > max_peaks:
        cut = np.sort(heights)[-max_peaks]
        found = found[heights >= _SCALLOPING_BOUND * cut]
    k = found + 1
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b, c = (np.log(amplitude[k + shift]) for shift in (-1, 0, 1))
        offset = 0.5 * (a - c) / (a - 2.0 * b + c)
    offset = np.where(np.isfinite(offset) & (np.abs(offset) <= 0.5), offset, 0.0)
    frequency = (k + offset) * df
    refined = _amplitude_at(ds, var, frequency)

    order = np.argsort(-refined, kind="stable")[:max_peaks]
    faults = fault_frequencies(ds.attrs) if vocabulary == "fault" else {}
    if vocabulary == "fault" and not faults:
        raise InputError("vocabulary: 'fault' needs the defect frequencies (ftf_hz, bpfo_hz, "
                         "bpfi_hz, bsf_hz) in the run's attrs; simulate the run again")
    if vocabulary == "fault":
        defects = run_defects(ds.attrs)
        low, _, high = str(ds.attrs.get("band_hz", "")).partition(":")
        reach = float(high) - float(low) if high else 0.5 / time_step(ds)
        top_order = max(4, int(reach / min(min(t.values()) for t in faults.values())))
        threshold = 10 ** (SIGNIFICANCE_DB / 20)
    # a measured record's envelope lines sit off their nominal frequencies by the slip
    slip = float(ds.attrs.get("label_tolerance_rel", 0.0)) if "band_hz" in ds.attrs else 0.0
    peaks = []
    for i in order:
        f = float(frequency[i])
        tol = max(_LABEL_TOLERANCE_BINS * df, slip * f)
        if vocabulary == "fault":
            floor = noise_floor(amplitude, int(k[i]))
            names = (fault_names(f, base_hz, faults, tol, max_harmonic=top_order,
                                 defects=defects)
                     if refined[i] >= threshold * floor else [])
            label, m = names[0] if names else (None, None)
            n, bearing, also = None, None, tuple(name for name, _ in names[1:])
        else:
            shaft_names = frequency_names(f, base_hz, vcs, tol_hz=tol, base=base)
            label, m, n, bearing = shaft_names[0] if shaft_names else (None, None, None, None)
            also = tuple(name for name, *_ in shaft_names[1:])
        peaks.append(Peak(direction=var, frequency_hz=f, amplitude=float(refined[i]),
                          label=label, shaft_order=m, vc_order=n, bearing=bearing,
                          also=also))
    return peaks


def _amplitude_at(ds: xr.Dataset, var: str, frequency: np.ndarray) -> np.ndarray:
    """Window-corrected amplitude of the Hann-windowed, mean-free ``ds[var]`` at each
    ``frequency`` (Hz): 2·|Σ w_j x_j exp(-2πi f j dt)| / Σ w_j."""
    dt = time_step(ds)
    values = np.asarray(ds[var].values, dtype=float)
    w = window_of("hann", values.size)
    weighted = (values - values.mean()) * w
    # e^{-iωj} for j = a·B + b as e^{-iωaB}·e^{-iωb}: 2√N exponentials a frequency, not N
    block = max(1, math.isqrt(values.size))
    rows = -(-values.size // block)
    grid = np.zeros(rows * block)
    grid[:values.size] = weighted
    grid = grid.reshape(rows, block)
    a, b = np.arange(rows) * block, np.arange(block)
    omega = -2j * np.pi * np.asarray(frequency, dtype=float)[:, None] * dt
    # all frequencies in one product (the real grid is made complex once, not per frequency)
    coarse = np.exp(omega * a) @ grid
    return 2.0 * np.abs(np.sum(coarse * np.exp(omega * b), axis=1)) / w.sum()


def peak_table(ds: xr.Dataset, directions: tuple[str, ...] | None = None,
               **kwargs: Any) -> list[Peak]:
    """:func:`find_peaks` for each variable in ``directions`` (default: the first body's
    displacements, ``x`` and ``y`` for the paper's rotor), concatenated in that order."""
    directions = displacement_names(ds) if directions is None else directions
    return [peak for var in directions for peak in find_peaks(ds, var, **kwargs)]


def major_peak(ds: xr.Dataset, var: str | None = None) -> Peak:
    """The largest peak of the amplitude spectrum of ``ds[var]`` (default: as
    :func:`find_peaks`)."""
    var = displacement_names(ds)[0] if var is None else var
    peaks = find_peaks(ds, var, max_peaks=1)
    if not peaks:
        raise InputError(f"{var}: the spectrum has no peak (constant signal?)")
    return peaks[0]
