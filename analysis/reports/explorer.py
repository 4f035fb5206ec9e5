"""The chart explorer: one self-contained HTML page for a stability chart.

The page holds the chart as a clickable map (one cell per grid point, coloured by its class)
and, for the point clicked, its spectra, its Poincaré maps and its numbers (class, period,
largest Lyapunov exponent with its 95 % interval, amplitudes, the labelled peaks). Its
script, its style and its data are inline: it opens from disk with no network.

A chart file stores per point only what classifies it (``analysis.sweeps.chart``), not the
motion. The detail is therefore computed here, at export time, point by point: the run the
chart point made (same model, balls, parameters, RK4 step, transient and number of section
periods; the tangent dynamics left out), its amplitude spectra (``amplitude_spectrum``,
peak-preserving thinned to ``spectrum_bins`` bins up to the plots' upper frequency) and its
section (``poincare_section``). That costs one simulation per point, about what the chart
point cost without its Lyapunov exponent, and runs on any executor of
``analysis.sweeps.executors``. Numbers return here as plain data; the page is made by
``explorer_html``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import BearingdynError, InputError, check_count
from analysis.io import atomic_write, open_result
from analysis.provenance import displacement_names, plain, provenance
from analysis.stability.classify import NATURE_COLORS
from analysis.sweeps.grid import Setting

SPECTRUM_BINS = 400
"""Default number of spectrum bins kept per variable (peak-preserving thinning)."""
MAX_SECTION_POINTS = 400
"""Most Poincaré points kept per point (the first ones)."""
PEAKS_SHOWN = 6
"""Peaks named per variable (the largest; ``find_peaks`` refines only those that can rank
among them)."""


def _setting_of_chart(chart: xr.Dataset) -> Setting:
    """The ``Setting`` a chart was computed with, from its attrs (``Setting.from_attrs``;
    an old chart file's base balls and speed under its axes are dropped), without λ1."""
    attrs = chart.attrs
    if attrs.get("kind") != "chart":
        raise InputError(f"chart file: kind must be 'chart', got {attrs.get('kind')!r} "
                         "(make one with `bearingdyn chart`)")
    setting = Setting.from_attrs(attrs, (str(attrs["x"]), str(attrs["y"])))
    return replace(setting, lyapunov=False)


def point_detail(task: tuple) -> dict[str, Any]:
    """Spectra, Poincaré points and peaks of one chart point (``task``: setting, x name,
    x value, y name, y value); ``{"error": message}`` when its run fails."""
    from analysis.provenance import vc_frequencies
    from analysis.reports.labels import default_partner, display_label, f_max_of
    from analysis.signal.poincare import poincare_section
    from analysis.signal.spectrum import amplitude_spectrum, find_peaks
    from analysis.sweeps.chart import classified_section
    from analysis.sweeps.grid import record

    setting, xname, xv, yname, yv, bins = task
    try:
        system = setting.system_at(**{xname: xv, yname: yv})
        run = record(setting, system)
        spectra, sections, peaks = {}, [], []
        for var in displacement_names(run):
            amp = amplitude_spectrum(run, var)
            found = find_peaks(run, var, max_peaks=PEAKS_SHOWN, spectrum=amp)
            f_max = f_max_of(run.attrs)
            if f_max:  # the plots' range, reaching every peak of the table
                top = max((p.frequency_hz for p in found), default=0.0)
                amp = amp.sel(frequency=slice(0.0, max(f_max, 1.06 * top)))
            f, a = _thinned(amp.frequency.values, amp.values, bins)
            spectra[var] = {"f": _floats(f), "a": _floats(a),
                            "units": str(amp.attrs.get("units", ""))}
            peaks += [{"var": var, "label": p.label, "name": display_label(p.name),
                       "f": p.frequency_hz, "a": p.amplitude} for p in found]
        points = poincare_section(run, classified_section(setting, system)).isel(
            k=slice(0, MAX_SECTION_POINTS))
        for var in displacement_names(run):
            partner = default_partner(run, var)
            sections.append({"x": var, "y": partner, "xu": str(run[var].attrs.get("units", "")),
                             "yu": str(run[partner].attrs.get("units", "")),
                             "px": _floats(points[var].values),
                             "py": _floats(points[partner].values)})
        vcs = vc_frequencies(run.attrs)
        return {"spectra": spectra, "sections": sections, "peaks": peaks,
                "shaft_hz": float(run.attrs.get("shaft_hz", 0.0)),
                "vc_hz": float(run.attrs.get("vc_hz", 0.0)),
                "vc": {(f"VC[{b}]" if b else "VC"): f for b, f in vcs.items()}}
    except BearingdynError as exc:
        return {"error": str(exc)}


def _thinned(f: np.ndarray, a: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``bins`` (f, a) pairs: in each group of neighbouring bins the largest one, so
    no peak is lost."""
    if f.size <= bins:
        return f, a
    groups = np.array_split(np.arange(f.size), bins)
    top = np.array([g[np.argmax(a[g])] for g in groups])
    return f[top], a[top]


def _floats(values) -> list[float | None]:
    """Plain floats to 6 significant digits (what a figure can show; the page stays small),
    None for NaN."""
    return [float(f"{float(v):.6g}") if math.isfinite(float(v)) else None
            for v in np.ravel(values)]


def explorer_data(chart: xr.Dataset, *, spectrum_bins: int = SPECTRUM_BINS, executor=None,
                  progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Everything the page shows, as plain data: the grid and each point's chart values
    and detail (see the module docstring), the chart's provenance."""
    from analysis.model import load_model
    from analysis.sweeps.executors import SerialExecutor

    check_spectrum_bins(spectrum_bins)
    setting = _setting_of_chart(chart)
    xname, yname = str(chart.attrs["x"]), str(chart.attrs["y"])
    xs, ys = chart[xname].values.tolist(), chart[yname].values.tolist()
    units = load_model(setting.model).units
    fields = [v for v in chart.data_vars if chart[v].dims == (yname, xname)]
    tasks = [(setting, xname, xv, yname, yv, spectrum_bins) for yv in ys for xv in xs]
    details: dict[tuple[float, float], dict] = {}
    executor = executor or SerialExecutor()
    for task, detail in executor.run(point_detail, tasks):
        details[(task[2], task[4])] = detail
        if progress:
            progress(len(details), len(tasks))
    points = []
    for iy, yv in enumerate(ys):
        for ix, xv in enumerate(xs):
            values = {f: plain(chart[f].values[iy, ix], finite=True) for f in fields}
            points.append({"ix": ix, "iy": iy, "x": xv, "y": yv, **values,
                           "detail": details[(xv, yv)]})
    field_units = {f: str(chart[f].attrs.get("units", "")) for f in fields}
    return {"model": str(chart.attrs["model"]), "x": xname, "y": yname, "xs": xs, "ys": ys,
            "x_units": units.get(xname, "balls" if xname.startswith("n_balls") else ""),
            "y_units": units.get(yname, "balls" if yname.startswith("n_balls") else ""),
            "section": str(chart.attrs["section"]), "units": field_units, "points": points,
            "provenance": provenance(chart)}


def explorer_html(data: dict[str, Any]) -> str:
    """The self-contained page (inline style, script and data) for ``explorer_data``."""
    payload = json.dumps(data, allow_nan=False, separators=(",", ":"))
    payload = payload.replace("</", "<\\/")  # never ends the script element
    title = f"bearingdyn chart explorer: {data['model']}"
    return (_PAGE.replace("__TITLE__", _escape(title))
            .replace("__STYLE__", _STYLE)
            .replace("__SCRIPT__", _SCRIPT.replace("__COLORS__", json.dumps(NATURE_COLORS)))
            .replace("__DATA__", payload))


def _escape(text: str) -> str:
    from html import escape

    return escape(text)


def check_spectrum_bins(spectrum_bins: int) -> None:
    """``InputError`` unless ``spectrum_bins`` (bins kept per spectrum) is a whole number
    >= 16."""
    check_count("spectrum_bins", spectrum_bins, 16)


def load_chart(chart_file: str | Path) -> xr.Dataset:
    """The chart file ``chart_file``, read and judged (a stability chart of `bearingdyn
    chart` whose setting can be rebuilt), or ``InputError``: checked before any work."""
    chart = open_result(chart_file)
    _setting_of_chart(chart)
    return chart


def write_explorer(chart_file: str | Path | xr.Dataset, output: str | Path, *,
                   spectrum_bins: int = SPECTRUM_BINS, executor=None,
                   progress: Callable[[int, int], None] | None = None) -> Path:
    """Read a chart file (or take a chart read by ``load_chart``), compute each point's
    detail and write the page atomically."""
    chart = chart_file if isinstance(chart_file, xr.Dataset) else load_chart(chart_file)
    page = explorer_html(explorer_data(chart, spectrum_bins=spectrum_bins, executor=executor,
                                       progress=progress))
    return atomic_write(output, lambda tmp: tmp.write_text(page, encoding="utf-8"))


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>__TITLE__</title><style>__STYLE__</style></head>
<body>
<header><h1>__TITLE__</h1><p id="subtitle"></p></header>
<main>
<section id="map-panel"><h2>Stability chart</h2>
<p class="hint">Click a point to see its spectra, its Poincaré maps and its numbers.</p>
<svg id="map" role="img" aria-label="stability chart"></svg><div id="legend"></div></section>
<section id="detail"><h2 id="detail-title">No point selected</h2>
<table id="numbers"></table><div id="spectra"></div><div id="sections"></div>
<table id="peaks"></table></section>
</main>
<footer id="provenance"></footer>
<script type="application/json" id="chart-data">__DATA__</script>
<script>__SCRIPT__</script>
</body></html>
"""

_STYLE = """
body{font-family:system-ui,sans-serif;margin:0 1.2em;color:#222}
h1{font-size:1.3em;margin:.6em 0 .1em}h2{font-size:1.05em;margin:.4em 0}
main{display:flex;flex-wrap:wrap;gap:1.5em}
#map-panel{flex:0 0 auto}#detail{flex:1 1 480px;min-width:420px}
.hint,#subtitle{color:#555;font-size:.9em;margin:.2em 0}
svg text{font-size:11px;fill:#333}.cell{stroke:#fff;stroke-width:1;cursor:pointer}
.cell:hover{stroke:#000}.cell.selected{stroke:#000;stroke-width:3}
.multistable{stroke:#000;stroke-width:1.6;pointer-events:none}
#legend span{display:inline-block;margin-right:1em;font-size:.85em}
#legend i{display:inline-block;width:.9em;height:.9em;margin-right:.3em;vertical-align:middle}
table{border-collapse:collapse;font-size:.88em;margin:.3em 0}
td,th{padding:1px 8px;text-align:left;border-bottom:1px solid #eee}
.plot{display:inline-block;margin:0 .6em .4em 0}.axis{stroke:#444}.grid{stroke:#eee}
.line{fill:none;stroke:#1f5fa8;stroke-width:1.2}.dot{fill:#b8322a}.mark{fill:#b8322a}
svg text.peak-name{font-size:9px;fill:#222}
footer{color:#666;font-size:.8em;margin:1.2em 0;word-break:break-all}
"""

_SCRIPT = r"""
"use strict";
const D = JSON.parse(document.getElementById("chart-data").textContent);
const NS = "http://www.w3.org/2000/svg";
const COLORS = __COLORS__;  // nature_code -> colour: analysis.stability.classify.NATURES
const SCALES = {"m": [1e6, "µm"], "m/s": [1e3, "mm/s"], "rad": [1e6, "µrad"],
                "rad/s": [1e3, "mrad/s"]};
function colour(p) {
  return COLORS[p.nature_code] || "#999";
}
function el(name, attrs, parent) {
  const e = document.createElementNS(NS, name);
  for (const k in attrs) e.setAttribute(k, attrs[k]);
  if (parent) parent.appendChild(e);
  return e;
}
function fmt(v, digits) {
  if (v === null || v === undefined) return "–";
  if (typeof v !== "number") return String(v);
  return Number(v.toPrecision(digits || 4)).toString();
}
function ticks(a, b) {
  const raw = (b - a) / 4, mag = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 2.5, 5, 10].map(m => m * mag).find(s => s >= raw) || raw;
  const out = [];
  for (let v = Math.ceil(a / step) * step; v <= b + step * 1e-9; v += step)
    out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return out;
}
function scale(unit) { return SCALES[unit] || [1, unit]; }
function axisName(name, unit) { return unit ? `${name} (${unit})` : name; }

function drawMap() {
  const svg = document.getElementById("map");
  const nx = D.xs.length, ny = D.ys.length;
  const cw = Math.max(8, Math.min(40, Math.floor(560 / nx)));
  const ch = Math.max(8, Math.min(40, Math.floor(420 / ny)));
  const left = 60, top = 10, w = cw * nx, h = ch * ny;
  svg.setAttribute("width", left + w + 20);
  svg.setAttribute("height", top + h + 50);
  for (const p of D.points) {
    const r = el("rect", {x: left + p.ix * cw, y: top + (ny - 1 - p.iy) * ch, width: cw,
                          height: ch, fill: colour(p), class: "cell",
                          "data-ix": p.ix, "data-iy": p.iy}, svg);
    const t = el("title", {}, r);
    t.textContent = `${D.x} = ${fmt(p.x)}, ${D.y} = ${fmt(p.y)}: ${p.nature}` +
      (p.n_attractors !== undefined ?
        `; ${p.n_attractors} attractor(s) among the --ics states` : "");
    r.addEventListener("click", () => select(p, r));
    if (p.multistable === 1) {  // chart --ics: two or more attractors coexist here
      const x0 = left + p.ix * cw, y0 = top + (ny - 1 - p.iy) * ch;
      el("path", {d: `M${x0 + 2} ${y0 + ch - 2} L${x0 + cw - 2} ${y0 + 2}`,
                  class: "multistable"}, svg);
    }
  }
  const every = (n) => Math.max(1, Math.ceil(n / 8));
  D.xs.forEach((v, i) => { if (i % every(nx) === 0) {
    const t = el("text", {x: left + (i + 0.5) * cw, y: top + h + 14, "text-anchor": "middle"}, svg);
    t.textContent = fmt(v); } });
  D.ys.forEach((v, i) => { if (i % every(ny) === 0) {
    const t = el("text", {x: left - 4, y: top + (ny - i - 0.5) * ch + 4,
                          "text-anchor": "end"}, svg);
    t.textContent = fmt(v); } });
  const xl = el("text", {x: left + w / 2, y: top + h + 34, "text-anchor": "middle"}, svg);
  xl.textContent = axisName(D.x, D.x_units);
  const yl = el("text", {x: 12, y: top + h / 2, "text-anchor": "middle",
                         transform: `rotate(-90 12 ${top + h / 2})`}, svg);
  yl.textContent = axisName(D.y, D.y_units);
  const seen = [...new Set(D.points.map(p => p.nature))];
  document.getElementById("legend").innerHTML = seen.map(n =>
    `<span><i style="background:${colour(D.points.find(p => p.nature === n))}"></i>${n}</span>`
  ).join("") + (D.points.some(p => p.multistable === 1) ?
    "<span id='multistable-key'>╱ multistable (two or more attractors among the --ics " +
    "initial states)</span>" : "");
}

function plot(container, title, xs, ys, xlabel, ylabel, kind, marks) {
  const W = kind === "spectrum" ? 340 : 300, H = kind === "spectrum" ? 250 : 220;
  const L = 58, R = 10, T = 22, B = 38;
  const div = document.createElement("div");
  div.className = "plot";
  container.appendChild(div);
  const svg = el("svg", {width: W, height: H, class: kind}, div);
  const good = xs.map((x, i) => [x, ys[i]]).filter(([x, y]) => x !== null && y !== null);
  const xv = good.map(g => g[0]), yv = good.map(g => g[1]);
  let x0 = Math.min(...xv), x1 = Math.max(...xv), y0 = Math.min(...yv), y1 = Math.max(...yv);
  if (kind === "spectrum") { x0 = 0; y0 = 0; y1 *= 1.5; }  // room for the peak names
  if (!(x1 > x0)) { x0 -= 1; x1 += 1; }
  if (!(y1 > y0)) { const d = Math.abs(y0) * 0.1 || 1; y0 -= d; y1 += d; }
  if (kind !== "spectrum") {  // every point inside the axes, none on their lines
    const dx = 0.06 * (x1 - x0), dy = 0.06 * (y1 - y0);
    x0 -= dx; x1 += dx; y0 -= dy; y1 += dy;
  }
  const px = x => L + (x - x0) / (x1 - x0) * (W - L - R);
  const py = y => H - B - (y - y0) / (y1 - y0) * (H - T - B);
  el("line", {x1: L, y1: H - B, x2: W - R, y2: H - B, class: "axis"}, svg);
  el("line", {x1: L, y1: T, x2: L, y2: H - B, class: "axis"}, svg);
  for (const v of ticks(x0, x1))
    el("text", {x: px(v), y: H - B + 13, "text-anchor": "middle"}, svg).textContent = fmt(v, 3);
  for (const v of ticks(y0, y1))
    el("text", {x: L - 3, y: py(v) + 4, "text-anchor": "end"}, svg).textContent = fmt(v, 3);
  el("text", {x: (L + W - R) / 2, y: H - 4, "text-anchor": "middle"}, svg).textContent = xlabel;
  el("text", {x: 11, y: (T + H - B) / 2, "text-anchor": "middle",
              transform: `rotate(-90 11 ${(T + H - B) / 2})`}, svg).textContent = ylabel;
  el("text", {x: L, y: 14}, svg).textContent = title;
  if (kind === "spectrum") {
    const d = good.map(([x, y], i) => `${i ? "L" : "M"}${px(x).toFixed(1)},${py(y).toFixed(1)}`);
    el("path", {d: d.join(""), class: "line"}, svg);
    const placed = [];  // the peaks named on the plot, larger first, labels kept apart
    for (const m of (marks || [])) {
      if (m.f < x0 || m.f > x1) continue;
      const x = px(m.f), y = py(m.a), w = 5.2 * m.name.length + 4;
      el("path", {d: `M${x - 3},${y - 7}L${x + 3},${y - 7}L${x},${y - 2}Z`, class: "mark"},
         svg);
      const cx = Math.min(Math.max(x, L + w / 2), W - R - w / 2);  // inside the axes
      let ty = y - 9;
      while (placed.some(([u, v, uw]) => Math.abs(u - cx) < (w + uw) / 2 &&
                                         Math.abs(v - ty) < 11)) ty -= 11;
      placed.push([cx, ty, w]);
      el("text", {x: cx, y: Math.max(ty, T + 8), "text-anchor": "middle",
                  class: "peak-name"}, svg).textContent = m.name;
    }
  } else {
    for (const [x, y] of good) el("circle", {cx: px(x), cy: py(y), r: 1.8, class: "dot"}, svg);
  }
}

function select(p, rect) {
  document.querySelectorAll(".cell.selected").forEach(c => c.classList.remove("selected"));
  rect.classList.add("selected");
  rect.parentNode.appendChild(rect);  // drawn last: its outline on top of its neighbours
  const d = p.detail || {};
  document.getElementById("detail-title").textContent =
    `${D.x} = ${fmt(p.x)} ${D.x_units}, ${D.y} = ${fmt(p.y)} ${D.y_units}: ${p.nature}`;
  const rows = [["class", p.nature], ["period (section samples)", p.period || "–"]];
  if (p.lyapunov !== undefined)
    rows.push(["largest Lyapunov exponent", `${fmt(p.lyapunov)} ± ${fmt(p.ci95, 2)} 1/s (95 %)`]);
  for (const k in p) if (k.startsWith("amplitude_")) {
    const [f, u] = scale(D.units[k] || "m");
    rows.push([`amplitude of ${k.slice(10)}`, `${fmt(p[k] * f)} ${u}`]);
  }
  if (d.shaft_hz) rows.push(["X (shaft)", `${fmt(d.shaft_hz)} Hz`]);
  const vcs = d.vc || (d.vc_hz ? {"VC": d.vc_hz} : {});
  for (const name in vcs) rows.push([name, `${fmt(vcs[name])} Hz`]);
  if (d.error) rows.push(["detail", d.error]);
  document.getElementById("numbers").innerHTML =
    rows.map(([k, v]) => `<tr><th>${k}</th><td>${v}</td></tr>`).join("");
  const spectra = document.getElementById("spectra");
  const sections = document.getElementById("sections");
  spectra.innerHTML = ""; sections.innerHTML = "";
  for (const v in (d.spectra || {})) {
    const s = d.spectra[v], [f, u] = scale(s.units);
    const marks = (d.peaks || []).filter(k => k.var === v)
      .map(k => ({f: k.f, a: k.a * f, name: k.name || k.label || `${fmt(k.f, 4)} Hz`}));
    plot(spectra, `spectrum of ${v}`, s.f, s.a.map(a => a === null ? null : a * f),
         "frequency (Hz)", `amplitude (${u})`, "spectrum", marks);
  }
  for (const s of (d.sections || [])) {
    const [fx, ux] = scale(s.xu), [fy, uy] = scale(s.yu);
    plot(sections, `Poincaré map (${D.section} section)`, s.px.map(x => x * fx),
         s.py.map(y => y * fy), axisName(s.x, ux), axisName(s.y, uy), "poincare");
  }
  document.getElementById("peaks").innerHTML = (d.peaks || []).length ?
    "<tr><th>variable</th><th>peak</th><th>frequency (Hz)</th><th>amplitude</th></tr>" +
    d.peaks.map(k => { const [f, u] = scale((d.spectra[k.var] || {}).units);
      return `<tr><td>${k.var}</td><td>${k.name || (k.label || "?").replace("-", "−")}</td>` +
             `<td>${fmt(k.f, 5)}</td><td>${fmt(k.a * f, 3)} ${u}</td></tr>`; }).join("") : "";
}

document.getElementById("subtitle").textContent =
  `${D.points.length} points, ${D.y} × ${D.x}; classes on the ${D.section} section`;
const P = D.provenance;
document.getElementById("provenance").textContent =
  `model ${P.model}, spec ${P.spec_file} (sha256 ${P.spec_sha256}), bearingdyn ` +
  `${P.bearingdyn_version}, generator ${P.generator}`;
drawMap();
"""
