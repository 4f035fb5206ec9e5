"""`bearingdyn continue`: --json against the netCDF file, special-point lines in the model's
units, --switch-bp, restarts with --from-branch, and the settle default."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from analysis.integrate.flow import Period
from analysis.io import open_result
from analysis.model import System
from analysis.stability.continuation import continue_from_branch, continue_orbits
from analysis.stability.periodic import default_settle

RPM = 30 / math.pi
DUFFING = ["--period", "shaft", "--dt", "0.01", "--set", "linear_stiffness=1",
           "--set", "cubic_stiffness=1", "--set", "damping=0.2",
           "--set", "forcing_amplitude=20"]
"""The hardening Duffing oscillator whose symmetric branch folds twice and has a BP."""
LINE = re.compile(r"^  (LP|PD|BP|NS|grazing\?)  speed_rpm = (\S+) rpm  \(point (\d+)\)$")


@pytest.fixture(scope="module")
def switched(tmp_path_factory):
    """``continue … --switch-bp --json`` from rest at ω = 1.05 rad/s to 1.3 rad/s."""
    from tests.conftest import run_cli

    out = tmp_path_factory.mktemp("bp") / "sym.nc"
    res = run_cli("continue", "duffing", "--param", "speed_rpm", "--from", "10.03",
                  "--to", "12.41", *DUFFING, "--max-points", "300", "--switch-bp",
                  "--json", "-o", str(out))
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout), out


def test_json_matches_the_netcdf_files(switched):
    data, _ = switched
    assert data["plot"] is None and len(data["branches"]) == 2
    for summary in data["branches"]:
        br = open_result(summary["file"])
        lam = br.speed_rpm.values
        assert summary["points"] == br.sizes["point"] and summary["status"] == br.attrs["status"]
        assert summary["units"] == "rpm" and summary["param"] == "speed_rpm"
        assert summary["range"] == [lam.min(), lam.max()]
        assert summary["stable_points"] == int(br.stable.values.sum())
        labelled = np.nonzero(br.special.values != "")[0]
        assert [p["point"] for p in summary["special_points"]] == labelled.tolist()
        for p in summary["special_points"]:
            assert p["kind"] == br.special.values[p["point"]] and p["value"] == lam[p["point"]]
            assert p["multipliers_real"] == br.multiplier_real.values[p["point"]].tolist()
            assert p["multipliers_imag"] == br.multiplier_imag.values[p["point"]].tolist()
    sym, asym = data["branches"]
    assert [p["kind"] for p in sym["special_points"]] == ["LP", "LP", "BP"]
    assert asym["file"].endswith("sym-asymmetric.nc") and asym["branch"].startswith("asym")
    bp = sym["special_points"][2]
    assert bp["value"] / RPM == pytest.approx(1.15567, abs=1e-4)  # test_branch_safety
    assert min(abs(np.array(bp["multipliers_real"]) - 1)) < 1e-3
    # the asymmetric branch starts just past the BP, stable, and period-doubles at 1.2093
    assert asym["stable_points"] > 0
    assert [p["kind"] for p in asym["special_points"]][:1] == ["PD"]
    assert asym["special_points"][0]["value"] / RPM == pytest.approx(1.2093, abs=2e-4)


def test_special_points_one_per_line_in_the_model_units(switched, cli):
    _, out = switched
    res = cli("continue", "--from-branch", str(out), "--point", "0", "--to", "12.41",
              "--max-points", "300", "--quiet", "-o", str(out.with_name("again.nc")))
    assert res.returncode == 0, res.stderr
    lines = [m for m in map(LINE.match, res.stdout.splitlines()) if m]
    br = open_result(out.with_name("again.nc"))
    assert [m[1] for m in lines] == [str(k) for k in br.special.values if k]
    for m in lines:
        assert float(m[2]) == pytest.approx(br.speed_rpm.values[int(m[3])], rel=1e-5)
    # a restart from point 0 over the same range is the same branch, point for point
    first = open_result(out)
    assert br.sizes["point"] == first.sizes["point"]
    np.testing.assert_allclose(br.speed_rpm.values, first.speed_rpm.values, rtol=1e-10)
    np.testing.assert_allclose(br.z0.values, first.z0.values, rtol=0,
                               atol=1e-10 * np.abs(first.z0.values).max())
    assert list(br.special.values) == list(first.special.values)


def test_from_branch_refuses_a_model_and_needs_one_otherwise(switched, cli):
    _, out = switched
    res = cli("continue", "duffing", "--from-branch", str(out), "--to", "12", "-o", "x.nc")
    assert res.returncode == 2 and "drop MODEL" in res.stderr
    res = cli("continue", "--param", "speed_rpm", "--to", "12", "-o", "x.nc")
    assert res.returncode == 2 and "give MODEL, --from" in res.stderr


def test_restart_in_either_direction_from_a_point_of_the_file(tmp_path):
    """From a point on the middle (unstable) part of the S, back up towards the upper fold
    and, in the stored direction, down to the lower one: the same folds as the original."""
    br = continue_orbits("duffing", param="speed_rpm", start=1.05 * RPM, stop=1.3 * RPM,
                         period="shaft", dt=0.01, max_points=300,
                         **dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2,
                                forcing_amplitude=20.0))
    path = tmp_path / "s.nc"
    from analysis.io import save_dataset

    save_dataset(br, path)
    folds = br.speed_rpm.values[br.special.values == "LP"]
    lp = np.nonzero(br.special.values == "LP")[0]
    k = int((lp[0] + lp[1]) // 2)
    lam = float(br.speed_rpm.values[k])
    back = continue_from_branch(path, k, stop=1.3 * RPM)  # λ grows: against the stored way
    on = continue_from_branch(path, k, stop=1.0 * RPM)
    assert back.attrs["restarted_from"] == f"{path} point {k}"
    assert back.speed_rpm.values[1] > lam > on.speed_rpm.values[1]
    assert back.speed_rpm.values[back.special.values == "LP"] == pytest.approx([folds[0]],
                                                                               rel=1e-7)
    assert on.speed_rpm.values[on.special.values == "LP"] == pytest.approx([folds[1]],
                                                                           rel=1e-7)


def test_settle_defaults_to_the_model_time_scale(cli, tmp_path):
    """No --settle: the first guess comes from the spec's transient (300 s for Duffing), as
    floquet's; 0.5 s would start from rest."""
    system = System.make("duffing", None, None, speed_rpm=1.2 * RPM)
    assert default_settle(system, Period.parse("shaft")) == 300.0
    res = cli("continue", "duffing", "--param", "speed_rpm", "--from", "11.459",
              "--to", "11.6", *DUFFING, "--max-points", "3", "--json", "-o",
              str(tmp_path / "s.nc"))
    assert res.returncode == 0, res.stderr
    br = continue_orbits("duffing", param="speed_rpm", start=11.459, stop=11.6,
                         period="shaft", dt=0.01, max_points=3, settle=300.0,
                         **dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2,
                                forcing_amplitude=20.0))
    np.testing.assert_allclose(open_result(tmp_path / "s.nc").z0.values, br.z0.values,
                               rtol=1e-12)
