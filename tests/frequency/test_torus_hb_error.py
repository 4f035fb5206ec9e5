"""Issue 32: `torus --method hb` prints, stores and plots its own error estimate (the change
when both harmonics double and when the grid doubles), as `hb` does: small where the force
is smooth (a preloaded bearing keeps every ball in contact), large on the Hertz contact. The
default invariant circle prints, stores and plots its own: the circle's tail, the change at
2N points, and between the sections the RK4 step's change and the stored series' distance
from the integrated run. Printed numbers are parsed and compared with the .nc, the PNG's
metadata and the texts of the figure that ``--plot`` draws (``torus_figure``)."""

import re

from PIL import Image

from analysis.cli.frequency import torus_figure
from analysis.frequency.accuracy import ESTIMATES, hb_error
from analysis.frequency.methods import TORUS, Request
from analysis.io import open_result
from analysis.model import System
from tests.frequency.test_hb_error import (
    assert_as_printed,
    assert_said_stored_drawn,
    figure_texts,
    said,
)

SYSTEM = ["vakharia2015", "--n-balls", "10", "--set", "speed_rpm=5000",
          "--lyapunov-duration", "0"]
CASE = [*SYSTEM, "--harmonics", "4,2"]
FIGURE_DURATION = 2.0
"""The torus command's default --duration (s): the figure's time run."""

CIRCLE_LINE = re.compile(r"circle tail (?P<tail>\S+), change at N = (?P<circle_change_points>"
                         r"\d+): (?P<circle_change>\S+);")
BETWEEN_LINE = re.compile(r"at half the RK4 step it moves (?P<run_step_error>\S+) of the "
                          r"amplitude.*the stored 2-D series is (?P<between_error>\S+) from "
                          r"that run")
CIRCLE_LABEL = re.compile(r"invariant circle u\(0, θ2\), N = (?P<points>\d+) \(tail "
                          r"(?P<tail>\S+), change at 2N (?P<circle_change>\S+)\)")
"""What the default torus prints (two lines) and draws (the circle's legend entry)."""


def test_contact_torus_says_its_large_error(cli, tmp_path):
    nc, png = tmp_path / "t.nc", tmp_path / "t.png"
    out = cli("torus", *CASE, "-o", str(nc), "--plot", str(png))
    assert out.returncode == 0, out.stderr
    assert said(out.stdout, re.compile(r"change at H = (?P<h>\S+) "))["h"] == "8,4"
    stored = assert_said_stored_drawn(out.stdout, nc, png,
                                      torus_figure(open_result(nc), FIGURE_DURATION))
    assert float(stored[ESTIMATES[0]]) > 0.05, \
        "2-D HB on contact is far from converged at H = 4,2"


def test_default_circle_says_stores_and_draws_its_error(cli, tmp_path):
    nc, png = tmp_path / "c.nc", tmp_path / "c.png"
    out = cli("torus", *SYSTEM, "--points", "17", "-o", str(nc), "--plot", str(png))
    assert out.returncode == 0, out.stderr
    data = open_result(nc)
    stored = {**data.attrs, "tail": float(data.border.values[0])}
    printed = said(out.stdout, CIRCLE_LINE) | said(out.stdout, BETWEEN_LINE)
    assert int(printed.pop("circle_change_points")) == int(stored["circle_change_points"]) \
        == 34
    assert_as_printed(stored, printed, printed)
    metadata = Image.open(png).text
    for key in ("circle_change", "between_error", "run_step_error"):
        assert float(metadata[key]) == float(stored[key]), key
    drawn = said("\n".join(figure_texts(torus_figure(data, FIGURE_DURATION))), CIRCLE_LABEL)
    assert drawn == {"points": "17", "tail": printed["tail"],
                     "circle_change": printed["circle_change"]}


def test_smooth_torus_says_its_small_error():
    system = System.make("vakharia2015", 10, speed_rpm=5000.0, radial_clearance=-8e-6)
    request = Request("4,2", lyapunov_duration=0.0)
    data = hb_error(TORUS["hb"], system, request, TORUS["hb"].run(system, request))
    assert data.attrs["error_at"] == "the response"
    assert 0 <= data.attrs["error_harmonics"] < 1e-8
    assert 0 <= data.attrs["error_aliasing"] < 1e-8
