"""The seed paper's case, shared by the ``run`` job (``analysis.reports.report``) and the
reproduction (``analysis.reports.reproduce``): the paper's Table 2 as transcribed, the ranges
of the quantities it omits, the per-N_b step (simulate, write the run and its figure, find the
peaks) and the naming of peaks.

Dependencies go one way: ``paper`` ← ``reproduce`` (computes) ← ``report`` (renders).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from analysis.errors import InputError
from analysis.integrate.simulate import simulate
from analysis.io import save_dataset
from analysis.signal.spectrum import Peak, find_peaks

PAPER_N_BALLS = (6, 7, 8, 9, 10)
"""Table 2 of the paper."""


def check_one_bearing(model: str, option: str, job: str) -> None:
    """``InputError`` naming ``option`` unless ``model`` has one bearing: ``job`` (the
    paper's case, its reproduction) varies the number of balls N_b of that bearing."""
    from analysis.model import load_model

    loaded = load_model(model)
    if len(loaded.bearings) != 1:
        has = f"bearings {', '.join(loaded.bearing_names)}" if loaded.bearings else \
            "no bearing"
        raise InputError(f"{option}: {job} varies N_b, the balls of a model with one "
                         f"bearing; model '{loaded.name}' has {has}, got {model!r} (give such "
                         "a model, e.g. vakharia2015, or use `bearingdyn simulate`)")


@dataclass(frozen=True)
class PaperRow:
    """One row of the paper's Table 2 (labels in our ASCII form, e.g. ``VC-X``)."""

    major_x: str
    major_y: str
    others_x: tuple[str, ...]
    others_y: tuple[str, ...]
    nature: str
    """chaotic, quasi-periodic, or multi-orbit periodic (the paper's words)."""


PAPER_TABLE2: dict[int, PaperRow] = {
    6: PaperRow("2X", "X", ("X", "VC-X", "2X", "VC", "VC+X"), ("VC-X", "VC"), "chaotic"),
    7: PaperRow("X", "X", ("2X", "VC"), ("VC-X",), "quasi-periodic"),
    8: PaperRow("X", "X", ("2X", "VC-X", "VC", "VC+X"), (), "quasi-periodic"),
    9: PaperRow("X", "X", ("2X", "VC"), (), "quasi-periodic"),
    10: PaperRow("X", "X", ("2X", "VC-X", "VC"), (), "multi-orbit periodic"),
}
"""Table 2 of the paper, transcribed. N_b = 5 is only in the conclusions: 'chaotic'."""
PAPER_NATURE = {5: "chaotic", **{n: row.nature for n, row in PAPER_TABLE2.items()}}

CALIBRATED_MODEL = "vakharia2015-calibrated"
"""The paper-literal model at a point calibrated against Table 2 (``bearingdyn calibrate``,
target ``paper-table2``; docs/calibration.md)."""
EXPLANATION = ("Where the classes differ from the paper's: the paper gives no rotor mass, "
               "damping or contact stiffness; which values reproduce its Table 2 is answered "
               "in docs/calibration.md (\"Which parameters did the paper use?\", "
               "`bearingdyn calibrate`); model `vakharia2015-calibrated` runs such a point.")
"""The line under ``run``'s table that says where the explanation of a disagreement lives."""

SENSITIVITY: dict[str, tuple[float, ...]] = {
    "damping": (50.0, 100.0, 200.0, 300.0, 400.0),
    "rotor_mass": (0.3, 0.6, 0.9, 1.2),
    "contact_stiffness": tuple(7.055e9 * f for f in (0.8, 0.9, 1.0, 1.1, 1.2)),
}
"""Plausible ranges of the quantities the paper omits (N·s/m, kg, N/m^1.5)."""


def nature_matches(paper: str, ours: str) -> bool:
    """Whether our class agrees with the paper's word for it."""
    if paper == "multi-orbit periodic":
        return ours.startswith("periodic-") and ours != "periodic-1"
    return ours == paper


def major_name(peaks: Sequence[Peak]) -> str:
    """Name of the largest peak (``-`` when there is none; ``Peak.name``: its label, or an
    unnamed peak's frequency)."""
    return peaks[0].name if peaks else "-"


def other_peak_names(peaks: Sequence[Peak], named_only: bool = False) -> list[str]:
    """The distinct names of the peaks after the largest (``peaks`` largest first), in
    their order; with ``named_only``, only labelled peaks and never the largest's name (the
    paper's "other peaks" column, which lists combinations only)."""
    names: list[str] = []
    major = major_name(peaks)
    for p in peaks[1:]:
        if p.name in names or (named_only and (not p.label or p.name == major)):
            continue
        names.append(p.name)
    return names


def series_f_max(model, n_balls: Sequence[int], **parameters: float) -> float | None:
    """One upper frequency (Hz) for the spectra of a series of N_b: the largest of the
    runs' own ranges (2.5 (VC + X) of the largest VC), known before any run."""
    from analysis.reports.plots import series_f_max as largest

    values = model.parameters(parameters)
    return largest([model.frequencies(nb, values).as_dict() for nb in n_balls])


def case_verdict(ds, progress=None):
    """The motion class of one N_b's run ``ds`` (``analysis.stability.classify``) with its
    largest Lyapunov exponent λ1 (1/s, 95 % interval), averaged over the whole recorded
    span (the run's duration − transient) from the record's first state, with the run's
    model, parameters and step: what ``reproduce`` computes for its Table 2. Returns the
    ``Classification`` (its ``largest_exponent``, ``ci95`` always set)."""
    from dataclasses import replace

    from analysis.provenance import state_at, system_of_attrs
    from analysis.stability.classify import classify
    from analysis.stability.lyapunov import lyapunov

    system = system_of_attrs(ds.attrs, state_at(ds, 0))
    exps = lyapunov(system, duration=float(ds.attrs["duration"] - ds.attrs["transient"]),
                    transient=0.0, n_exponents=1, dt=float(ds.attrs["dt"]), progress=progress)
    verdict = classify(ds, exponents=exps)
    return replace(verdict, largest_exponent=float(exps.exponents[0]),
                   ci95=float(exps.ci95[0]))


def paper_nature(model: str, n_balls: int) -> str:
    """The paper's class for ``n_balls`` (Table 2, or its conclusions for N_b = 5), or
    ``-`` for an N_b it does not report or a model that is not the paper's
    (``vakharia2015…``)."""
    if not str(model).startswith("vakharia2015"):
        return "-"
    return PAPER_NATURE.get(n_balls, "-")


def simulate_case(model, n_balls: int, netcdf: Path, figure: Path,
                  f_max: float | None = None, **kwargs):
    """Simulate one N_b, write its run and its paper figure (spectra up to ``f_max`` Hz and
    Poincaré maps, x and y), and return the run and its labelled peaks per direction."""
    # matplotlib is imported only when a figure is drawn (it costs the CLI a second)
    from analysis.reports.plots import paper_figure, save_figure

    ds = simulate(model, n_balls, **kwargs)
    save_dataset(ds, netcdf)
    save_figure(paper_figure(ds, f_max=f_max), figure)
    return ds, {var: find_peaks(ds, var) for var in ("x", "y")}
