"""The paper's case as a job: simulate N_b = 6…10, write results, figures and a peak table."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from analysis.io import atomic_write, save_dataset
from analysis.model import load_model
from analysis.simulate import simulate
from analysis.spectrum import Peak, find_peaks

PAPER_N_BALLS = (6, 7, 8, 9, 10)
"""Table 2 of the paper."""


@dataclass
class CaseResult:
    """One simulated N_b: its files and labelled spectral peaks (x and y)."""

    n_balls: int
    netcdf: Path
    figure: Path
    peaks: dict[str, list[Peak]]
    wall_s: float
    frequencies: dict[str, float] = field(default_factory=dict)

    def major(self, var: str) -> str:
        return peak_name(self.peaks[var][0]) if self.peaks[var] else "-"

    def others(self, var: str) -> str:
        names = []
        for p in self.peaks[var][1:]:
            if peak_name(p) not in names:
                names.append(peak_name(p))
        return ", ".join(names) or "-"


def peak_name(peak: Peak) -> str:
    return peak.label if peak.label else f"{peak.frequency_hz:.0f} Hz"


def run_paper_case(
    out_dir: str | Path = "bearingdyn-out",
    model: str = "vakharia2015",
    n_balls: Sequence[int] = PAPER_N_BALLS,
    duration: float | None = None,
    transient: float | None = None,
    progress: Callable[[str], None] | None = None,
    **parameters: float,
) -> list[CaseResult]:
    """Simulate each N_b, save ``nb<N>.nc`` and ``nb<N>.png`` in ``out_dir``, and write
    ``peaks.md`` and ``peaks.json`` (the peak table). Returns one result per N_b."""
    from analysis.plots import paper_figure, save_figure

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    mdl = load_model(model)
    results = []
    for i, nb in enumerate(n_balls):
        start = time.perf_counter()
        ds = simulate(mdl, nb, duration=duration, transient=transient, **parameters)
        peaks = {var: find_peaks(ds, var) for var in ("x", "y")}
        nc, png = out / f"nb{nb}.nc", out / f"nb{nb}.png"
        save_dataset(ds, nc)
        save_figure(paper_figure(ds), png)
        results.append(CaseResult(nb, nc, png, peaks, time.perf_counter() - start,
                                  {k: ds.attrs[k] for k in ("shaft_hz", "cage_hz", "vc_hz")}))
        if progress:
            progress(f"[{i + 1}/{len(n_balls)}] N_b = {nb}: {png} "
                     f"({results[-1].wall_s:.1f} s)")
    atomic_write(out / "peaks.md", lambda tmp: tmp.write_text(peak_table_markdown(results)))
    atomic_write(out / "peaks.json", lambda tmp: tmp.write_text(json.dumps(
        [{"n_balls": r.n_balls, **r.frequencies,
          "peaks": {v: [p.as_dict() for p in ps] for v, ps in r.peaks.items()}}
         for r in results], indent=2)))
    return results


def peak_table_markdown(results: Sequence[CaseResult]) -> str:
    """The shape of the paper's Table 2 (without the nature-of-response column)."""
    lines = ["| N_b | VC (Hz) | major peak, x | major peak, y | other peaks, x | other peaks, y |",
             "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| {r.n_balls} | {r.frequencies['vc_hz']:.1f} | {r.major('x')} | "
                     f"{r.major('y')} | {r.others('x')} | {r.others('y')} |")
    return "\n".join(lines) + "\n"
