"""The ``bearingdyn`` command on models of other shapes than the paper's rotor: several
bodies (rotor-housing), several bearings (two-bearing-rotor), one coordinate and no
bearings (mathieu). Each check recomputes what it can independently of the code under
test (hash of the spec file, VC = N_b · cage, the forcing period)."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from analysis.io import open_result
from analysis.provenance import load_dataset
from tests.conftest import SPECS

ROTOR_HOUSING = ("x_rotor", "y_rotor", "x_housing", "y_housing",
                 "vx_rotor", "vy_rotor", "vx_housing", "vy_housing")


def test_rotor_housing_run_has_its_eight_states_and_provenance(cli, tmp_path):
    res = cli("simulate", "rotor-housing", "--duration", "0.3", "--transient", "0.2",
              "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    ds = load_dataset(tmp_path / "r.nc")
    assert tuple(ds.data_vars) == ROTOR_HOUSING
    for name in ROTOR_HOUSING:
        assert ds[name].attrs["units"] == ("m/s" if name.startswith("v") else "m")
    assert ds.attrs["state_names"] == " ".join(ROTOR_HOUSING)
    spec = SPECS / "rotor-housing.toml"
    assert ds.attrs["spec_file"] == "modelgen/specs/rotor-housing.toml"
    assert ds.attrs["spec_sha256"] == hashlib.sha256(spec.read_bytes()).hexdigest()
    assert "N_b = 8" in res.stdout


def test_two_bearing_balls_by_name(cli, tmp_path):
    res = cli("simulate", "two-bearing-rotor", "--n-balls", "left=7", "--n-balls", "right=11",
              "--duration", "0.3", "--transient", "0.2", "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    attrs = load_dataset(tmp_path / "r.nc").attrs
    assert (attrs["n_balls_left"], attrs["n_balls_right"]) == (7, 11)
    assert attrs["vc_hz_left"] == pytest.approx(7 * attrs["cage_hz_left"], rel=1e-12)
    assert attrs["vc_hz_right"] == pytest.approx(11 * attrs["cage_hz_right"], rel=1e-12)
    assert "n_balls" not in attrs and "vc_hz" not in attrs

    bad = cli("simulate", "two-bearing-rotor", "--n-balls", "8", "-o", "b.nc", cwd=tmp_path)
    assert bad.returncode == 2 and "left=8" in bad.stderr
    assert not (tmp_path / "b.nc").exists()


def test_spectrum_names_each_bearings_vc(cli, tmp_path):
    """Left 7 balls, right 11: VC[left] = 7 cage and VC[right] = 11 cage are far apart (232
    and 365 Hz at 5000 rpm) and from every m·X. The record is 0.5 s: bins of 2 Hz."""
    res = cli("simulate", "two-bearing-rotor", "--n-balls", "left=7", "--n-balls", "right=11",
              "--duration", "1.0", "--transient", "0.5", "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = cli("spectrum", "r.nc", "--json", "--var", "x", "--var", "ty", "--max-peaks", "12",
              cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    attrs = load_dataset(tmp_path / "r.nc").attrs
    bin_hz = 1.0 / (attrs["duration"] - attrs["transient"])
    balls = {"left": 7, "right": 11}
    pure = [p for p in report["peaks"] if p["label"] in ("VC[left]", "VC[right]")]
    assert pure, report["peaks"]
    for peak in pure:
        bearing = peak["bearing"]
        assert peak["label"] == f"VC[{bearing}]"
        cage = attrs[f"cage_hz_{bearing}"]
        assert abs(peak["frequency_hz"] - balls[bearing] * cage) < bin_hz
    assert report["vc"] == {"left": pytest.approx(7 * attrs["cage_hz_left"]),
                            "right": pytest.approx(11 * attrs["cage_hz_right"])}
    text = cli("spectrum", "r.nc", cwd=tmp_path).stdout
    assert "VC[left] = 232.56 Hz" in text and "VC[right] = 365.46 Hz" in text


def test_poincare_of_mathieu_at_its_forcing_period(cli, tmp_path):
    """Undamped Mathieu at delta = 1/4 (inside the first tongue) with T = 2π: the section
    points are the run sampled every T; t = k·T falls on samples of dt = 0.01 only where
    2πk/0.01 is close to whole, so compare with a fine independent interpolation."""
    res = cli("simulate", "mathieu", "--duration", "40", "--transient", "0", "-o", "m.nc",
              cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = cli("poincare", "m.nc", "--section", "param:forcing_period", "--json",
              "-o", "m.png", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    points = json.loads(res.stdout)
    assert set(points) == {"t", "x", "vx", "provenance"}
    period = 2 * np.pi
    np.testing.assert_allclose(points["t"], period * np.arange(len(points["t"])), rtol=1e-12)
    assert len(points["t"]) == int(40 // period) + 1
    run = load_dataset(tmp_path / "m.nc")
    np.testing.assert_allclose(points["x"], np.interp(points["t"], run.t, run.x),
                               atol=1e-4 * float(np.abs(run.x).max()))
    assert (tmp_path / "m.png").read_bytes()[:4] == b"\x89PNG"

    res = cli("poincare", "m.nc", "--section", "vc", cwd=tmp_path)
    assert res.returncode == 2 and "no cage or VC period" in res.stderr


def test_chart_over_one_bearings_balls(cli, tmp_path):
    """Without unbalance both bearings' forcings repeat every cage period (VC = N_b · cage,
    the same cage speed): with damping and load enough to settle, each point is period-1
    on the cage section."""
    res = cli("chart", "two-bearing-rotor", "--x", "speed_rpm:5000:5000:1",
              "--y", "n_balls[left]:6:7", "--section", "cage", "--revolutions", "20",
              "--transient", "0.5", "--no-lyapunov", "--set", "unbalance_force=0",
              "--set", "damping=2000", "--set", "radial_load=200", "--executor", "serial",
              "--quiet", "--table", "-o", "c.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    chart = open_result(tmp_path / "c.nc")
    assert chart.attrs["y"] == "n_balls[left]"
    assert chart["n_balls[left]"].values.tolist() == [6.0, 7.0]
    assert chart["n_balls[left]"].attrs["long_name"] == "balls in bearing left"
    assert chart.nature.values.ravel().tolist() == ["periodic-1", "periodic-1"]
    assert chart.attrs["n_balls_right"] == 10  # the other bearing keeps its spec count
    assert "| n_balls[left] (balls in bearing left) | speed_rpm |" in res.stdout
    assert not (tmp_path / "c.nc.parts").exists()

    res = cli("chart", "two-bearing-rotor", "--x", "speed_rpm:5000:5000:1",
              "--y", "n_balls:6:7", "-o", "d.nc", cwd=tmp_path)
    assert res.returncode == 2 and "n_balls[left]" in res.stderr


def test_generate_a_user_spec_into_the_cache_or_a_folder(cli, tmp_path, monkeypatch):
    """A spec from outside the package never writes into generated/: without --out it goes
    to the user cache (and the command says where), with --out to a loadable folder."""
    from tests.conftest import ROOT

    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    text = (SPECS / "duffing.toml").read_text().replace('name = "duffing"', 'name = "myduff"')
    (tmp_path / "myduff.toml").write_text(text)
    before = sorted(p.name for p in (ROOT / "generated").iterdir())
    res = cli("generate", "myduff.toml", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "in the user cache" in res.stdout and str(tmp_path / "cache") in res.stdout
    assert list((tmp_path / "cache" / "models").glob("myduff-*/myduff/__init__.py"))
    res = cli("generate", "myduff.toml", "--out", "gen", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert str((tmp_path / "gen").resolve()) in res.stdout
    assert sorted(p.name for p in (ROOT / "generated").iterdir()) == before
    res = cli("simulate", "gen", "--duration", "10", "--transient", "0", "-o", "g.nc",
              cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert load_dataset(tmp_path / "g.nc").attrs["model"] == "myduff"
    monkeypatch.setenv("BEARINGDYN_MODELS", str(tmp_path))
    res = cli("models", cwd=tmp_path)
    line = next(row for row in res.stdout.splitlines() if row.startswith("myduff"))
    assert str(tmp_path / "myduff.toml") in line and "n =  4" in line
