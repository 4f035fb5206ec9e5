"""``continue``, ``basins`` and ``calibrate`` take the flexible three-disk rotor (32 states,
two ball bearings) unchanged: smoke runs at tiny settings, each exit 0 with a result file
that names the model and holds what its settings asked for.

The rotor's unbalance (its shaft's, scaled by ``unbalance_scale``, default 1) gives its
forcing the frequencies X and VC (50 and 159.5 Hz at 3000 rpm), incommensurate: a
VC-periodic orbit here is the one-period map's fixed point from t = 0, which these smoke
runs do not read as physics (see the report of issue 38).
"""

from __future__ import annotations

import numpy as np

from analysis.io import open_result

MODEL = "three-disk-rotor"


def test_continue_runs_on_the_flexible_rotor(tmp_path, cli):
    out = tmp_path / "branch.nc"
    res = cli("continue", MODEL, "--param", "speed_rpm", "--from", "3000", "--to", "3020",
              "--period", "vc[left]", "--max-points", "3", "--quiet", "-o", str(out))
    assert res.returncode == 0, res.stderr
    branch = open_result(out)
    assert branch.attrs["model"] == MODEL
    speeds = branch["speed_rpm"].values
    assert speeds.size == 3 and speeds[0] == 3000.0 and np.all(np.diff(speeds) > 0)


def test_basins_runs_on_the_flexible_rotor(tmp_path, cli):
    out = tmp_path / "basins.nc"
    res = cli("basins", MODEL, "--x", "x:-1e-5:1e-5:2", "--y", "y:-1e-5:1e-5:2",
              "--period", "shaft", "--max-periods", "20", "--transient-periods", "5",
              "--revisits", "3", "--record", "5", "--hits", "2", "--executor", "serial",
              "--quiet", "-o", str(out))
    assert res.returncode == 0, res.stderr
    basins = open_result(out)
    assert basins.attrs["model"] == MODEL
    assert basins.sizes["x_grid"] == basins.sizes["y_grid"] == 2


def test_calibrate_runs_on_the_flexible_rotor(tmp_path, cli):
    target = tmp_path / "flexible-smoke.toml"
    target.write_text('name = "flexible-smoke"\n[[rows]]\n'
                      'n_balls = { left = 8, right = 8 }\nspeed_rpm = 3000.0\n'
                      'class = "quasi-periodic"\n')
    out = tmp_path / "cal.nc"
    res = cli("calibrate", MODEL, "--target", str(target), "--prior", "damping:100:1000:log",
              "--samples", "2", "--rounds", "1", "--transient-revolutions", "10",
              "--revolutions", "40", "--block", "2", "-o", str(out))
    assert res.returncode == 0, res.stderr
    cal = open_result(out)
    assert cal.attrs["model"] == MODEL
    assert cal.sizes["row"] == 1
    assert np.all((cal["damping"].values >= 100) & (cal["damping"].values <= 1000))
