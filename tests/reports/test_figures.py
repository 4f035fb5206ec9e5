"""Legible spectrum figures: peak labels never overlap (their rendered boxes, on a real Agg
figure), an unnamed peak is shown one way and explained in the legend, labels ambiguous
within the tolerance are flagged, and a series of N_b shares one frequency range."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import xarray as xr

from analysis import simulate
from analysis.reports.plots import (
    AMBIGUOUS_MARK,
    label_box,
    paper_figure,
    peak_labels,
    series_f_max,
    spectrum_figure,
)
from analysis.signal.spectrum import find_peaks

X_HZ = 5000 / 60


def _boxes(fig):
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return {ax: [(note, label_box(note, renderer)) for note in peak_labels(ax)]
            for ax in fig.axes}


def _assert_disjoint_and_inside(fig) -> int:
    moved = 0
    for ax, items in _boxes(fig).items():
        for (a, box_a), (b, box_b) in itertools.combinations(items, 2):
            assert not box_a.overlaps(box_b), (a.get_text(), b.get_text())
        legend = ax.get_legend()
        for note, box in items:
            assert ax.bbox.y0 <= box.y0 and box.y1 <= ax.bbox.y1, note.get_text()
            assert ax.bbox.x0 <= box.x0 and box.x1 <= ax.bbox.x1, note.get_text()
            if legend is not None:
                assert not box.overlaps(legend.get_window_extent()), note.get_text()
            moved += note.xyann[1] > 4.0
    return moved


@pytest.mark.parametrize("n_balls", [9, 10])
def test_paper_case_labels_never_overlap(n_balls):
    ds = simulate("vakharia2015", n_balls)  # the paper's 3 s, 1 s dropped
    fig = paper_figure(ds)
    texts = [n.get_text() for ax in fig.axes for n in peak_labels(ax)]
    assert len(texts) >= 12
    # labels at near-coincident frequencies (VC ≈ 4X at N_b = 10: VC−3X next to X,
    # VC−X next to 3X) had to be moved apart, and none overlaps now
    assert _assert_disjoint_and_inside(fig) >= 1


def _synthetic(freqs_amps, vc_hz, duration=2.0, dt=1e-3):
    t = np.arange(0, duration, dt)
    x = sum(a * np.sin(2 * np.pi * f * t) for f, a in freqs_amps)
    return xr.Dataset({"x": ("t", x, {"units": "m"}), "y": ("t", 0.5 * x, {"units": "m"}),
                       "vx": ("t", np.gradient(x, dt), {"units": "m/s"}),
                       "vy": ("t", 0.5 * np.gradient(x, dt), {"units": "m/s"})},
                      coords={"t": t},
                      attrs={"shaft_hz": X_HZ, "vc_hz": vc_hz, "n_balls": 10,
                             "model": "synthetic", "speed_rpm": 5000.0,
                             "state_names": "x y vx vy"})


def test_an_ambiguous_label_is_flagged_in_the_data_and_the_figure():
    vc = 332.23  # N_b = 10: VC − 2X = 165.56 Hz and 2X = 166.67 Hz, 1.1 Hz apart
    ds = _synthetic([(X_HZ, 1e-6), (166.1, 5e-7)], vc)
    peaks = {round(p.frequency_hz): p for p in find_peaks(ds, "x")}
    tol = 1.5 / 2.0  # 1.5 bins of a 2 s record, Hz
    assert abs(166.1 - 2 * X_HZ) < tol and abs(166.1 - (vc - 2 * X_HZ)) < tol
    ambiguous = peaks[166]
    assert ambiguous.label == "2X" and ambiguous.also == ("VC-2X",)
    assert ambiguous.ambiguous and ambiguous.as_dict()["also"] == ["VC-2X"]
    assert not peaks[83].ambiguous and "also" not in peaks[83].as_dict()
    fig = spectrum_figure(ds, ["x"])
    texts = [n.get_text() for n in peak_labels(fig.axes[0])]
    assert "2X" + AMBIGUOUS_MARK in texts and "X" in texts
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(t.startswith(AMBIGUOUS_MARK + ": ambiguous") for t in legend)


def test_an_unnamed_peak_is_its_frequency_everywhere_and_explained_in_the_legend(cli, tmp_path):
    vc = 199.34  # N_b = 6; no m·X + n·VC (|m| ≤ 4, n ≤ 3) within 0.75 Hz of 140.2 Hz
    ds = _synthetic([(X_HZ, 1e-6), (140.2, 4e-7)], vc)
    unnamed = next(p for p in find_peaks(ds, "x") if round(p.frequency_hz) == 140)
    assert unnamed.label is None and unnamed.name == f"{unnamed.frequency_hz:.1f} Hz"
    fig = spectrum_figure(ds, ["x"])
    notes = {n.get_text(): n for n in peak_labels(fig.axes[0])}
    assert unnamed.name in notes and notes[unnamed.name].get_fontstyle() == "italic"
    assert "?" not in "".join(notes) and "None" not in "".join(notes)
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(t.startswith("unnamed peak") for t in legend)
    from analysis.reports.paper import major_name, other_peak_names

    assert major_name([unnamed]) == unnamed.name
    assert other_peak_names([unnamed, unnamed]) == [unnamed.name]
    assert other_peak_names([unnamed, unnamed], named_only=True) == []
    ds.to_netcdf(tmp_path / "run.nc", engine="h5netcdf")
    res = cli("spectrum", "run.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    line = next(row for row in res.stdout.splitlines() if " 140.2" in row)
    assert line.rstrip().endswith(unnamed.name) and "?" not in line


def test_a_series_shares_one_frequency_range(monkeypatch, tmp_path):
    from analysis.model import load_model
    from analysis.reports import plots
    from analysis.reports.paper import series_f_max as paper_series
    from analysis.reports.report import run_paper_case

    model = load_model("vakharia2015")
    values = model.defaults
    expected = max(2.5 * (model.frequencies(nb, values).vc_hz + X_HZ) for nb in (6, 10))
    assert paper_series(model, (6, 10)) == pytest.approx(expected)
    assert series_f_max([model.frequencies(nb, values).as_dict() for nb in (6, 10)]) == \
        pytest.approx(expected)
    seen = []
    draw = plots.paper_figure

    def spy(ds, section="shaft", f_max=None):
        fig = draw(ds, section, f_max)
        seen.append(fig.axes[0].get_xlim()[1])
        return fig

    monkeypatch.setattr(plots, "paper_figure", spy)
    run_paper_case(tmp_path, "vakharia2015", (6, 10), duration=0.5, transient=0.2)
    assert seen == pytest.approx([expected, expected])


@pytest.mark.parametrize("rows", [1, 3])
def test_every_chart_point_is_a_cell_of_its_colour_also_on_one_row(rows):
    """A chart over one number of balls (one row) draws every point, as a chart of several
    rows does: the rendered pixel at each point's coordinates has the colour of its class.
    (With matplotlib's "nearest" shading a row of one value had no height: an empty chart.)"""
    from matplotlib.colors import to_rgba

    from analysis.reports.plots import chart_figure
    from analysis.stability.classify import NATURE_COLORS

    xs, ys = np.linspace(1000.0, 2000.0, 5), 8.0 + np.arange(rows)
    codes = (np.arange(rows * 5).reshape(rows, 5) % 3) + 1
    ds = xr.Dataset({"nature_code": (("n_balls", "speed_rpm"), codes),
                     "lyapunov": (("n_balls", "speed_rpm"), np.zeros((rows, 5)))},
                    coords={"speed_rpm": xs, "n_balls": ys},
                    attrs={"x": "speed_rpm", "y": "n_balls", "model": "vakharia2015"})
    fig = chart_figure(ds)
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())
    ax = fig.axes[0]
    for (i, y), (j, x) in itertools.product(enumerate(ys), enumerate(xs)):
        px, py = ax.transData.transform((x, y))
        got = pixels[round(float(pixels.shape[0] - py)), round(float(px))] / 255
        want = to_rgba(NATURE_COLORS[int(codes[i, j])])
        assert np.allclose(got, want, atol=2 / 255), (x, y, got, want)


def test_figures_leave_the_backend_and_pyplot_alone(tmp_path):
    """Importing the figure modules and drawing sets no backend and opens no pyplot figure
    (a notebook's inline backend stays, and shows a returned figure once)."""
    import subprocess
    import sys

    code = ("import matplotlib; matplotlib.use('svg')\n"
            "import numpy as np, xarray as xr, sys\n"
            "import analysis.reports.plots as plots, analysis.reports.curve_plots\n"
            "t = np.arange(2000) * 1e-4\n"
            "ds = xr.Dataset({'x': ('t', 1e-6 * np.sin(2 * np.pi * 80 * t)),"
            " 'y': ('t', 1e-6 * np.cos(2 * np.pi * 80 * t))}, coords={'t': t},"
            " attrs={'state_names': 'x y', 'shaft_hz': 80.0, 'dt': 1e-4})\n"
            "fig = plots.spectrum_figure(ds, ['x'])\n"
            "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
            "pyplot = sys.modules.get('matplotlib.pyplot')\n"
            "assert pyplot is None or not pyplot.get_fignums()\n"
            "fig.savefig(sys.argv[1], format='png')\n")
    from tests.conftest import ROOT

    out = tmp_path / "figure.png"
    res = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True,
                         text=True, cwd=ROOT, timeout=300)
    assert res.returncode == 0, res.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
