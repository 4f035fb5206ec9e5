"""Reproduce the seed paper: its Table 2 and Figs. 2-6 next to what the equations give, and how
the verdicts depend on the parameters the paper does not state.

``reproduce()`` computes; ``analysis.reports.report.write_reproduction`` renders the report
folder. The paper's own data (Table 2, the omitted quantities' ranges) is in
``analysis.reports.paper``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import xarray as xr

from analysis.errors import InputError
from analysis.integrate.simulate import check_run, simulate
from analysis.model import as_system, load_model
from analysis.provenance import run_attrs
from analysis.reports.paper import (
    PAPER_NATURE,
    PAPER_TABLE2,
    SENSITIVITY,
    PaperRow,
    case_verdict,
    check_one_bearing,
    major_name,
    nature_matches,
    other_peak_names,
    series_f_max,
    simulate_case,
)
from analysis.signal.spectrum import Peak
from analysis.stability.classify import default_section, verdict_points
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.executors import Executor
from analysis.sweeps.grid import Axis, Setting, check_grid, section_period


@dataclass
class Row:
    """Our result for one N_b, with the paper's row (None for N_b outside Table 2)."""

    n_balls: int
    peaks: dict[str, list[Peak]]
    nature: str
    detail: str
    lyapunov: float
    ci95: float
    figure: Path
    netcdf: Path
    paper: PaperRow | None = None

    def major(self, var: str) -> str:
        return major_name(self.peaks[var])

    def others(self, var: str) -> list[str]:
        """The other labelled peaks of ``var`` (the paper's "other peaks" column)."""
        return other_peak_names(self.peaks[var], named_only=True)

    def marks(self) -> dict[str, bool | None]:
        """Per column: True (matches the paper), False, or None (not counted: the paper has
        no value there, i.e. no row for this N_b or an empty cell)."""
        if self.paper is None:
            nature = PAPER_NATURE.get(self.n_balls)
            return {"nature": None if nature is None else nature_matches(nature, self.nature)}
        p = self.paper
        return {"major_x": self.major("x") == p.major_x, "major_y": self.major("y") == p.major_y,
                "others_x": _listed(p.others_x, [*self.others("x"), self.major("x")]),
                "others_y": _listed(p.others_y, [*self.others("y"), self.major("y")]),
                "nature": nature_matches(p.nature, self.nature)}

    def differences(self) -> dict[str, tuple[list[str], list[str]]]:
        """Per column that differs from the paper (a ✗): (what the paper has that we have
        not, what we have that the paper has not)."""
        p, marks, out = self.paper, self.marks(), {}
        for key, ok in marks.items():
            if ok is not False:
                continue
            if key == "nature":
                paper = PAPER_NATURE[self.n_balls] if p is None else p.nature
                out[key] = ([paper], [self.nature])
            elif key.startswith("major"):
                var = key[-1]
                out[key] = ([getattr(p, key)], [self.major(var)])
            else:
                var = key[-1]
                ours = [self.major(var), *self.others(var)]
                theirs = list(getattr(p, key))
                out[key] = ([n for n in theirs if n not in ours],
                            [n for n in self.others(var) if n not in theirs])
        return out


def _listed(paper: Sequence[str], ours: Sequence[str]) -> bool | None:
    """Every peak the paper lists is among ours (None: the paper lists none, not counted)."""
    return None if not paper else set(paper) <= set(ours)


@dataclass
class Reproduction:
    model: str
    rows: list[Row]
    sensitivity: dict[str, xr.Dataset] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    wall_s: float = 0.0
    calibrated_model: str | None = None
    """A calibrated model run beside ``model`` (``reproduce(calibrated=…)``), or None."""
    calibrated: dict[int, tuple[str, float, float]] = field(default_factory=dict)
    """Per N_b the calibrated model's class, λ1 and its 95 % half-width (1/s)."""

    def reproduced_ranges(self) -> dict[str, list[float]]:
        """For each varied parameter, the values at which every N_b gets the paper's class."""
        out = {}
        for name, chart in self.sensitivity.items():
            ok = []
            for value in chart[name].values:
                col = chart.sel({name: value})
                if all(nature_matches(PAPER_NATURE[int(nb)], str(col.sel(n_balls=nb).nature.item()))
                       for nb in chart.n_balls.values if int(nb) in PAPER_NATURE):
                    ok.append(float(value))
            out[name] = ok
        return out


def _sensitivity_axes(name: str, values: Sequence[float],
                      n_balls: Sequence[int]) -> tuple[Axis, Axis]:
    """The axes of one sensitivity chart: ``name`` over ``values``, and the balls."""
    return (Axis(name, tuple(float(v) for v in values)),
            Axis("n_balls", tuple(float(n) for n in n_balls)))


def check_reproduction(model: str, n_balls: Sequence[int] = (5, 6, 7, 8, 9, 10), *,
                       duration: float = 3.0, transient: float = 1.0, revolutions: int = 200,
                       sensitivity: dict[str, Sequence[float]] | None = None) -> None:
    """Raise ``InputError`` (or ``SpecError``) before anything is written when any part of
    the reproduction would be refused: the model, every N_b's run (times in s, the step)
    and every sensitivity chart's grid."""
    check_one_bearing(model, "model", "the reproduction")
    for nb in n_balls:
        check_run(model, nb, duration=duration, transient=transient)
        system = as_system(model, nb)
        section = default_section(run_attrs(system.model, system.structure,
                                            dict(system.parameters)))
        period, least = section_period(system, section), verdict_points() + 1
        if (duration - transient) / period < least:
            raise InputError(f"duration: must be at least {transient + least * period:.4g} s "
                             f"(the transient and {least} {section} periods of "
                             f"{period * 1e3:.4g} ms: a verdict needs them at N_b = {nb}), "
                             f"got {duration:g} s")
    setting = Setting(model, None, {}, transient, revolutions)
    for name, values in (SENSITIVITY if sensitivity is None else sensitivity).items():
        check_grid(setting, *_sensitivity_axes(name, values, n_balls))


def reproduce(
    out_dir: str | Path,
    model: str = "vakharia2015",
    n_balls: Sequence[int] = (5, 6, 7, 8, 9, 10),
    *,
    duration: float = 3.0,
    transient: float = 1.0,
    revolutions: int = 200,
    sensitivity: dict[str, Sequence[float]] | None = None,
    quick: bool = False,
    calibrated: str | None = None,
    executor: Executor | None = None,
    log: Callable[[str], None] | None = None,
    progress_factory: Callable[[str], Callable[[int, int], None]] | None = None,
) -> Reproduction:
    """Simulate the paper's case for each N_b (``duration`` s, the first ``transient`` s
    dropped), classify it with its largest Lyapunov exponent, and chart the verdicts over
    the ``sensitivity`` ranges (default ``SENSITIVITY``). Results go to ``out_dir``.
    ``quick`` marks the result as a smoke test (the report says so at the top).
    ``calibrated``: a second model (e.g. ``paper.CALIBRATED_MODEL``) run and classified the
    same way at every N_b, its classes shown beside the paper's and ``model``'s."""
    start = time.perf_counter()
    out = Path(out_dir)
    charts_of = SENSITIVITY if sensitivity is None else sensitivity
    check_reproduction(model, n_balls, duration=duration, transient=transient,
                       revolutions=revolutions, sensitivity=charts_of)
    if calibrated is not None:
        check_reproduction(calibrated, n_balls, duration=duration, transient=transient,
                           sensitivity={})
    (out / "runs").mkdir(parents=True, exist_ok=True)
    mdl = load_model(model)
    f_max = series_f_max(mdl, n_balls)  # one frequency range for every N_b's figure
    rows = []
    for nb in n_balls:
        nc, png = out / "runs" / f"nb{nb}.nc", out / f"fig-nb{nb}.png"
        ds, peaks = simulate_case(mdl, nb, nc, png, f_max, duration=duration,
                                  transient=transient)
        verdict = case_verdict(ds)  # λ1 over the recorded span, as `run`'s table
        rows.append(Row(nb, peaks, verdict.nature, verdict.detail,
                        verdict.largest_exponent, verdict.ci95, png, nc,
                        PAPER_TABLE2.get(nb)))
        if log:
            log(f"N_b = {nb}: {verdict.nature} (λ1 = {rows[-1].lyapunov:.3g} ± "
                f"{rows[-1].ci95:.2g} 1/s)")
    beside = {}
    for nb in n_balls if calibrated is not None else ():
        verdict = case_verdict(simulate(calibrated, nb, duration=duration,
                                        transient=transient))
        beside[nb] = (verdict.nature, verdict.largest_exponent, verdict.ci95)
        if log:
            log(f"N_b = {nb}, {calibrated}: {verdict.nature}")
    charts = {}
    setting = Setting(model, None, {}, transient, revolutions)
    for name, values in charts_of.items():
        progress = progress_factory(f"sensitivity {name}") if progress_factory else None
        charts[name] = stability_chart(setting, *_sensitivity_axes(name, values, n_balls),
                                       out / "runs" / f"sensitivity-{name}.nc",
                                       executor=executor, progress=progress)
    return Reproduction(model, rows, charts,
                        {"duration": duration, "transient": transient,
                         "revolutions": revolutions, "n_balls": list(n_balls),
                         "quick": bool(quick)},
                        time.perf_counter() - start, calibrated, beside)

