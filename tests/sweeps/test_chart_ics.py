"""`bearingdyn chart --ics K`: K initial states per chart point as one ensemble, the number
of distinct attractors and the class of each, multistable points marked in the figure and
the explorer.

Independent reference: the balanced rotor (eight balls, 50 N) has a stable period-3 orbit
beside the period-1 orbit between the period-3 branch's folds at 7871.75 and 8424.25 rpm
(pseudo-arclength continuation, docs/stability.md); outside them the period-1 orbit alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.io import open_result
from analysis.reports.plots import chart_figure
from analysis.stability.classify import NATURE_CODES
from tests.browser import require_chromium, start_chromium
from tests.conftest import run_cli

CHART = ["balanced-rotor", "--n-balls", "8",
         "--x", "speed_rpm:7800:8500:3", "--y", "radial_load:50:50:1", "--revolutions", "60",
         "--ics", "12", "--executor", "serial", "--quiet"]


@pytest.fixture(scope="module")
def chart(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ics")
    res = run_cli("chart", *CHART, "-o", str(folder / "chart.nc"))
    assert res.returncode == 0, res.stderr
    assert "1 multistable among 12 initial states each" in res.stdout
    return folder


def test_multistable_exactly_between_the_period3_folds(chart):
    ds = open_result(chart / "chart.nc")
    speeds = ds.speed_rpm.values
    assert speeds.tolist() == [7800.0, 8150.0, 8500.0]
    inside = (speeds > 7871.75) & (speeds < 8424.25)
    assert ds.multistable.values[0].tolist() == inside.astype(int).tolist()
    assert ds.n_attractors.values[0].tolist() == [1, 2, 1]
    codes = ds.attractor_codes.values[0, 1]
    # at 8150 rpm: the period-3 orbit and the period-2 orbit (after the PD at 8142 rpm)
    assert sorted(c for c in codes if c >= 0) == sorted([NATURE_CODES["periodic-2"],
                                                          NATURE_CODES["periodic-n"]])
    assert ds.attrs["ics"] == 12 and np.all(ds.diverged_share.values == 0)


def test_the_figure_hatches_the_multistable_cells(chart):
    from matplotlib.patches import Rectangle

    ds = open_result(chart / "chart.nc")
    fig = chart_figure(ds)
    hatched = [p for p in fig.axes[0].patches if isinstance(p, Rectangle) and p.get_hatch()]
    assert len(hatched) == int(ds.multistable.sum()) == 1
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(label.startswith("multistable") for label in labels)


@pytest.fixture(scope="module")
def browser():
    yield from start_chromium()


def test_the_explorer_marks_the_multistable_cells(chart, browser):
    require_chromium()
    res = run_cli("explore", str(chart / "chart.nc"), "-o", str(chart / "chart.html"),
                  "--executor", "serial", "--quiet")
    assert res.returncode == 0, res.stderr
    browser.get((chart / "chart.html").as_uri())
    marks = browser.find_elements("css selector", "path.multistable")
    assert len(marks) == 1
    assert "multistable" in browser.find_element("id", "multistable-key").text
    titles = [t.get_attribute("textContent")
              for t in browser.find_elements("css selector", "rect.cell title")]
    assert sum("2 attractor(s)" in t for t in titles) == 1


def test_bad_ics_is_refused_before_any_point(tmp_path):
    for args, message in (
            (["--ics", "0"], "ics: must be a whole number in [1, 256], got 0"),
            (["--ics-box", "x:-1e-5:1e-5"], "--ics-box: draws the initial states of --ics"),
            (["--ics", "4", "--ics-box", "q:0:1"], "'q' is not a state of model")):
        res = run_cli("chart", *CHART[:-7], "--executor", "serial", *args,
                      "-o", str(tmp_path / "c.nc"))
        assert res.returncode == 2 and message in res.stderr, res.stderr
        assert list(tmp_path.iterdir()) == []
