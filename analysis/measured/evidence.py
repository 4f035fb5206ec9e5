"""The evidence of each bearing-fault family in a (squared) envelope spectrum, and the
threshold a line must pass.

Families (R. B. Randall, J. Antoni, MSSP 25 (2011) 485–520, Sec. 2–3):

* ``outer-race``: BPFO and its harmonics (a fixed defect: no modulation);
* ``inner-race``: BPFI and its harmonics, with sidebands at ±1X (the defect turns through
  the load zone once per revolution);
* ``ball``: the ball spin frequency's harmonics (BSF, 2xBSF, 3BSF, …: a spall strikes one
  race or both each spin), with sidebands at ±FTF (the ball turns through the load zone
  with the cage);
* ``cage``: FTF and its harmonics.

**Search.** Each harmonic h·F is first searched in a wide window of ±``rel_window`` of its
theoretical frequency (default ``REL_WINDOW``, at least ``MIN_WINDOW_BINS`` bins): rolling
elements slip by 1–2 % (Randall & Antoni, Sec. 2.1), and the CWRU records' lines sit within
0.5 % of theory once the shaft speed is taken from the 1X line. The line found is the
largest bin of the window that is a local maximum (a window whose largest bin is on the
flank of a line outside it has none); its level is its amplitude over the local noise floor,
the median amplitude of ``FLOOR_BINS`` bins on each side
(``analysis.signal.spectrum.noise_floor``), in dB.

**Consistency.** The harmonics of one impact train are exact multiples of one frequency,
whatever the slip. Each harmonic found above the threshold is tried as the anchor: the
family's frequency F' = f_found/h, and the other harmonics and the sidebands are searched in
a tight window of ±``TIGHT`` of h·F' (at least ``MIN_WINDOW_BINS`` bins). The anchor with
the most harmonics above the threshold (then the largest score) gives the family's lines.
Lines at one frequency but not at its multiples (a line of some other machine element near
BPFO, another near 4BPFO) do not make a family.

**Exclusions.** The bins of the shaft harmonics nX (n ≥ 1) are left out of every search: a
line there is the shaft's (unbalance, misalignment, looseness), whatever else it might be.
A diagnosis also leaves out the lines a clearer family explains (its harmonics and their
sidebands, e.g. 3BPFI − 2X, which falls near 6BSF of the 6205) before it judges the others.

**The threshold.** The squared envelope of band-passed Gaussian noise is exponentially
distributed (χ² with 2 degrees of freedom); its spectrum at a frequency away from 0 is
asymptotically complex Gaussian, so each bin's amplitude is Rayleigh distributed and exceeds
k times the median with probability 2^(−k²) (the median is σ·√(2 ln 2)). Noise makes a family
clear when the largest of the W bins of one of its H wide windows and the largest of the w
bins of one of the H − 1 tight windows both pass k: probability ≤ H·W·(H − 1)·w·2^(−2k²).
The threshold of a family is the k (in dB, 20·log10 k) at which that bound equals
``FAMILY_FALSE_ALARM``. ``tests/measured/test_diagnose.py`` checks it by simulation.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from analysis.signal.spectrum import noise_floor

REL_WINDOW = 0.015
"""Half width of a harmonic's first (wide) search window, relative to its theory."""
TIGHT = 0.003
"""Half width of the consistent search around h·F' (relative): the anchor's frequency is
interpolated to a fraction of a bin, and one impact train's harmonics are exact multiples."""
SPEED_UNCERTAINTY = 0.01
"""Added to ``REL_WINDOW`` when the shaft speed is not measured on the 1X line (a nominal
speed: an induction motor slips by up to a few % under load)."""
MIN_WINDOW_BINS = 2
"""Fewest bins on each side of a line's centre in its window."""
FLOOR_BINS = 100
"""Bins on each side over which a line's noise floor (the median amplitude) is taken."""
FAMILY_FALSE_ALARM = 1e-4
"""Probability that pure noise makes a family clear (two consistent harmonics above the
threshold)."""
MIN_HARMONICS = 2
"""Consistent harmonics above the threshold that make a family's evidence clear."""
HARMONICS = {"outer-race": 4, "inner-race": 4, "ball": 6, "cage": 3}
"""Harmonics searched per family (the ball family counts harmonics of BSF: BSF, 2xBSF, …)."""
FAMILIES = ("outer-race", "inner-race", "ball", "cage")
"""The fault families, in the order they are reported."""
BASE = {"outer-race": "BPFO", "inner-race": "BPFI", "ball": "BSF", "cage": "FTF"}
"""The line whose harmonics make each family."""
ALLOWED_GCD = {"outer-race": (1,), "inner-race": (1,), "ball": (1, 2), "cage": (1,)}
"""The greatest common divisor the orders of a clear family's harmonics may have: lines at
3F and 6F alone are one periodic component near 3F and its harmonic, not evidence of F; for
the ball, 2xBSF is itself the defect's rate (a spall striking both races), so 2BSF and
4BSF are evidence."""
SIDEBAND_ORDERS = 2
"""Sidebands ±m·X (inner race) or ±m·FTF (ball), m = 1 … this, that a clear family
explains (the evidence counts m = 1)."""


def threshold_db(wide_bins: int, tight_bins: int, harmonics: int,
                 false_alarm: float = FAMILY_FALSE_ALARM) -> float:
    """The level (dB over the median floor) at which noise makes a family of ``harmonics``
    lines clear with probability ``false_alarm``: H·W·(H − 1)·w·2^(−2k²) = α.

    >>> round(threshold_db(49, 5, 4), 2)
    10.94
    """
    h = max(harmonics, MIN_HARMONICS)
    trials = h * max(wide_bins, 1) * (h - 1) * max(tight_bins, 1)
    k2 = 0.5 * math.log2(trials / false_alarm)
    return 10.0 * math.log10(k2)


def line_false_alarm(level_db: float, window_bins: int) -> float:
    """Probability that the largest of ``window_bins`` Rayleigh bins of noise stands
    ``level_db`` over their median: 1 − (1 − 2^(−k²))^W."""
    k2 = 10 ** (level_db / 10)
    return float(-np.expm1(window_bins * np.log1p(-(2.0 ** -k2))))


def noise_median_db(window_bins: int) -> float:
    """The level (dB over the median floor) that the largest of ``window_bins`` Rayleigh
    bins of noise passes with probability 1/2: k² = −log2(1 − 2^(−1/W))."""
    k2 = -math.log2(-math.expm1(-math.log(2.0) / max(window_bins, 1)))
    return 10.0 * math.log10(k2)


def above_noise(family: Family) -> list[Line]:
    """The family's harmonics that stand over the median largest noise bin of their window
    (``noise_median_db``): lines more likely there than not, clear or not."""
    return [ln for ln in family.lines if ln.role == "harmonic" and ln.level_db is not None
            and ln.level_db >= noise_median_db(int(2 * round(ln.window_hz / family.df) + 1))]


@dataclass(frozen=True)
class Line:
    """One line searched: its name, theory and what was found (Hz, dB, multiples of the
    shaft speed)."""

    name: str
    role: str
    """``harmonic`` or ``sideband``."""
    theory_hz: float
    centre_hz: float
    """Centre of the window searched (theory, or h·F' of the anchor)."""
    window_hz: float
    """Half width of the window searched."""
    found_hz: float | None = None
    level_db: float | None = None
    theory_multiple: float = 0.0
    found_multiple: float | None = None
    above: bool = False
    """At or above the family's threshold."""
    note: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Family:
    """A fault family's evidence: every line searched, the threshold and the anchor."""

    name: str
    base: str
    threshold_db: float
    lines: tuple[Line, ...] = field(default_factory=tuple)
    df: float = 1.0
    """Bin width of the spectrum searched (Hz)."""
    anchor: str = ""
    """The harmonic whose frequency set the consistent search ('' : none passed)."""
    fundamental_hz: float | None = None
    """F' = f_anchor/h: the family's frequency as measured."""
    note: str = ""

    @property
    def harmonics_above(self) -> list[Line]:
        return [ln for ln in self.lines if ln.role == "harmonic" and ln.above]

    @property
    def sidebands_above(self) -> list[Line]:
        return [ln for ln in self.lines if ln.role == "sideband" and ln.above]

    @property
    def orders_gcd(self) -> int:
        """Greatest common divisor of the orders h of the harmonics above the threshold."""
        return math.gcd(*(_order(ln.name, self.base) for ln in self.harmonics_above))

    @property
    def clear(self) -> bool:
        """At least ``MIN_HARMONICS`` consistent harmonics above the threshold, not all of
        them multiples of one harmonic (``ALLOWED_GCD``)."""
        return (len(self.harmonics_above) >= MIN_HARMONICS
                and self.orders_gcd in ALLOWED_GCD[self.name])

    @property
    def score(self) -> float:
        """Sum over the harmonics and sidebands above the threshold of their level over it
        (dB): how strongly the family stands out."""
        return float(sum(ln.level_db - self.threshold_db for ln in self.lines
                         if ln.above and ln.level_db is not None))

    @property
    def false_alarm(self) -> float:
        """Probability that noise alone gives the two strongest consistent harmonics at
        their levels (the bound of the module docstring); 1 with fewer than two."""
        found = sorted((ln for ln in self.harmonics_above), key=lambda ln: -ln.level_db)
        if len(found) < MIN_HARMONICS:
            return 1.0
        h = sum(1 for ln in self.lines if ln.role == "harmonic")
        p = h * (h - 1)
        for ln in found[:MIN_HARMONICS]:
            p *= line_false_alarm(ln.level_db, int(2 * round(ln.window_hz / self.df) + 1))
        return float(min(1.0, p))

    @property
    def measured_ratio(self) -> float | None:
        """F'/F: the family's measured frequency over its theory (None without anchor)."""
        base = next((ln for ln in self.lines if ln.name == self.base), None)
        if self.fundamental_hz is None or base is None:
            return None
        return self.fundamental_hz / base.theory_hz

    def as_dict(self) -> dict:
        return {"family": self.name, "base": self.base, "threshold_db": self.threshold_db,
                "clear": self.clear, "harmonics_above": len(self.harmonics_above),
                "sidebands_above": len(self.sidebands_above), "score_db": self.score,
                "false_alarm": self.false_alarm, "anchor": self.anchor,
                "fundamental_hz": self.fundamental_hz, "measured_ratio": self.measured_ratio,
                "note": self.note, "lines": [ln.as_dict() for ln in self.lines]}


def shaft_mask(size: int, df: float, shaft_hz: float, speed_tolerance: float) -> np.ndarray:
    """True at the bins of the shaft harmonics nX (n ≥ 1): within ``MIN_WINDOW_BINS`` + 1
    bins plus ``speed_tolerance``·nX of each. A line there is the shaft's."""
    f = np.arange(size) * df
    n = np.maximum(np.rint(f / shaft_hz), 1.0)
    return np.abs(f - n * shaft_hz) <= (MIN_WINDOW_BINS + 1) * df + speed_tolerance * n * shaft_hz


def explained_mask(size: int, df: float, frequencies: list[float]) -> np.ndarray:
    """True within ±``TIGHT`` (at least ``MIN_WINDOW_BINS`` bins) of each frequency (Hz)."""
    mask = np.zeros(size, dtype=bool)
    for f in frequencies:
        half = max(TIGHT * f, MIN_WINDOW_BINS * df)
        mask[max(0, math.floor((f - half) / df)):min(size, math.ceil((f + half) / df) + 1)] = True
    return mask


def masked(searched: np.ndarray, f: float, df: float) -> bool:
    """Whether the bin of ``f`` (Hz) is left out (a shaft harmonic's, or a line a clearer
    family explains): a line there cannot be told from that one, so it is not searched."""
    i = round(f / df)
    return 0 <= i < searched.size and searched[i] == 0


def _search(searched: np.ndarray, amplitude: np.ndarray, df: float, f: float, half: float
            ) -> tuple[float | None, float | None]:
    """(frequency Hz, level dB) of the line in [f − half, f + half]: the largest bin of
    ``searched`` (the spectrum with the excluded bins zeroed) that is a local maximum of
    ``amplitude``, its frequency interpolated (log-parabolic, exact for a Gaussian peak and
    close for Hann); Nones when there is none, when ``f`` itself is left out (``masked``)
    or when the bin found lies beside a left-out bin (a left-out line's flank)."""
    lo = max(1, math.floor((f - half) / df))
    hi = min(amplitude.size - 2, math.ceil((f + half) / df))
    if hi < lo or not searched[lo:hi + 1].any() or masked(searched, f, df):
        return None, None
    i = lo + int(np.argmax(searched[lo:hi + 1]))
    if not (amplitude[i] > amplitude[i - 1] and amplitude[i] >= amplitude[i + 1]):
        return None, None  # the window's largest bin is on the flank of a line outside it
    if searched[i - 1] == 0 or searched[i + 1] == 0:
        return None, None  # beside a left-out line: its flank, not a line of its own
    floor = noise_floor(amplitude, i, FLOOR_BINS)
    if not floor > 0:
        return None, None
    a, b, c = np.log(np.maximum(amplitude[i - 1:i + 2], 1e-300))
    denom = a - 2 * b + c
    shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
    return (i + shift) * df, 20.0 * math.log10(amplitude[i] / floor)


def _modulation(family: str, table: dict[str, float], shaft_hz: float) -> float:
    """The sideband spacing of a family (Hz): X for the inner race, FTF for the ball."""
    return {"inner-race": shaft_hz, "ball": table["FTF"]}.get(family, 0.0)


def _order(name: str, base: str) -> int:
    """h of a harmonic's name (``3BPFI`` -> 3, ``BPFI`` -> 1)."""
    head = name[:-len(base)]
    return int(head) if head else 1


def _harmonic_name(base: str, h: int) -> str:
    return base if h == 1 else f"{h}{base}"


@dataclass(frozen=True)
class Spectrum:
    """An envelope spectrum prepared for the search: amplitude, bin width, the bins left
    out (shaft harmonics, lines explained by another family)."""

    amplitude: np.ndarray
    df: float
    excluded: np.ndarray

    @property
    def searched(self) -> np.ndarray:
        return np.where(self.excluded, 0.0, self.amplitude)


def family_evidence(name: str, spec: Spectrum, table: dict[str, float], shaft_hz: float,
                    rel_window: float = REL_WINDOW, excluded_note: str = "") -> Family:
    """The evidence of family ``name`` in ``spec`` for the defect frequencies ``table`` (Hz)
    at shaft frequency ``shaft_hz`` (module docstring)."""
    amplitude, df = spec.amplitude, spec.df
    searched = spec.searched
    top = (amplitude.size - 1) * df
    base = BASE[name]
    spacing = _modulation(name, table, shaft_hz)
    harmonics = [h for h in range(1, HARMONICS[name] + 1)
                 if h * table[base] * (1 + rel_window) + spacing < top]
    wide = {h: max(rel_window * h * table[base], MIN_WINDOW_BINS * df) for h in harmonics}
    wide_bins = max((2 * round(w / df) + 1 for w in wide.values()), default=1)
    tight_bins = max((2 * round(max(TIGHT * h * table[base], MIN_WINDOW_BINS * df) / df) + 1
                      for h in harmonics), default=1)
    threshold = threshold_db(wide_bins, tight_bins, len(harmonics))
    first = {h: _search(searched, amplitude, df, h * table[base], wide[h]) for h in harmonics}
    best: tuple[tuple[bool, int, float], int, list[Line]] | None = None
    for h, (found, level) in first.items():
        if found is None or level is None or level < threshold:
            continue
        lines = _consistent(name, h, found / h, first, spec, table, shaft_hz, threshold,
                            wide)
        trial = Family(name, base, threshold, tuple(lines), df)
        key = (trial.clear, len(trial.harmonics_above), trial.score)
        if best is None or key > best[0]:
            best = (key, h, lines)
    if best is None:  # no harmonic passes: the wide search is the evidence
        lines = []
        for h in harmonics:
            found, level = first[h]
            f = h * table[base]
            lines.append(Line(_harmonic_name(base, h), "harmonic", f, f, wide[h], found, level,
                              f / shaft_hz, None if found is None else found / shaft_hz,
                              note=MASKED if masked(searched, f, df) else ""))
        return Family(name, base, threshold, tuple(lines), df, note=excluded_note)
    _, h, lines = best
    fundamental = first[h][0] / h  # type: ignore[operator]
    return Family(name, base, threshold, tuple(lines), df, _harmonic_name(base, h),
                  fundamental, excluded_note)


def _consistent(name: str, anchor: int, fundamental: float, first: dict, spec: Spectrum,
                table: dict[str, float], shaft_hz: float, threshold: float, wide: dict
                ) -> list[Line]:
    """The family's lines searched around multiples of ``fundamental`` (the anchor's own
    line as found by the wide search)."""
    base = BASE[name]
    spacing = _modulation(name, table, shaft_hz)
    searched = spec.searched
    lines = []
    for h in first:
        f = h * table[base]
        centre = h * fundamental
        if h == anchor:
            found, level = first[h]
            half = wide[h]
            centre = f
        else:
            half = max(TIGHT * centre, MIN_WINDOW_BINS * spec.df)
            found, level = _search(searched, spec.amplitude, spec.df, centre, half)
        lines.append(_line(_harmonic_name(base, h), "harmonic", f, centre, half, found, level,
                           shaft_hz, threshold,
                           MASKED if masked(searched, centre, spec.df) else ""))
        if spacing:
            tag = "X" if name == "inner-race" else "FTF"
            for sign in (-1, 1):
                c = h * fundamental + sign * spacing
                half = max(TIGHT * c, MIN_WINDOW_BINS * spec.df)
                if name == "ball":  # the cage's own slip moves FTF by up to REL_WINDOW
                    half += REL_WINDOW * spacing
                found, level = _search(searched, spec.amplitude, spec.df, c, half)
                lines.append(_line(f"{_harmonic_name(base, h)}{'+' if sign > 0 else '-'}{tag}",
                                   "sideband", f + sign * spacing, c, half, found, level,
                                   shaft_hz, threshold))
    return lines


def _line(name: str, role: str, theory: float, centre: float, half: float,
          found: float | None, level: float | None, shaft_hz: float, threshold: float,
          note: str = "") -> Line:
    return Line(name, role, theory, centre, half, found, level, theory / shaft_hz,
                None if found is None else found / shaft_hz,
                bool(level is not None and level >= threshold), note)


MASKED = "on a left-out line (a shaft harmonic nX, or a clearer family's): not searched"
"""The note of a line whose own frequency is left out."""


def explained_frequencies(family: Family, table: dict[str, float], shaft_hz: float,
                          top_hz: float) -> list[float]:
    """The frequencies (Hz) a clear family accounts for: its harmonics h·F' (h up to the
    top of the spectrum; the cage only its ``HARMONICS``), for the inner race with ±m·X
    sidebands and for the ball with ±m·FTF (m ≤ ``SIDEBAND_ORDERS``); the ball also
    accounts for FTF and its harmonics (the cage's modulation of a ball defect shows at
    FTF itself)."""
    if family.fundamental_hz is None:
        return []
    f0 = family.fundamental_hz
    spacing = _modulation(family.name, table, shaft_hz)
    out = []
    # the cage claims only the harmonics it was searched for: BPFO = z·FTF exactly, so its
    # higher harmonics would hide an outer race's lines
    last = HARMONICS["cage"] if family.name == "cage" else int(top_hz / f0)
    for h in range(1, last + 1):
        out.append(h * f0)
        for m in range(1, SIDEBAND_ORDERS + 1 if spacing else 1):
            out += [h * f0 - m * spacing, h * f0 + m * spacing]
    if family.name == "ball":
        out += [m * table["FTF"] for m in range(1, HARMONICS["cage"] + 1)]
    return [f for f in out if 0 < f < top_hz]


def all_families(amplitude: np.ndarray, df: float, table: dict[str, float], shaft_hz: float,
                 rel_window: float = REL_WINDOW, speed_tolerance: float = 0.001
                 ) -> dict[str, Family]:
    """Every family's evidence, the shaft harmonics left out (``speed_tolerance``: the
    speed's relative uncertainty); then, strongest clear family first, the lines each clear
    family explains left out of the families not yet judged, which are judged again."""
    base = shaft_mask(amplitude.size, df, shaft_hz, speed_tolerance)
    spec = Spectrum(amplitude, df, base)
    families = {n: family_evidence(n, spec, table, shaft_hz, rel_window) for n in FAMILIES}
    judged: list[str] = []
    top = (amplitude.size - 1) * df
    while True:
        pending = [f for n, f in families.items() if n not in judged and f.clear]
        if not pending:
            return families
        winner = max(pending, key=lambda f: f.score)
        judged.append(winner.name)
        freqs = explained_frequencies(winner, table, shaft_hz, top)
        mask = explained_mask(amplitude.size, df, freqs)
        spec = Spectrum(amplitude, df, spec.excluded | mask)
        note = (f"lines that {winner.name} ({winner.anchor} at "
                f"{winner.fundamental_hz:.2f} Hz) explains are left out")
        for n in FAMILIES:
            if n not in judged:
                earlier = families[n].note
                families[n] = family_evidence(n, spec, table, shaft_hz, rel_window,
                                              "; ".join(s for s in (earlier, note) if s))
