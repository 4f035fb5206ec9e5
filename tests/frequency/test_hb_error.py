"""Issue 32: every HB response prints, stores and plots its own error estimate (the change
at 2H harmonics and at twice the AFT samples), and the estimate shrinks as H grows. The
printed numbers are parsed and compared with the attrs of the written .nc and of the PNG's
metadata, and with the texts drawn by the figure function that ``--plot`` calls."""

from __future__ import annotations

import math
import re
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.text import Text
from PIL import Image

from analysis.cli.frequency import response_figure
from analysis.frequency.accuracy import ESTIMATES
from analysis.io import open_result

DUFFING = ["duffing", "--period", "shaft", "--set", "linear_stiffness=1", "--set",
           "cubic_stiffness=0.5", "--set", "damping=0.1", "--set", "forcing_amplitude=0.3",
           "--set", "speed_rpm=12"]

ERROR_LINE = re.compile(r"error estimate(?: at [^:]+)?: change at H = (?P<doubled>\S+) "
                        r"(?P<error_harmonics>\S+) of the amplitude, aliasing \(2x samples\) "
                        r"(?P<error_aliasing>[^\s;]+)")
"""The error line of an HB response or torus, as printed and as drawn."""


def figure_texts(fig: Figure) -> list[str]:
    """Every non-empty text drawn on ``fig``: titles, labels, legend entries, notes."""
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def said(text: str, pattern: re.Pattern) -> dict[str, str]:
    """The named groups of the one match of ``pattern`` in ``text`` (printed or drawn)."""
    found = [m.groupdict() for m in pattern.finditer(text)]
    assert len(found) == 1, f"one {pattern.pattern!r} expected in {text!r}"
    return found[0]


def assert_as_printed(stored: dict, printed: dict[str, str], keys) -> None:
    """Each of ``keys`` in ``stored`` (attrs) a finite number that prints (``%.1e``) as the
    text said it."""
    for key in keys:
        value = float(stored[key])
        assert math.isfinite(value), f"{key} = {value}"
        assert f"{value:.1e}" == printed[key], (key, value, printed[key])


def assert_said_stored_drawn(stdout: str, nc: Path, png: Path, fig: Figure) -> dict:
    """The error estimate of an HB result: printed in ``stdout``, stored in ``nc`` and in
    the metadata of ``png`` (every digit), and drawn on ``fig`` (the figure ``--plot``
    draws), the same numbers each time. Returns the stored attrs."""
    stored = open_result(nc).attrs
    printed = said(stdout, ERROR_LINE)
    assert_as_printed(stored, printed, ESTIMATES)
    metadata = Image.open(png).text
    for key in ESTIMATES:
        assert float(metadata[key]) == float(stored[key]), key
    assert said("\n".join(figure_texts(fig)), ERROR_LINE) == printed
    return stored


def test_error_estimate_is_printed_stored_and_falls_with_h(cli, tmp_path):
    found = {}
    for h in (2, 7):
        nc, png = tmp_path / f"h{h}.nc", tmp_path / f"h{h}.png"
        out = cli("hb", *DUFFING, "--harmonics", str(h), "-o", str(nc), "--plot", str(png))
        assert out.returncode == 0, out.stderr
        stored = assert_said_stored_drawn(out.stdout, nc, png,
                                          response_figure(open_result(nc)))
        assert said(out.stdout, ERROR_LINE)["doubled"] == str(2 * h)
        found[h] = [float(stored[k]) for k in ESTIMATES]
        assert all(v >= 0 for v in found[h])
    assert found[7][0] < found[2][0] / 10
    assert found[7][0] < 1e-3


def test_error_estimate_in_the_json(cli, tmp_path):
    import json

    out = cli("hb", *DUFFING, "--harmonics", "5", "-o", str(tmp_path / "j.nc"), "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert 0 <= data["error_harmonics"] < 1 and data["error_at"] == "the response"
    assert data["error_aliasing"] == float(open_result(tmp_path / "j.nc").attrs[
        "error_aliasing"])
