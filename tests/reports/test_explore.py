"""`bearingdyn explore`: a stability chart as one self-contained page, opened from disk in
headless Chromium. Clicking a point fills the detail panel with that point's numbers (read
back against the chart file) and its spectra and Poincaré maps, recomputed at export time
by another path than the chart's one-pass point (simulate + poincare_section): a period-n
point of the chart must show section points that repeat every n, not sooner."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from analysis.io import open_result
from analysis.reports.explorer import explorer_data
from tests.browser import require_chromium, start_chromium
from tests.conftest import run_cli

CHART = ["balanced-rotor", "--n-balls", "8", "--section", "vc",
         "--x", "speed_rpm:7800:8300:3", "--y", "radial_load:45:50:2", "--transient", "0.5",
         "--revolutions", "40", "--executor", "serial", "--quiet"]
"""Six points of the balanced rotor near its period doublings: periodic-1, -2, -3, -4, -6."""


@pytest.fixture(scope="module")
def chart(tmp_path_factory):
    folder = tmp_path_factory.mktemp("explore")
    res = run_cli("chart", *CHART, "-o", str(folder / "chart.nc"))
    assert res.returncode == 0, res.stderr
    res = run_cli("explore", str(folder / "chart.nc"), "-o", str(folder / "chart.html"),
                  "--executor", "serial", "--quiet")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"wrote {folder / 'chart.html'}")
    return folder / "chart.nc", folder / "chart.html"


@pytest.fixture(scope="module")
def browser():
    yield from start_chromium()


def _repeat_period(xs: list[float], size: float, tol: float = 1e-3) -> int | None:
    """The smallest n for which the last 20 section values repeat every n within ``tol``
    of the motion's size (the chart's peak-to-peak amplitude), or None."""
    x = np.asarray(xs[-20:])
    for n in range(1, 10):
        if np.all(np.abs(x[n:] - x[:-n]) <= tol * size):
            return n
    return None


def test_the_page_is_self_contained(chart):
    _, page = chart
    html = page.read_text(encoding="utf-8")
    assert not re.search(r"<(script|link|img|iframe)[^>]*\s(src|href)=", html)
    assert not re.search(r"url\(|@import", html)
    external = set(re.findall(r"https?://[^\s\"'<>]+", html))
    assert external <= {"http://www.w3.org/2000/svg"}, external  # a namespace, never fetched


def test_clicking_a_point_shows_its_detail(chart, browser):
    require_chromium()
    chart_file, page = chart
    ds = open_result(chart_file)
    browser.get(page.as_uri())
    assert browser.find_element("id", "detail-title").text == "No point selected"
    cells = browser.find_elements("css selector", "rect.cell")
    assert len(cells) == ds.sizes["speed_rpm"] * ds.sizes["radial_load"] == 6
    seen = set()
    for cell in cells:
        ix, iy = int(cell.get_attribute("data-ix")), int(cell.get_attribute("data-iy"))
        cell.click()
        title = browser.find_element("id", "detail-title").text
        point = ds.isel(speed_rpm=ix, radial_load=iy)
        nature = str(point.nature.values)
        assert title == (f"speed_rpm = {float(point.speed_rpm):g} rpm, radial_load = "
                         f"{float(point.radial_load):g} N: {nature}")
        assert title not in seen
        seen.add(title)
        numbers = browser.find_element("id", "numbers").text
        assert f"{float(point.lyapunov):.4g} ± " in numbers
        assert f"amplitude of x {float(point.amplitude_x) * 1e6:.4g} µm" in numbers
        assert len(browser.find_elements("css selector", "#spectra path.line")) == 2
        drawn = browser.find_elements("css selector", "#sections svg")
        assert len(drawn) == 2
        section = browser.execute_script(
            f"return D.points.find(p => p.ix === {ix} && p.iy === {iy}).detail.sections[0];")
        circles = len(drawn[0].find_elements("css selector", "circle"))
        assert circles == len(section["px"]) >= int(ds.attrs["samples"])
        size = 2 * float(point.amplitude_x)
        assert _repeat_period(section["px"], size) == int(point.period)
        assert "selected" in cell.get_attribute("class")
    assert len(browser.find_elements("css selector", "rect.cell.selected")) == 1


def test_each_cell_is_drawn_in_its_class_colour(chart, browser):
    """The rendered page (a screenshot's pixel at each cell's centre) draws every point in
    its class's colour of ``analysis.stability.classify.NATURE_COLORS``, as the chart PNG
    and the curve figure do."""
    import io

    from matplotlib.colors import to_rgb
    from PIL import Image

    from analysis.stability.classify import NATURE_COLORS

    require_chromium()
    chart_file, page = chart
    ds = open_result(chart_file)
    browser.get(page.as_uri())
    cells = browser.find_elements("css selector", "rect.cell")
    shot = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    scale = shot.width / browser.execute_script("return window.innerWidth;")
    for cell in cells:
        ix, iy = int(cell.get_attribute("data-ix")), int(cell.get_attribute("data-iy"))
        box = browser.execute_script("const r = arguments[0].getBoundingClientRect();"
                                     "return [r.left + r.width / 2, r.top + r.height / 2];",
                                     cell)
        got = np.array(shot.getpixel((round(box[0] * scale), round(box[1] * scale)))) / 255
        code = int(ds.nature_code.values[iy, ix])
        assert np.allclose(got, to_rgb(NATURE_COLORS[code]), atol=2 / 255), (ix, iy, got)


def test_the_api_gives_the_same_data_as_plain_json(chart):
    chart_file, _ = chart
    data = explorer_data(open_result(chart_file), spectrum_bins=64)
    assert (data["x"], data["y"], data["x_units"], data["y_units"]) == (
        "speed_rpm", "radial_load", "rpm", "N")
    assert data["provenance"]["spec_sha256"] == open_result(chart_file).attrs["spec_sha256"]
    assert all(len(p["detail"]["spectra"]["x"]["f"]) <= 64 for p in data["points"])
    json.dumps(data, allow_nan=False)  # plain JSON, no NaN
    spectra = data["points"][0]["detail"]["spectra"]["x"]
    assert max(spectra["a"]) > 0 and spectra["units"] == "m"


def test_a_file_that_is_not_a_chart_is_refused(tmp_path):
    res = run_cli("simulate", "mathieu", "--duration", "1", "--transient", "0", "-o",
                  str(tmp_path / "run.nc"))
    assert res.returncode == 0, res.stderr
    res = run_cli("explore", str(tmp_path / "run.nc"), "-o", str(tmp_path / "x.html"))
    assert res.returncode == 2
    assert res.stderr.strip().startswith("error: chart file: kind must be 'chart'")
    assert not (tmp_path / "x.html").exists()
