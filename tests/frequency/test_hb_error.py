"""Issue 32: every HB response prints, stores and plots its own error estimate (the change
at 2H harmonics and at twice the AFT samples), and the estimate shrinks as H grows."""

import math

from analysis.frequency.accuracy import ESTIMATES
from analysis.io import open_result

DUFFING = ["duffing", "--period", "shaft", "--set", "linear_stiffness=1", "--set",
           "cubic_stiffness=0.5", "--set", "damping=0.1", "--set", "forcing_amplitude=0.3",
           "--set", "speed_rpm=12"]


def test_error_estimate_is_printed_stored_and_falls_with_h(cli, tmp_path):
    found = {}
    for h in (2, 7):
        out = cli("hb", *DUFFING, "--harmonics", str(h), "-o", str(tmp_path / f"h{h}.nc"),
                  "--plot", str(tmp_path / f"h{h}.png"))
        assert out.returncode == 0, out.stderr
        assert f"error estimate: change at H = {2 * h} " in out.stdout
        stored = open_result(tmp_path / f"h{h}.nc")
        found[h] = [float(stored.attrs[k]) for k in ESTIMATES]
        assert all(math.isfinite(v) and v >= 0 for v in found[h])
        assert (tmp_path / f"h{h}.png").stat().st_size > 0
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
