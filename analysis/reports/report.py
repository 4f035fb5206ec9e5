"""Rendering for people: the paper's case as a job (simulate N_b = 6…10, write results,
figures and a peak table) and the reproduction report (``reproduce()``'s result as Markdown,
HTML and JSON). The computation is in ``analysis.reports.paper`` and
``analysis.reports.reproduce``; this module imports them, never the other way round."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from analysis.errors import InputError
from analysis.io import atomic_write
from analysis.model import load_model
from analysis.provenance import provenance
from analysis.reports.paper import (
    EXPLANATION,
    PAPER_N_BALLS,
    PAPER_NATURE,
    SENSITIVITY,
    case_verdict,
    major_name,
    nature_matches,
    other_peak_names,
    paper_nature,
    series_f_max,
    simulate_case,
)
from analysis.reports.reproduce import Reproduction
from analysis.signal.spectrum import Peak
from analysis.stability.classify import Classification


@dataclass
class CaseResult:
    """One simulated N_b: its files, labelled spectral peaks (x and y) and motion class
    (``verdict``, with λ1; None when not computed), beside the paper's (``paper``)."""

    n_balls: int
    netcdf: Path
    figure: Path
    peaks: dict[str, list[Peak]]
    wall_s: float
    frequencies: dict[str, float] = field(default_factory=dict)
    verdict: Classification | None = None
    paper: str = "-"
    unclassified: str = ""
    """Why ``verdict`` is None ('' when it was not asked for): e.g. a record too short."""

    def motion(self) -> str:
        """The class as the table shows it (``-`` when not computed)."""
        return self.verdict.label if self.verdict else "-"

    def exponent(self) -> str:
        """λ1 ± its 95 % half-width (1/s) as the table shows it."""
        v = self.verdict
        if v is None or v.largest_exponent is None:
            return "-"
        return f"{v.largest_exponent:.3g} ± {v.ci95:.2g}"

    def major(self, var: str) -> str:
        return major_name(self.peaks[var])

    def others(self, var: str) -> str:
        """The other peaks of ``var`` as text (``-`` for none)."""
        return ", ".join(other_peak_names(self.peaks[var])) or "-"


def run_paper_case(
    out_dir: str | Path = "bearingdyn-out",
    model: str = "vakharia2015",
    n_balls: Sequence[int] = PAPER_N_BALLS,
    duration: float | None = None,
    transient: float | None = None,
    progress: Callable[[str], None] | None = None,
    classify: bool = True,
    **parameters: float,
) -> list[CaseResult]:
    """Simulate each N_b, save ``nb<N>.nc`` and ``nb<N>.png`` in ``out_dir``, classify its
    motion with λ1 over the recorded span (``case_verdict``; ``classify=False``: not), and
    write ``peaks.md`` and ``peaks.json`` (the table: peaks, the paper's class and ours).
    Returns one result per N_b."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    mdl = load_model(model)
    f_max = series_f_max(mdl, n_balls, **parameters)  # one frequency range for the series
    results = []
    for i, nb in enumerate(n_balls):
        start = time.perf_counter()
        nc, png = out / f"nb{nb}.nc", out / f"nb{nb}.png"
        ds, peaks = simulate_case(mdl, nb, nc, png, f_max, duration=duration,
                                  transient=transient, **parameters)
        verdict, why = None, ""
        if classify:
            try:
                verdict = case_verdict(ds)
            except InputError as exc:  # a record too short for a verdict: said, not fatal
                why = str(exc).removeprefix("run: ")
        results.append(CaseResult(nb, nc, png, peaks, time.perf_counter() - start,
                                  {k: ds.attrs[k] for k in ("shaft_hz", "cage_hz", "vc_hz")},
                                  verdict, paper_nature(mdl.name, nb), why))
        if progress:
            said = f", {results[-1].motion()} (λ1 = {results[-1].exponent()} 1/s)" \
                if verdict else (f", not classified: {why}" if why else "")
            progress(f"[{i + 1}/{len(n_balls)}] N_b = {nb}: {png}{said} "
                     f"({results[-1].wall_s:.1f} s)")
    atomic_write(out / "peaks.md", lambda tmp: tmp.write_text(
        peak_table_markdown(results) + explanation_note(results)))
    atomic_write(out / "peaks.json", lambda tmp: tmp.write_text(json.dumps(
        [{"n_balls": r.n_balls, **r.frequencies,
          "peaks": {v: [p.as_dict() for p in ps] for v, ps in r.peaks.items()},
          "paper_nature": r.paper,
          "classification": r.verdict.as_dict() if r.verdict else None,
          **({"not_classified": r.unclassified} if r.unclassified else {}),
          "provenance": provenance(r.netcdf)}
         for r in results], indent=2)))
    return results


def peak_table_markdown(results: Sequence[CaseResult]) -> str:
    """The shape of the paper's Table 2: the peaks, the paper's class of motion (Table 2,
    ``-`` where it gives none) and this model's (``classify`` with λ1 and its 95 %
    interval, over the recorded span)."""
    lines = ["| N_b | VC (Hz) | major peak, x | major peak, y | other peaks, x | other peaks, y "
             "| class (paper) | class (this model) | λ1 (1/s, 95 %) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r.n_balls} | {r.frequencies['vc_hz']:.1f} | {r.major('x')} | "
                     f"{r.major('y')} | {r.others('x')} | {r.others('y')} | {r.paper} | "
                     f"{r.motion()} | {r.exponent()} |")
    return "\n".join(lines) + "\n"


def explanation_note(results: Sequence[CaseResult]) -> str:
    """The line under ``run``'s table saying where a disagreement with the paper is
    explained ('' for a model that is not the paper's)."""
    return f"\n{EXPLANATION}\n" if any(r.paper != "-" for r in results) else ""


# --- the reproduction report --------------------------------------------------------------

def _mark(ok: bool | None, diff: tuple[list[str], list[str]] | None = None,
          peaks: bool = True) -> str:
    """✓, or ✗ naming what is missing (the paper's, not ours) and what is extra (ours, not
    the paper's); nothing for a cell that is not counted. ``peaks``: the names are peak
    labels (printed with a unicode minus), else words (classes)."""
    if ok is None:
        return ""
    if ok:
        return " ✓"
    missing, extra = diff or ([], [])
    show = _labels if peaks else (lambda names: ", ".join(names) or "–")
    return f" ✗ (missing: {show(missing)}; extra: {show(extra)})"


def _labels(names) -> str:
    return ", ".join(n.replace("-", "−") for n in names) or "–"


SMOKE_TEST = """
> **Smoke test (`--quick`), not a reproduction.** {duration:g} s simulated ({transient:g} s
> dropped), {revolutions} revolutions per sensitivity point and two values per parameter:
> the verdicts below are not reliable. Run `bearingdyn reproduce` without `--quick` for the
> report.
"""

MULTI_ORBIT = """
The paper's "multi-orbit periodic" (N_b = 10) is not one of the classes this tool gives
(periodic-1, periodic-2, periodic-n for n ≥ 3, quasi-periodic, chaotic). It is counted as
agreeing with periodic-n for n ≥ 2 (an orbit that closes after several shaft revolutions:
several points on the shaft section). A two-frequency torus (quasi-periodic, locked to X
and VC) also draws several closed curves on that section, and the paper may have meant
that; the table does not count it as agreeing, and says so here rather than choose.
"""

TABLE_HEAD = ("| N_b | major peak, x | major peak, y | other peaks, x | other peaks, y | nature | "
              "largest Lyapunov exponent (1/s, 95 %) |\n|---|---|---|---|---|---|---|")


def reproduction_markdown(rep: Reproduction, figure_names: dict[str, str]) -> str:
    """The report as Markdown (figures referenced by file name)."""
    model = load_model(rep.model)
    rows = []
    matched = total = 0
    for r in rep.rows:
        m, p, d = r.marks(), r.paper, r.differences()
        matched += sum(1 for v in m.values() if v)
        total += sum(1 for v in m.values() if v is not None)

        def cell(paper_value, ours, key, m=m, d=d):
            return f"{paper_value} / {ours}{_mark(m.get(key), d.get(key), key != 'nature')}"

        if p is None:
            paper_nature = PAPER_NATURE.get(r.n_balls, "–")
            rows.append(f"| {r.n_balls} | – / {_labels([r.major('x')])} | – / "
                        f"{_labels([r.major('y')])} | – / "
                        f"{_labels(r.others('x'))} | – / {_labels(r.others('y'))} | "
                        f"{paper_nature} (conclusions) / {r.nature}"
                        f"{_mark(m['nature'], d.get('nature'), peaks=False)} | "
                        f"{r.lyapunov:.3g} ± {r.ci95:.2g} |")
        else:
            rows.append(
                f"| {r.n_balls} | "
                f"{cell(_labels([p.major_x]), _labels([r.major('x')]), 'major_x')} | "
                f"{cell(_labels([p.major_y]), _labels([r.major('y')]), 'major_y')} | "
                f"{cell(_labels(p.others_x), _labels(r.others('x')), 'others_x')} | "
                f"{cell(_labels(p.others_y), _labels(r.others('y')), 'others_y')} | "
                f"{cell(p.nature, r.nature, 'nature')} | {r.lyapunov:.3g} ± {r.ci95:.2g} |")
    ranges = rep.reproduced_ranges()
    sens = []
    for name, chart in rep.sensitivity.items():
        ok = ranges[name]
        unit = model.units.get(name, "")
        verdict = (f"the paper's classes for every N_b at {', '.join(f'{v:g}' for v in ok)} "
                   f"{unit}" if ok else "the paper's classes are reproduced at none of the "
                   "values tried")
        sens.append(f"### {name} ({unit})\n\nValues tried: "
                    f"{', '.join(f'{v:g}' for v in chart[name].values)} {unit}. Result: "
                    f"{verdict}.\n\n![{name}]({figure_names['sens-' + name]})\n")
    figures = "\n".join(f"![N_b = {r.n_balls}]({figure_names[f'nb{r.n_balls}']})\n"
                        for r in rep.rows)
    params = "\n".join(f"| `{n}` | {v:g} | {model.units[n]} | {model.sources[n]} |"
                       for n, v in model.defaults.items())
    gen = model.module.GENERATOR
    files = ", ".join(f"`generated/{model.name.replace('-', '_')}/{f}`" for f in
                      ("__init__.py", f"{model.name.replace('-', '_')}.c", "MODEL.md"))
    default_ranges = ", ".join(f"{k} {min(v):g}–{max(v):g} {model.units.get(k, '')}".rstrip()
                               for k, v in SENSITIVITY.items())
    smoke = SMOKE_TEST.format(**rep.settings) if rep.settings.get("quick") else ""
    return f"""# Reproduction of Vakharia, Gupta, Kankar: Table 2 and Figs. 2–6
{smoke}
Model `{rep.model}` (the paper as written; mass, stiffness and damping are assumptions the
paper does not state). {matched} of {total} comparable cells agree with the paper
(✓ agree, ✗ differ, naming what is missing, the paper's, and what is extra, ours). Each
cell reads *paper / this model*; "other peaks" agree when every peak the paper lists is
among ours; cells where the paper gives nothing (–) are shown but not counted.

## Table 2

{TABLE_HEAD}
{chr(10).join(rows)}

Nature: periodic-n, quasi-periodic (a two-frequency torus locked to X and VC, or a frequency
of its own) or chaotic, from the shaft-synchronous Poincaré points and the largest Lyapunov
exponent (`analysis.stability.classify`).
{MULTI_ORBIT}
{_calibrated_table(rep)}Run: {rep.settings['duration']:g} s simulated, the first
{rep.settings['transient']:g} s dropped, fixed-step RK4 with Δt = 1e-5 s.

## Figures 2–6 redrawn

Spectra of x and y with the peaks named as combinations of X and VC, and shaft-synchronous
Poincaré maps.

{figures}
## Sensitivity to what the paper omits

The paper gives no rotor mass, contact stiffness or damping. Each chart below varies one of
them over a plausible range (default ranges: {default_ranges}), the others at their assumed
values, and classifies every N_b; {rep.settings['revolutions']} shaft revolutions after a
{rep.settings['transient']:g} s transient per point.

{chr(10).join(sens)}
## Provenance

- model `{model.name}`, spec sha256 `{model.spec_sha256}`
- generated code: {files}
- generator: bearingdyn {gen['bearingdyn']}, SymPy {gen['sympy']}, CasADi {gen['casadi']}
- run with: {_versions()}
- wall time {rep.wall_s:.0f} s

| parameter | value | unit | source |
|---|---|---|---|
{params}
"""


def _calibrated_table(rep: Reproduction) -> str:
    """The classes side by side, paper / default model / calibrated model, when the
    reproduction ran a calibrated model too (``reproduce(calibrated=…)``), else ''."""
    if not rep.calibrated:
        return ""
    lines = [f"### Classes: the paper, `{rep.model}` and `{rep.calibrated_model}`", "",
             f"| N_b | paper | `{rep.model}` (assumed values) | `{rep.calibrated_model}` "
             "(calibrated, docs/calibration.md) |", "|---|---|---|---|"]
    for r in rep.rows:
        paper = PAPER_NATURE.get(r.n_balls, "–")
        nature, lam, ci = rep.calibrated[r.n_balls]
        marks = ["" if paper == "–" else (" ✓" if nature_matches(paper, ours) else " ✗")
                 for ours in (r.nature, nature)]
        lines.append(f"| {r.n_balls} | {paper} | {r.nature}{marks[0]} (λ1 = "
                     f"{r.lyapunov:.3g} ± {r.ci95:.2g}) | {nature}{marks[1]} (λ1 = "
                     f"{lam:.3g} ± {ci:.2g}) |")
    return "\n".join(lines) + "\n\n" + EXPLANATION + "\n\n"


def _versions() -> str:
    import platform
    from importlib import metadata

    names = ("bearingdyn", "casadi", "numpy", "scipy", "xarray", "matplotlib")
    found = []
    for name in names:
        try:
            found.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            found.append(f"{name} (source tree)")
    return ", ".join(found) + f", Python {platform.python_version()}"


def write_reproduction(rep: Reproduction, out_dir: str | Path) -> dict[str, Path]:
    """Write report.md, report.html (figures embedded) and table2.json into ``out_dir``."""
    import base64

    import markdown

    from analysis.reports.plots import save_figure, sensitivity_figure

    out = Path(out_dir)
    units = load_model(rep.model).units
    names = {f"nb{r.n_balls}": r.figure.name for r in rep.rows}
    for name, chart in rep.sensitivity.items():
        path = out / f"sensitivity-{name}.png"
        save_figure(sensitivity_figure(chart, units.get(name, "")), path)
        names[f"sens-{name}"] = path.name
    text = reproduction_markdown(rep, names)
    body = markdown.markdown(text, extensions=["tables"])
    for file in set(names.values()):
        data = base64.b64encode((out / file).read_bytes()).decode()
        body = body.replace(f'src="{file}"', f'src="data:image/png;base64,{data}"')
    title = "bearingdyn: reproduction" + (" (smoke test, --quick)"
                                          if rep.settings.get("quick") else "")
    html = ("<!DOCTYPE html><html><head><meta charset='utf-8'><title>" + title +
            "</title><style>body{font-family:sans-serif;max-width:1100px;margin:auto;"
            "padding:1em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
            "padding:4px 8px;font-size:90%}img{max-width:100%}</style></head><body>"
            f"{body}</body></html>")
    table = [{"n_balls": r.n_balls, "major_x": r.major("x"), "major_y": r.major("y"),
              "others_x": r.others("x"), "others_y": r.others("y"), "nature": r.nature,
              "lyapunov": r.lyapunov, "ci95": r.ci95, "marks": r.marks(),
              "differences": {k: {"missing": m, "extra": e}
                              for k, (m, e) in r.differences().items()},
              "paper": None if r.paper is None else r.paper.__dict__,
              "provenance": provenance(r.netcdf)} for r in rep.rows]
    paths = {"markdown": out / "report.md", "html": out / "report.html",
             "json": out / "table2.json"}
    atomic_write(paths["markdown"], lambda tmp: tmp.write_text(text))
    atomic_write(paths["html"], lambda tmp: tmp.write_text(html))
    atomic_write(paths["json"], lambda tmp: tmp.write_text(json.dumps(
        {"smoke_test": bool(rep.settings.get("quick")), "settings": rep.settings,
         "ranges_reproducing_table2": rep.reproduced_ranges(), "rows": table}, indent=2,
        default=list)))
    return paths
