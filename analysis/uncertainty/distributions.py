"""Distributions of uncertain parameters: ``NAME=uniform:LO:HI``, ``NAME=normal:MEAN:SD``,
``NAME=lognormal:MEDIAN:FACTOR`` (SI units, speed in rpm).

Each is a ``scipy.stats`` distribution whose support is checked against the parameter's
allowed range (``Model.parameters`` refuses a value outside it): a uniform or lognormal
reaching outside is refused; the tails of a normal or lognormal (unbounded) are truncated to
the allowed range (the inverse CDF taken over the kept probability only) and ``Dist.note``
says so, with the probability cut off. A zero
spread (LO = HI, SD = 0, FACTOR = 1) is a point mass at that value: the study then reduces
to the deterministic point. The lognormal's FACTOR is its geometric standard deviation:
log(value) is normal with mean log(MEDIAN) and standard deviation log(FACTOR).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from analysis.errors import InputError
from analysis.model import Model

KINDS = ("uniform", "normal", "lognormal")
"""The distributions ``--dist`` knows."""
NOT_UNCERTAIN = ("n_balls",)
"""Names that are not runtime parameters (the balls are swept with ``--n-balls``)."""


@dataclass(frozen=True)
class Dist:
    """One uncertain parameter: ``name``, ``kind`` and its two numbers ``a``, ``b`` as the
    command line gives them (uniform: LO, HI; normal: MEAN, SD; lognormal: MEDIAN,
    FACTOR), with ``lo``, ``hi`` the truncation of a normal to the allowed range (±inf:
    none)."""

    name: str
    kind: str
    a: float
    b: float
    lo: float = -math.inf
    hi: float = math.inf
    note: str = ""
    """What was done to fit the allowed range ('' when nothing)."""

    @property
    def degenerate(self) -> bool:
        """A zero spread: every draw is the same value."""
        return (self.kind == "uniform" and self.a == self.b) or \
            (self.kind == "normal" and self.b == 0) or (self.kind == "lognormal" and
                                                        self.b == 1)

    @property
    def centre(self) -> float:
        """The value of a zero spread (and the middle of the distribution)."""
        return float(self.ppf(np.array([0.5]))[0])

    def frozen(self):
        """The ``scipy.stats`` distribution before truncation (None for a zero spread)."""
        if self.degenerate:
            return None
        if self.kind == "uniform":
            return stats.uniform(loc=self.a, scale=self.b - self.a)
        if self.kind == "normal":
            return stats.norm(loc=self.a, scale=self.b)
        return stats.lognorm(s=math.log(self.b), scale=self.a)

    def cut(self) -> float:
        """The probability the truncation to [``lo``, ``hi``] cuts off."""
        dist = self.frozen()
        return 0.0 if dist is None else float(dist.cdf(self.lo) + dist.sf(self.hi))

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Values at probabilities ``u`` in (0, 1): the inverse CDF of the distribution
        truncated to [``lo``, ``hi``]."""
        u = np.asarray(u, dtype=float)
        dist = self.frozen()
        if dist is None:
            return np.full(u.shape, self.a)
        if self.kind == "uniform":
            return np.asarray(dist.ppf(u), dtype=float)
        below, above = float(dist.cdf(self.lo)), float(dist.sf(self.hi))
        if below == 0.0 and above == 0.0:
            return np.asarray(dist.ppf(u), dtype=float)
        values = dist.ppf(below + u * (1.0 - below - above))
        return np.clip(np.asarray(values, dtype=float), self.lo, self.hi)

    def text(self) -> str:
        """As the command line writes it: ``radial_clearance=uniform:5e-06:2e-05``."""
        return f"{self.name}={self.kind}:{self.a:g}:{self.b:g}"


def parse_dist(text: str) -> Dist:
    """``NAME=uniform:LO:HI``, ``NAME=normal:MEAN:SD`` or ``NAME=lognormal:MEDIAN:FACTOR``
    (``InputError`` naming ``--dist`` and what is wrong: an unknown distribution, a
    non-number, a negative spread, HI < LO, a lognormal's MEDIAN <= 0 or FACTOR < 1)."""
    name, eq, rest = str(text).partition("=")
    name = name.strip()
    parts = rest.split(":")
    form = "NAME=uniform:LO:HI, NAME=normal:MEAN:SD or NAME=lognormal:MEDIAN:FACTOR"
    if not eq or not name or len(parts) != 3:
        raise InputError(f"dist: must be {form}, got {text!r}", field="dist")
    kind = parts[0].strip().lower()
    if kind not in KINDS:
        raise InputError(f"dist {name}: unknown distribution {parts[0]!r}; "
                         f"known: {', '.join(KINDS)}", field="dist")
    try:
        a, b = float(parts[1]), float(parts[2])
    except ValueError:
        raise InputError(f"dist {name}: the two numbers must be numbers, "
                         f"got {text!r}", field="dist") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise InputError(f"dist {name}: the two numbers must be finite, got {text!r}", field="dist")
    if kind == "uniform" and b < a:
        raise InputError(f"dist {name}: a negative spread: HI must be >= LO, got LO = "
                         f"{a:g}, HI = {b:g}", field="dist")
    if kind == "normal" and b < 0:
        raise InputError(f"dist {name}: a negative spread: SD must be >= 0, got {b:g}",
                         field="dist")
    if kind == "lognormal" and (a <= 0 or b < 1):
        raise InputError(f"dist {name}: a lognormal needs MEDIAN > 0 and FACTOR >= 1 (its "
                         f"geometric standard deviation), got MEDIAN = {a:g}, "
                         f"FACTOR = {b:g}", field="dist")
    return Dist(name, kind, a, b)


def allowed_range(model: Model, name: str) -> tuple[float, float, bool]:
    """(low, high, low inclusive) of a parameter of ``model``: where
    ``Model.parameters`` accepts it."""
    low, high, inclusive = model.module.RANGES[name]
    return float(low), float(high), bool(inclusive)


def _inside(model: Model, dist: Dist, value: float, what: str) -> None:
    try:
        model.parameters({dist.name: value})
    except InputError as exc:
        raise InputError(f"dist {dist.name}: its support reaches outside the parameter's "
                         f"allowed range at its {what} ({exc})", field="dist") from None


def fit_to_model(dist: Dist, model: Model) -> Dist:
    """``dist`` checked against ``model``: a runtime parameter of it, a uniform's ends (or a
    zero spread's value) inside the allowed range, a normal's mean or a lognormal's median
    inside it and its tails truncated to it (``note`` says so, with the share of probability
    cut off)."""
    if dist.name in NOT_UNCERTAIN:
        raise InputError(f"dist {dist.name}: the balls are swept with --n-balls, not drawn",
                         field="dist")
    if dist.name not in model.parameter_names:
        raise InputError(f"dist {dist.name}: not a parameter of model '{model.name}' "
                         f"({', '.join(model.parameter_names)})", field="dist")
    low, high, _ = allowed_range(model, dist.name)
    if dist.degenerate or dist.kind == "uniform":
        _inside(model, dist, dist.a, "low end" if not dist.degenerate else "value")
        _inside(model, dist, dist.b if dist.kind == "uniform" else dist.a, "high end")
        return dist
    _inside(model, dist, dist.a, "median" if dist.kind == "lognormal" else "mean")
    truncated = Dist(dist.name, dist.kind, dist.a, dist.b, low, high)
    cut = truncated.cut()
    note = ""
    if cut > 0:
        note = (f"{dist.name}: the {dist.kind} is truncated to the allowed range [{low:g}, "
                f"{high:g}] {model.units.get(dist.name, '')}: {cut:.3g} of its probability "
                "lies outside and is cut off")
    return Dist(dist.name, dist.kind, dist.a, dist.b, low, high, note)


def check_dists(dists: Sequence[Dist | str], model: Model,
                sets: dict[str, float] | None = None,
                swept: str | None = None) -> tuple[Dist, ...]:
    """Parse and check every distribution against ``model``: at least one, each parameter
    once, none also given a fixed value (``sets``, ``--set``) or swept (``swept``)."""
    parsed = [d if isinstance(d, Dist) else parse_dist(d) for d in dists]
    if not parsed:
        raise InputError("dist: give at least one, NAME=uniform:LO:HI|normal:MEAN:SD|"
                         "lognormal:MEDIAN:FACTOR", field="dist")
    seen: set[str] = set()
    out = []
    for dist in parsed:
        if dist.name in seen:
            raise InputError(f"dist {dist.name}: given twice", field="dist")
        seen.add(dist.name)
        if sets and dist.name in sets:
            raise InputError(f"dist {dist.name}: also given with --set; a parameter is "
                             "either uncertain (--dist) or fixed (--set)", field="dist")
        if swept is not None and dist.name == swept:
            raise InputError(f"dist {dist.name}: also the swept --param; a parameter is "
                             "either uncertain or swept", field="dist")
        out.append(fit_to_model(dist, model))
    return tuple(out)
