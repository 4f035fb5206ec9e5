"""The grid of a diagram or chart (``analysis.sweeps.grid``): a section given is the section
used (``--section shaft`` is not "the model's default"), no section means the model's own;
the chart's attrs carry nothing its axes overrule and store ball axes as integers, and old
chart files still read; every figure draws one class in the one colour of
``analysis.stability.classify.NATURES``."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import xarray as xr

from analysis.io import open_result
from analysis.stability.classify import (
    NATURE_CODES,
    NATURE_COLORS,
    classify,
    default_section,
    nature_code,
)
from analysis.sweeps.grid import Axis, Setting, record
from tests.conftest import run_cli

BALANCED = ["balanced-rotor", "--n-balls", "8", "--set", "radial_load=50",
            "--x", "speed_rpm:5000:6000:2", "--y", "damping:200:200:1", "--transient", "0.1",
            "--revolutions", "40", "--no-lyapunov", "--executor", "serial", "--quiet"]
"""Two points of the balanced rotor: periodic-1 on its own (VC) section."""


def _expected(setting: Setting, speed: float, section: str) -> tuple[str, int]:
    """The class and period of the point's record classified on ``section``."""
    run = record(setting, setting.system_at(speed_rpm=speed, damping=200.0))
    verdict = classify(run, section)
    return verdict.nature, verdict.period or 0


@pytest.mark.parametrize("section", ["shaft", None])
def test_a_chart_classifies_on_the_section_given_and_else_on_the_models_own(tmp_path,
                                                                             section):
    out = tmp_path / "c.nc"
    given = ["--section", section] if section else []
    res = run_cli("chart", *BALANCED, *given, "-o", str(out))
    assert res.returncode == 0, res.stderr
    ds = open_result(out)
    setting = Setting("balanced-rotor", 8, {"radial_load": 50.0}, 0.1, 40, section,
                      lyapunov=False)
    used = section or "vc"  # a balanced rotor in one bearing: its VC section
    assert ds.attrs["section"] == used
    assert ("record_section" in ds.attrs) == (section is None)  # shaft revolutions recorded
    assert Setting.from_attrs(ds.attrs, ("speed_rpm", "damping")).section == section
    for ix, speed in enumerate(ds.speed_rpm.values):
        nature, period = _expected(setting, float(speed), used)
        assert str(ds.nature.values[0, ix]) == nature
        assert int(ds.period.values[0, ix]) == period
    if section == "shaft":  # VC/X is irrational: no repeat on the shaft section
        assert not any(str(n).startswith("periodic") for n in ds.nature.values.ravel())
    else:
        assert "periodic-1" in set(ds.nature.values.ravel())


@pytest.fixture(scope="module")
def small_chart(tmp_path_factory):
    """A 2 × 2 chart of vakharia2015 over speed and balls, short records, no λ1."""
    out = tmp_path_factory.mktemp("grid") / "c.nc"
    res = run_cli("chart", "vakharia2015", "--x", "speed_rpm:5000:6000:2", "--y",
                  "n_balls:7:8", "--transient", "0.02", "--revolutions", "5", "--no-lyapunov",
                  "--executor", "serial", "--quiet", "-o", str(out))
    assert res.returncode == 0, res.stderr
    return open_result(out)


def test_chart_attrs_carry_nothing_the_axes_overrule(small_chart):
    ds = small_chart
    for name in ("speed_rpm", "n_balls", "bearing_name", "shaft_hz", "vc_hz"):
        assert name not in ds.attrs, name
    assert ds.n_balls.dtype == np.int64 and ds.n_balls.values.tolist() == [7, 8]
    assert ds.speed_rpm.dtype == np.float64
    assert ds.attrs["radial_clearance"] > 0 and ds.attrs["dt"] == 1e-5  # the spec's step
    setting = Setting.from_attrs(ds.attrs, ("speed_rpm", "n_balls"))
    assert setting.n_balls is None and "speed_rpm" not in setting.values


def test_the_explorer_and_plot_read_old_and_new_chart_files(small_chart):
    """An old chart file (float ball coordinates, base n_balls and speed_rpm under the
    axes) gives the explorer the same points as the new one, and ``plot`` draws both."""
    from analysis.reports.explorer import explorer_data
    from analysis.reports.plots import any_figure

    new = small_chart
    old = new.assign_coords(n_balls=new.n_balls.astype(float))
    old.attrs.update(n_balls=6, bearing_name="bearing", speed_rpm=5000.0)
    got = [explorer_data(ds, spectrum_bins=16)["points"] for ds in (new, old)]
    assert [p["detail"] for p in got[0]] == [p["detail"] for p in got[1]]
    assert all("error" not in p["detail"] for p in got[0])
    for ds in (new, old):
        any_figure(ds)


def test_an_old_chart_files_attrs_still_give_its_setting():
    """An old chart file: base n_balls and speed_rpm under its axes, float ball coords,
    section 'shaft' as the record's section."""
    old = {"model": "vakharia2015", "spec_file": "modelgen/specs/vakharia2015.toml",
           "n_balls": 8, "bearing_name": "bearing", "speed_rpm": 5000.0,
           "radial_clearance": 1e-5, "kind": "chart", "transient": 0.3, "samples": 40,
           "section": "shaft", "dt": 1e-5, "lyapunov": 1, "x": "speed_rpm", "y": "n_balls"}
    setting = Setting.from_attrs(old, ("speed_rpm", "n_balls"))
    assert setting.n_balls is None and "speed_rpm" not in setting.values
    assert (setting.section, setting.record_section, setting.dt) == ("shaft", "shaft", 1e-5)
    system = setting.system_at(speed_rpm=6000.0, n_balls=7.0)
    assert system.structure == (7,) and system.parameters["speed_rpm"] == 6000.0


def test_no_step_means_the_specs():
    setting = Setting("duffing", None, {}, 1.0, 10)
    assert setting.step() == 0.01
    assert Setting("duffing", None, {}, 1.0, 10, dt=0.005).step() == 0.005


def test_default_sections_keep_each_users_rule():
    from analysis.errors import InputError
    from analysis.integrate.flow import Period
    from analysis.model import load_model
    from analysis.stability.periodic import default_period

    assert default_section({"n_balls": 8, "vc_hz": 265.0, "unbalance_force": 0.0}) == "vc"
    assert default_section({"n_balls": 8, "vc_hz": 265.0, "unbalance_force": 5.0}) == "shaft"
    assert default_section({"n_balls": 0, "forcing_period": 6.28}) == "param:forcing_period"
    assert default_section({"n_balls_left": 8, "n_balls_right": 10}) == "shaft"
    assert default_period(load_model("vakharia2015")) == Period.parse("vc")
    assert default_period(load_model("mathieu")) == Period.parse("param:forcing_period")
    assert default_period(load_model("duffing")) == Period.parse("shaft")
    with pytest.raises(InputError, match="each with its own VC frequency"):
        default_period(load_model("two-bearing-rotor"))


def test_one_vocabulary_of_classes():
    assert nature_code("periodic-7") == NATURE_CODES["periodic-n"] == 3
    assert nature_code("failed: blew up at t = 0.1 s") == NATURE_CODES["failed"] == 0
    assert sorted(NATURE_COLORS) == sorted(NATURE_CODES.values())


def _chart(codes: np.ndarray) -> xr.Dataset:
    rows, cols = codes.shape
    return xr.Dataset({"nature_code": (("radial_load", "speed_rpm"), codes),
                       "lyapunov": (("radial_load", "speed_rpm"), np.zeros(codes.shape))},
                      coords={"speed_rpm": np.linspace(7000.0, 8000.0, cols),
                              "radial_load": np.linspace(45.0, 50.0, rows)},
                      attrs={"x": "speed_rpm", "y": "radial_load", "kind": "chart",
                             "model": "balanced-rotor"})


def test_the_curve_figure_underlay_draws_each_class_in_its_colour():
    """``curve_plots.draw_chart`` (alpha 0.75 over white): each cell's rendered pixel is
    its class's colour of the one table, blended."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from analysis.reports.curve_plots import draw_chart

    codes = np.arange(6).reshape(2, 3)
    chart = _chart(codes)
    fig, ax = plt.subplots(figsize=(6, 4))
    draw_chart(ax, chart, "speed_rpm", "radial_load")
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())
    for (i, y), (j, x) in itertools.product(enumerate(chart.radial_load.values),
                                            enumerate(chart.speed_rpm.values)):
        px, py = ax.transData.transform((x, y))
        got = pixels[round(float(pixels.shape[0] - py)), round(float(px))][:3] / 255
        want = 0.75 * np.array(to_rgba(NATURE_COLORS[int(codes[i, j])])[:3]) + 0.25
        assert np.allclose(got, want, atol=2 / 255), (x, y, got, want)
    plt.close(fig)


def test_the_explorer_page_carries_the_one_colour_table():
    import json
    import re

    from analysis.reports.explorer import explorer_html

    page = explorer_html({"model": "m", "x": "speed_rpm", "y": "radial_load", "xs": [],
                          "ys": [], "points": [], "section": "vc"})
    table = re.search(r"const COLORS = (\{[^}]*\});", page).group(1)
    assert {int(k): v for k, v in json.loads(table).items()} == NATURE_COLORS


def test_axis_coord_of_balls_is_integer():
    name, values, _ = Axis.parse("n_balls[left]:5:7").coord()
    assert name == "n_balls[left]" and values.dtype == np.int64
    assert Axis.parse("speed_rpm:1:2:2").coord()[1].dtype == np.float64
