"""Figures that show what the text reports: PNG files carry their result's provenance (read
back with PIL), no axis shows an offset or a multiplier (µm in the labels instead), a
spectrum's range covers every peak the command prints, titles lie inside the figure (their
rendered extents against the figure's box), a many-state Lyapunov figure is scaled by its
converged values in distinct colours, the stiffness figure has one axes per unit over the
pitch 2π/N_b, and the explorer shows every bearing's VC and keeps its Poincaré points
inside their axes."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from PIL import Image

from analysis.reports.plots import (
    branch_figure,
    chart_figure,
    lyapunov_figure,
    save_figure,
    spectrum_figure,
    stiffness_figure,
)
from analysis.signal.spectrum import peak_table

X_HZ, VC_HZ = 83.3333, 199.34
PROVENANCE = {"model": "vakharia2015", "spec_file": "modelgen/specs/vakharia2015.toml",
              "spec_sha256": "ab" * 32, "bearingdyn_version": "9.9.9"}


def _run(lines, duration=1.0, dt=2e-4, **attrs):
    """A run whose x and y hold the sinusoids ``lines`` ((Hz, m) pairs)."""
    t = np.arange(0.0, duration, dt)
    x = sum(a * np.cos(2 * np.pi * f * t) for f, a in lines)
    y = sum(a * np.sin(2 * np.pi * f * t) for f, a in lines)
    data = {"x": ("t", x, {"units": "m"}), "y": ("t", y, {"units": "m"}),
            "vx": ("t", np.gradient(x, t), {"units": "m/s"}),
            "vy": ("t", np.gradient(y, t), {"units": "m/s"})}
    return xr.Dataset(data, coords={"t": t},
                      attrs={**PROVENANCE, "n_balls": 6, "speed_rpm": 5000.0,
                             "shaft_hz": X_HZ, "vc_hz": VC_HZ, "state_names": "x y vx vy",
                             "dt": dt, **attrs})


def _texts_inside(fig) -> None:
    """Every title, label and text of ``fig`` drawn inside the figure's box."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    texts = list(fig.texts)
    for ax in fig.axes:
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
    for text in texts:
        if not text.get_text() or not text.get_visible():
            continue
        ext = text.get_window_extent(renderer)
        assert ext.x0 >= box.x0 - 0.5 and ext.x1 <= box.x1 + 0.5, text.get_text()
        assert ext.y0 >= box.y0 - 0.5 and ext.y1 <= box.y1 + 0.5, text.get_text()


def _no_offsets(fig) -> None:
    fig.canvas.draw()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            assert axis.get_offset_text().get_text() == "", (ax.get_title(), axis)


def test_a_png_carries_the_model_spec_hash_and_version(tmp_path):
    from analysis.provenance import package_version

    path = tmp_path / "spectrum.png"
    save_figure(spectrum_figure(_run([(X_HZ, 2e-6), (VC_HZ, 1e-6)])), path)
    text = Image.open(path).text
    for key, value in PROVENANCE.items():
        assert text[key] == value
    assert text["Software"] == f"bearingdyn {package_version()}"
    svg = tmp_path / "spectrum.svg"
    save_figure(spectrum_figure(_run([(X_HZ, 2e-6)])), svg)
    assert f"spec_sha256={PROVENANCE['spec_sha256']}" in svg.read_text()


def test_the_plot_command_writes_the_runs_provenance(tmp_path, cli):
    from analysis import simulate

    ds = simulate("vakharia2015", n_balls=7, duration=0.25, transient=0.15)
    ds.to_netcdf(tmp_path / "run.nc")
    for option in ((), ("--orbit",)):
        out = tmp_path / f"fig{len(option)}.png"
        done = cli("plot", str(tmp_path / "run.nc"), *option, "-o", str(out))
        assert done.returncode == 0, done.stderr
        text = Image.open(out).text
        assert (text["model"], text["spec_sha256"]) == ("vakharia2015",
                                                        ds.attrs["spec_sha256"])
        assert text["spec_file"] == ds.attrs["spec_file"]
        assert text["bearingdyn_version"] == ds.attrs["bearingdyn_version"]


def test_the_spectrum_range_covers_every_printed_peak():
    """A line far above the default range (2.5 (VC + X) = 707 Hz) is printed, so drawn."""
    ds = _run([(X_HZ, 2e-6), (VC_HZ, 1e-6), (1733.0, 1.5e-6)])
    peaks = peak_table(ds, ("x", "y"))
    assert max(p.frequency_hz for p in peaks) == pytest.approx(1733.0, abs=1.0)
    fig = spectrum_figure(ds, peaks=peaks)
    for ax, var in zip(fig.axes, ("x", "y"), strict=True):
        top = max(p.frequency_hz for p in peaks if p.direction == var)
        assert ax.get_xlim()[1] >= top
        marked = [line for line in ax.lines if line.get_marker() == "v"
                  and len(line.get_xdata()) == 1]
        assert len(marked) == len([p for p in peaks if p.direction == var])


def test_long_titles_are_broken_to_fit_and_no_axis_has_an_offset():
    names = {f"bearing_number_{i}": 100.0 + 37 * i for i in range(6)}
    ds = _run([(X_HZ, 2e-6), (VC_HZ, 1e-6)], model="a-user-model-with-a-long-name",
              **{f"vc_hz_{k}": v for k, v in names.items()},
              **{f"n_balls_{k}": 9 for k in names})
    del ds.attrs["vc_hz"], ds.attrs["n_balls"]
    fig = spectrum_figure(ds)
    assert "\n" in fig._suptitle.get_text()
    _texts_inside(fig)
    _no_offsets(fig)


def test_continuation_and_chart_axes_are_in_micrometres():
    clearance = np.linspace(5e-6, 20e-6, 30)
    branch = xr.Dataset({"amplitude": ("radial_clearance", 1e-7 * (2 + np.sin(clearance * 4e5))),
                         "stable": ("radial_clearance", clearance < 12e-6),
                         "special": ("radial_clearance", np.array([""] * 30, dtype=object))},
                        coords={"radial_clearance": ("radial_clearance", clearance,
                                                     {"units": "m"})},
                        attrs={"param": "radial_clearance", "model": "vakharia2015",
                               "period": "vc", **PROVENANCE})
    fig = branch_figure([branch])
    ax = fig.axes[0]
    assert "µm" in ax.get_xlabel() and "µm" in ax.get_ylabel()
    _no_offsets(fig)
    _texts_inside(fig)
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert any(label in ("10", "15") for label in labels), labels
    chart = xr.Dataset({"nature_code": (("radial_clearance", "speed_rpm"),
                                        np.ones((3, 4), dtype=int)),
                        "lyapunov": (("radial_clearance", "speed_rpm"), -np.ones((3, 4)))},
                       coords={"speed_rpm": [4000.0, 5000.0, 6000.0, 7000.0],
                               "radial_clearance": ("radial_clearance", [5e-6, 1e-5, 2e-5],
                                                    {"units": "m"})},
                       attrs={"x": "speed_rpm", "y": "radial_clearance", **PROVENANCE})
    fig = chart_figure(chart)
    assert all("radial_clearance (µm)" == a.get_ylabel() for a in fig.axes[:2])
    _no_offsets(fig)


def _lyapunov_result(n=12):
    t = np.linspace(0.5, 3.0, 500)
    finals = np.linspace(40.0, -900.0, n)
    running = finals[:, None] + 5e4 * np.exp(-(t - 0.5) / 0.02)[None, :] * \
        np.cos(np.arange(n))[:, None]
    return xr.Dataset({"running": (("index", "t"), running),
                       "exponents": ("index", finals), "ci95": ("index", np.full(n, 5.0))},
                      coords={"index": np.arange(1, n + 1), "t": t},
                      attrs={**PROVENANCE, "shaft_hz": X_HZ, "vc_hz": VC_HZ, "n_balls": 6,
                             "speed_rpm": 5000.0, "sum_of_exponents": float(finals.sum()),
                             "mean_divergence": float(finals.sum())})


def test_a_many_state_lyapunov_figure_is_scaled_by_its_converged_values():
    result = _lyapunov_result()
    fig = lyapunov_figure(result)
    ax = fig.axes[0]
    low, high = ax.get_ylim()
    finals = result.exponents.values
    assert low <= finals.min() - 5 and high >= finals.max() + 5  # every value and interval
    assert high - low < 2 * (finals.max() - finals.min() + 10)  # not the 5e4 start-up swing
    colours = [tuple(np.round(np.atleast_1d(line.get_color()), 4)) if not isinstance(
        line.get_color(), str) else line.get_color() for line in ax.lines[:12]]
    assert len(set(colours)) == 12
    _texts_inside(fig)
    _no_offsets(fig)


@pytest.mark.parametrize("model, pitch_deg, units", [
    ("vakharia2015", 360 / 8, {"MN/m", "µm"}),
    ("two-bearing-rotor", 180.0, {"MN/m", "kN·m/rad", "µm", "µrad"})])
def test_the_stiffness_figure_has_one_axes_per_unit_over_the_pitch(model, pitch_deg, units):
    from analysis.model import as_system
    from analysis.stability.statics import coefficients

    ds = coefficients(as_system(model, 8 if model == "vakharia2015" else None), n_angles=12)
    fig = stiffness_figure(ds)
    shown = {label[label.rindex("(") + 1:-1] for label in
             (ax.get_ylabel() for ax in fig.axes)}
    assert shown == units and len(fig.axes) == len(units)
    for ax in fig.axes:
        ticks = ax.get_xticks()
        assert ticks[0] == 0 and ticks[-1] == pytest.approx(pitch_deg)
        assert ax.lines[0].get_xdata()[-1] == pytest.approx(pitch_deg)  # the pitch closed
        assert ax.get_legend() is not None
    _texts_inside(fig)
    _no_offsets(fig)


def test_the_explorer_names_every_bearings_vc_and_its_peaks():
    from analysis.reports.explorer import point_detail
    from analysis.sweeps.grid import Setting

    setting = Setting("two-bearing-rotor", None, {}, transient=0.1, samples=20,
                      lyapunov=False)
    detail = point_detail((setting, "speed_rpm", 5000.0, "radial_load", 40.0, 64))
    from analysis.model import load_model

    freqs = load_model("two-bearing-rotor").frequencies(None, {
        **load_model("two-bearing-rotor").defaults, "speed_rpm": 5000.0,
        "radial_load": 40.0})
    assert detail["vc"] == pytest.approx({"VC[left]": freqs.vc["left"],
                                          "VC[right]": freqs.vc["right"]})
    assert detail["peaks"] and all(p["name"] for p in detail["peaks"])
    for peak in detail["peaks"]:  # every peak of the table lies on the drawn spectrum
        assert peak["f"] <= max(detail["spectra"][peak["var"]]["f"])


def test_the_explorer_keeps_poincare_points_inside_their_axes(tmp_path):
    from analysis.reports.explorer import explorer_html
    from tests.browser import require_chromium, start_chromium

    require_chromium()
    rng = np.random.default_rng(1)
    px, py = rng.normal(size=60).tolist(), rng.normal(size=60).tolist()
    detail = {"spectra": {"x": {"f": [0.0, 100.0, 200.0], "a": [0.0, 1e-6, 0.0],
                                "units": "m"}},
              "sections": [{"x": "x", "y": "vx", "xu": "m", "yu": "m/s", "px": px,
                            "py": py}],
              "peaks": [{"var": "x", "label": "X", "name": "X", "f": 100.0, "a": 1e-6}],
              "shaft_hz": 100.0, "vc_hz": 0.0, "vc": {"VC[a]": 1.0, "VC[b]": 2.0}}
    data = {"model": "m", "x": "speed_rpm", "y": "n_balls", "xs": [1.0], "ys": [6],
            "x_units": "rpm", "y_units": "balls", "section": "shaft", "units": {},
            "points": [{"ix": 0, "iy": 0, "x": 1.0, "y": 6, "nature": "chaotic",
                        "nature_code": 5, "detail": detail}],
            "provenance": {k: "p" for k in ("model", "spec_file", "spec_sha256",
                                            "bearingdyn_version", "generator")}}
    page = tmp_path / "page.html"
    page.write_text(explorer_html(data), encoding="utf-8")
    session = start_chromium()
    browser = next(session)
    try:
        browser.get(page.as_uri())
        browser.find_element("css selector", "rect.cell").click()
        numbers = browser.find_element("id", "numbers").text
        assert "VC[a]" in numbers and "VC[b]" in numbers
        inside = browser.execute_script("""
            const svg = document.querySelector('#sections svg');
            const lines = svg.querySelectorAll('line.axis');
            const xAxis = lines[0], yAxis = lines[1];
            const left = +yAxis.getAttribute('x1'), bottom = +xAxis.getAttribute('y1');
            const right = +xAxis.getAttribute('x2'), top = +yAxis.getAttribute('y1');
            return [...svg.querySelectorAll('circle')].map(c => {
              const x = +c.getAttribute('cx'), y = +c.getAttribute('cy'),
                    r = +c.getAttribute('r');
              return x - r > left && x + r <= right && y + r < bottom && y - r >= top; });
        """)
        assert len(inside) == 60 and all(inside)
        names = [t.text for t in browser.find_elements("css selector", "#spectra text.peak-name")]
        assert names == ["X"]
    finally:
        session.close()


def test_orbit_and_full_spectrum_figures_read_in_micrometres_and_cover_their_lines():
    from analysis.reports.orbit_plots import full_spectrum_figure, orbit_figure
    from analysis.signal.full_spectrum import full_spectrum_peaks

    ds = _run([(X_HZ, 2e-6), (-VC_HZ, 0.5e-6), (1733.0, 1e-6)], radial_clearance=1e-5)
    fig = orbit_figure(ds)
    (ax,) = [a for a in fig.axes if a.get_visible()]
    assert ax.get_xlabel() == "X (µm)" and ax.get_ylabel() == "Y (µm)"
    radius = max(np.hypot(*line.get_data()).max() for line in ax.lines
                 if "clearance" in line.get_label())
    assert radius == pytest.approx(10.0)  # γ0 = 1e-5 m drawn in µm
    _no_offsets(fig)
    _texts_inside(fig)
    peaks = full_spectrum_peaks(ds)
    assert {p.name for p in peaks} >= {"X", "-VC"}
    fig = full_spectrum_figure(ds, peaks=peaks)
    low, high = fig.axes[0].get_xlim()
    assert all(low <= p.signed_frequency_hz <= high for p in peaks)
    assert high >= 1733.0  # beyond the default 2.5 (VC + X): a printed line is drawn
    assert "µm" in fig.axes[0].get_ylabel()
    _no_offsets(fig)
    _texts_inside(fig)
