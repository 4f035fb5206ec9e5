"""Issue 32: `torus --method hb` prints, stores and plots its own error estimate (the change
when both harmonics double and when the grid doubles), as `hb` does: small where the force
is smooth (a preloaded bearing keeps every ball in contact), large on the Hertz contact."""

import math

from analysis.frequency.accuracy import ESTIMATES, hb_error
from analysis.frequency.methods import TORUS, Request
from analysis.io import open_result
from analysis.model import System

CASE = ["vakharia2015", "--n-balls", "10", "--set", "speed_rpm=5000", "--harmonics", "4,2",
        "--lyapunov-duration", "0"]


def test_contact_torus_says_its_large_error(cli, tmp_path):
    out = cli("torus", *CASE, "-o", str(tmp_path / "t.nc"), "--plot", str(tmp_path / "t.png"))
    assert out.returncode == 0, out.stderr
    assert "error estimate: change at H = 8,4 " in out.stdout
    stored = open_result(tmp_path / "t.nc")
    found = [float(stored.attrs[k]) for k in ESTIMATES]
    assert all(math.isfinite(v) for v in found)
    assert found[0] > 0.05, "2-D HB on contact is far from converged at H = 4,2"
    assert f"{found[0]:.1e}" in out.stdout
    assert (tmp_path / "t.png").stat().st_size > 0


def test_smooth_torus_says_its_small_error():
    system = System.make("vakharia2015", 10, speed_rpm=5000.0, radial_clearance=-8e-6)
    request = Request("4,2", lyapunov_duration=0.0)
    data = hb_error(TORUS["hb"], system, request, TORUS["hb"].run(system, request))
    assert data.attrs["error_at"] == "the response"
    assert 0 <= data.attrs["error_harmonics"] < 1e-8
    assert 0 <= data.attrs["error_aliasing"] < 1e-8
