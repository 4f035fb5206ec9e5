"""Static equilibrium and linearised bearing coefficients (analysis.stability.statics)
against the zero-clearance closed form, an independent scipy Hertz balance, finite
differences of that balance, and the structure of the models (springs, damping)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from analysis.model import load_model
from analysis.stability.statics import cage_pitch, coefficients, equilibrium
from tests.extras import require

K_HERTZ = 7.055e9  # N/m^1.5, vakharia2015's contact_stiffness
LOAD = 6.0  # N, its radial_load


def hertz_force(q, n_balls, psi, k=K_HERTZ, clearance=10e-6, load=LOAD):
    """F(x, y) of the paper's model written here from Eqs. 3-8 (no CasADi): load P in +x
    minus k·max(0, x cos θ_i + y sin θ_i − γ0)^1.5 (cos θ_i, sin θ_i) summed over the balls."""
    theta = 2 * np.pi * np.arange(n_balls) / n_balls + psi
    d = np.maximum(q[0] * np.cos(theta) + q[1] * np.sin(theta) - clearance, 0.0)
    ball = k * d ** 1.5
    return np.array([load - np.sum(ball * np.cos(theta)), -np.sum(ball * np.sin(theta))])


@pytest.mark.parametrize("n_balls", [6, 7, 8, 9, 10])
def test_zero_clearance_kxx_matches_the_closed_form(n_balls):
    eq = equilibrium("vakharia2015", n_balls, radial_clearance=0.0)
    theta = 2 * np.pi * np.arange(n_balls) / n_balls
    s = np.sum(np.clip(np.cos(theta), 0, None) ** 2.5)
    kxx = 1.5 * K_HERTZ ** (2 / 3) * LOAD ** (1 / 3) * s ** (2 / 3)
    assert eq.stiffness[0, 0] == pytest.approx(kxx, rel=1e-9)
    delta = (LOAD / (K_HERTZ * s)) ** (2 / 3)  # the same balance solved for the deflection
    assert eq.position[0] == pytest.approx(delta, rel=1e-9)
    assert abs(eq.position[1]) < 1e-15
    loaded = np.cos(theta) > 1e-12
    kyy = 1.5 * K_HERTZ * np.sum(np.sqrt(delta * np.cos(theta[loaded]))
                                 * np.sin(theta[loaded]) ** 2)
    # a ball at exactly 90° (N_b = 8) has cos θ = 6e-17 in floating point: its 0.06 N/m
    # (1e-8 of kyy) is the only difference
    assert eq.stiffness[1, 1] == pytest.approx(kyy, rel=1e-7)
    assert abs(eq.stiffness[0, 1]) < 1e-6 * kxx and abs(eq.stiffness[1, 0]) < 1e-6 * kxx


@pytest.mark.parametrize(("n_balls", "psi_deg"), [(6, 12.0), (8, 20.0), (10, 5.0), (7, 30.0)])
def test_equilibrium_with_clearance_matches_an_independent_fsolve(n_balls, psi_deg):
    psi = math.radians(psi_deg)
    eq = equilibrium("vakharia2015", n_balls, cage_angle=psi)
    # in micrometres, from where the two balls either side of the load line both touch
    pitch = 2 * np.pi / n_balls
    phi = psi % pitch - pitch / 2
    r = 10.0 / np.cos(pitch / 2) + 0.5
    guess = [r * np.cos(phi), r * np.sin(phi)]
    reference = 1e-6 * fsolve(lambda u: hertz_force(1e-6 * u, n_balls, psi), guess,
                              xtol=1e-13)
    assert np.max(np.abs(hertz_force(reference, n_balls, psi))) < 1e-8
    assert eq.position == pytest.approx(reference, abs=1e-13)
    # K against central differences of the independent force (not CasADi's AD)
    h = 1e-11
    fd = np.column_stack([-(hertz_force(reference + h * e, n_balls, psi)
                            - hertz_force(reference - h * e, n_balls, psi)) / (2 * h)
                          for e in np.eye(2)])
    assert eq.stiffness == pytest.approx(fd, rel=1e-5, abs=1e-3 * np.abs(fd).max())
    assert not eq.singular


def test_unbalance_and_damping_are_not_static_loads():
    base = equilibrium("vakharia2015", 8, cage_angle=0.1)
    none = equilibrium("vakharia2015", 8, cage_angle=0.1, unbalance_force=0.0)
    assert base.position == pytest.approx(none.position, rel=1e-12, abs=1e-18)
    assert base.damping == pytest.approx(200.0 * np.eye(2))  # viscous: C = c·I
    damped = equilibrium("vakharia2015", 8, cage_angle=0.1, damping=75.0)
    assert damped.damping == pytest.approx(75.0 * np.eye(2))
    assert damped.stiffness == pytest.approx(base.stiffness, rel=1e-12)


def test_one_loaded_ball_is_reported_singular():
    eq = equilibrium("vakharia2015", 6)  # 10 µm clearance, 6 N: only the ball at θ = 0
    assert eq.singular and abs(eq.stiffness[1, 1]) < 1e-6 * eq.stiffness[0, 0]
    assert eq.stiffness[0, 0] == pytest.approx(
        1.5 * K_HERTZ ** (2 / 3) * LOAD ** (1 / 3), rel=1e-9)  # one ball: Σ cos^2.5 = 1


def test_cage_angle_dependence_has_the_ball_pitch_period():
    ds = coefficients("vakharia2015", 8, n_angles=8)
    pitch = 2 * np.pi / 8
    assert float(ds.attrs["cage_pitch"]) == pytest.approx(pitch)
    assert ds.cage_angle.values == pytest.approx(pitch * np.arange(8) / 8)
    again = equilibrium("vakharia2015", 8, cage_angle=pitch + float(ds.cage_angle[3]))
    assert again.stiffness == pytest.approx(ds.stiffness.values[3], rel=1e-9)
    mirror = equilibrium("vakharia2015", 8, cage_angle=pitch - float(ds.cage_angle[3]))
    # the mirror image of the cage about the load line mirrors y
    assert mirror.position[1] == pytest.approx(-ds.position.values[3, 1], rel=1e-9)
    assert ds.stiffness_mean.values == pytest.approx(ds.stiffness.values.mean(axis=0))
    assert ds.attrs["model"] == "vakharia2015" and ds.attrs["n_balls"] == 8
    assert ds.attrs["spec_sha256"] == load_model("vakharia2015").spec_sha256
    assert cage_pitch((8, 10)) == pytest.approx(np.pi)


def test_multi_body_matrix_carries_the_housing_springs():
    ds = coefficients("rotor-housing", n_angles=3)
    k = ds.stiffness.values[1]
    names = [str(c) for c in ds.row.values]
    assert names == ["x_rotor", "y_rotor", "x_housing", "y_housing"]
    springs = 2.0e7  # housing_stiffness: ground springs on the housing only
    bearing = k[:2, :2]
    assert k[2:, 2:] == pytest.approx(bearing + springs * np.eye(2), rel=1e-9)
    assert k[:2, 2:] == pytest.approx(-bearing, rel=1e-9)  # the races' relative motion
    c = ds.damping.values[1]
    assert c[:2, :2] == pytest.approx(200.0 * np.eye(2))
    assert c[2:, 2:] == pytest.approx((200.0 + 500.0) * np.eye(2))


def test_cli_json_and_bad_input(cli, tmp_path):
    res = cli("stiffness", "vakharia2015", "--n-balls", "8", "--angles", "4", "--set",
              "radial_clearance=0", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    theta = 2 * np.pi * np.arange(8) / 8
    s = np.sum(np.clip(np.cos(theta), 0, None) ** 2.5)
    closed = 1.5 * K_HERTZ ** (2 / 3) * LOAD ** (1 / 3) * s ** (2 / 3)
    assert data["at_cage_angle_0"]["kxx"] == pytest.approx(closed, rel=1e-9)
    assert data["provenance"]["model"] == "vakharia2015"
    assert data["provenance"]["radial_clearance"] == 0.0
    assert len(data["over_cage_angle"]["stiffness"]) == 4
    res = cli("stiffness", "vakharia2015", "--angles", "0", cwd=tmp_path)
    assert res.returncode == 2 and "--angles" in res.stderr
    res = cli("stiffness", "vakharia2015", "--ross", "r.json", "--speeds", "a:b", cwd=tmp_path)
    assert res.returncode == 2 and "--speeds" in res.stderr
    res = cli("stiffness", "rotor-housing", "--angles", "2", "--ross", "r.json", cwd=tmp_path)
    assert res.returncode == 2 and "one-body planar" in res.stderr


@pytest.mark.needs_extra
def test_ross_rotor_from_the_written_coefficients(cli, tmp_path):
    rs = require("ross", "ross")
    res = cli("stiffness", "vakharia2015", "--n-balls", "9", "--angles", "6", "--ross",
              "bearing.json", "--speeds", "1000:8000:3", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    data = json.loads((tmp_path / "bearing.json").read_text())
    element = data["bearing_element"]
    assert element["frequency"] == pytest.approx(np.array([1000, 4500, 8000]) * np.pi / 30)
    ds = coefficients("vakharia2015", 9, n_angles=6, speed_rpm=4500.0)
    assert element["kxx"][1] == pytest.approx(float(ds.stiffness_mean[0, 0]), rel=1e-12)
    steel = rs.materials.steel
    shaft = [rs.ShaftElement(L=0.05, idl=0.0, odl=0.02, material=steel) for _ in range(6)]
    disk = rs.DiskElement.from_geometry(n=3, material=steel, width=0.02, i_d=0.02, o_d=0.12)
    bearings = [rs.BearingElement(n=n, **element) for n in (0, 6)]
    rotor = rs.Rotor(shaft, [disk], bearings)
    k = bearings[0].K(element["frequency"][1])
    assert k[0, 0] == pytest.approx(element["kxx"][1], rel=1e-9)
    assert k[1, 1] == pytest.approx(element["kyy"][1], rel=1e-9)
    modal = rotor.run_modal(speed=element["frequency"][1], num_modes=8)
    wn = np.sort(np.asarray(modal.wn))
    assert np.all(np.isfinite(wn)) and wn[0] > 0
