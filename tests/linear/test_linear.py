"""Campbell and unbalance against closed-form results, and the commands (no ROSS needed).

A short, thick shaft on soft bearings moves as a rigid body: a disk at its middle, the same
bearings at both ends, so translation and tilt decouple. Its translation in x and in y are
single-DOF systems of the whole mass M on the two bearings: natural frequencies
sqrt(2 k / M) (kxx and kyy), and the unbalance response at the middle node
X = m e Omega² / (2 k - M Omega² + i 2 c Omega) with x(t) = |X| cos(Omega t + arg X).
The shaft's own flexibility shifts these by about k / k_shaft (< 1e-4 here).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import tomli_w
from typer.testing import CliRunner

from analysis.errors import InputError
from analysis.linear import campbell, unbalance_response
from analysis.linear.campbell import check_critical
from analysis.linear.rotor import load_rotor, parse_unbalance
from modelgen.fe.assembly import assemble
from modelgen.fe.schema import Shaft, Unbalance

KXX, KYY, CXX = 2.0e5, 5.0e5, 150.0
RIGID = {"materials": [{"name": "steel", "E": 211e9, "nu": 0.3, "rho": 7810.0}],
         "elements": [{"L": 0.05, "odl": 0.12, "material": "steel"}] * 4,
         "disks": [{"node": 2, "m": 10.0, "Id": 0.05, "Ip": 0.09}],
         "unbalances": [{"node": 2, "magnitude": 2e-4, "phase": 0.5}],
         "bearings": [{"node": 0, "kxx": KXX, "kyy": KYY, "cxx": CXX},
                      {"node": 4, "kxx": KXX, "kyy": KYY, "cxx": CXX}]}


def total_mass() -> float:
    return 10.0 + 7810.0 * math.pi * 0.12**2 / 4 * 0.2


def test_rigid_rotor_translation_frequencies_are_sqrt_2k_over_m():
    rotor = assemble(Shaft.model_validate(RIGID))
    result = campbell(rotor, [0.0, 3000.0], n_modes=4)
    m = total_mass()
    expected = [math.sqrt(2 * k / m - (2 * c / (2 * m)) ** 2) / (2 * math.pi)
                for k, c in ((KXX, CXX), (KYY, CXX))]  # damped: w_n sqrt(1 - zeta²)
    found = result.frequency_hz[:, 0]
    closest = [int(np.argmin(np.abs(found - f))) for f in expected]  # tilts lie between
    assert found[closest] == pytest.approx(expected, rel=2e-4)
    zeta = 2 * CXX / (2 * math.sqrt(2 * KXX * m))
    assert result.log_dec[closest[0], 0] == pytest.approx(
        2 * math.pi * zeta / math.sqrt(1 - zeta**2), rel=2e-4)
    assert np.all(np.diff(result.frequency_hz, axis=0)[np.isfinite(
        np.diff(result.frequency_hz, axis=0))] >= 0)  # ascending at every speed
    assert set(result.whirl.ravel()) <= {"forward", "backward", "mixed"}


def test_rigid_rotor_unbalance_response_is_the_one_dof_one():
    shaft = Shaft.model_validate(RIGID)
    speeds = np.linspace(200.0, 6000.0, 30)
    result = unbalance_response(assemble(shaft), 2, speeds, shaft.unbalances)
    omega = speeds * math.pi / 30
    m = total_mass()
    expected = 2e-4 * omega**2 * np.exp(0.5j) / (2 * KXX - m * omega**2 + 2j * CXX * omega)
    assert result.x == pytest.approx(expected, rel=1e-3)  # Q ~ 11 magnifies the flexibility
    assert result.amplitude_m == pytest.approx(np.abs(expected), rel=1e-3)
    assert result.phase_deg == pytest.approx(np.degrees(np.angle(expected)), abs=0.02)
    # the phase lags by 90 degrees at resonance: past it the rotor moves against the force
    assert result.phase_deg[0] == pytest.approx(np.degrees(0.5), abs=1.0)


def test_critical_speeds_lie_on_the_1x_line_and_are_refined():
    rotor = assemble(Shaft.model_validate(RIGID))
    coarse = campbell(rotor, np.linspace(0.0, 3000.0, 4), n_modes=2)
    fine = campbell(rotor, np.linspace(0.0, 3000.0, 301), n_modes=2)
    assert len(coarse.critical) == len(fine.critical) == 2
    for a, b in zip(coarse.critical, fine.critical, strict=True):
        assert a.speed_rpm == pytest.approx(b.speed_rpm, rel=1e-7)
        assert a.frequency_hz == pytest.approx(a.speed_rpm / 60, rel=1e-12)
    with pytest.raises(InputError, match=r"^speeds: 0 to 100 rpm passes no mode's crossing"):
        check_critical(campbell(rotor, [0.0, 100.0], n_modes=2))


@pytest.mark.parametrize(("text", "message"), [
    ("2", "expected NODE:KG_M"), ("9:1e-4", "no node 9"), ("2:-1", "must be in (0, 1000]"),
    ("a:b", "expected NODE:KG_M")])
def test_bad_unbalance_option(text, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace("]", r"\]")):
        parse_unbalance(text, 5)
    assert parse_unbalance("3:1e-4:90", 5) == Unbalance(node=3, magnitude=1e-4,
                                                         phase=math.pi / 2)


def write_spec(path, shaft: dict, name: str = "rigid-rotor") -> str:
    path.write_text(tomli_w.dumps({"model": {"name": name, "title": "t"}, "shaft": shaft}))
    return str(path)


def invoke(*args):
    from analysis.cli import app

    return CliRunner().invoke(app, [str(a) for a in args])


def test_campbell_and_unbalance_commands(tmp_path):
    spec = write_spec(tmp_path / "rigid-rotor.toml", RIGID)
    res = invoke("campbell", spec, "--speeds", "0:3000:7", "--modes", "4", "--json",
                 "--critical-speeds", "-o", tmp_path / "c.png")
    assert res.exit_code == 0, res.output
    data = json.loads(res.output[res.output.index("{"):])
    assert list(data) == ["speed_rpm", "frequency_hz", "log_dec", "whirl", "critical_speeds"]
    library = campbell(load_rotor(spec).matrices, np.linspace(0, 3000, 7), 4)
    assert np.array(data["frequency_hz"]) == pytest.approx(library.frequency_hz)
    assert (tmp_path / "c.png").stat().st_size > 10_000
    res = invoke("unbalance", spec, "--node", 2, "--speeds", "500,1000", "--json",
                 "--unbalance", "2:2e-4:28.64788975654116", "-o", tmp_path / "b.png")
    assert res.exit_code == 0, res.output
    data = json.loads(res.output[res.output.index("{"):])
    assert list(data) == ["speed_rpm", "amplitude_m", "phase_deg"]
    spec_default = unbalance_response(load_rotor(spec).matrices, 2, [500.0, 1000.0],
                                      Shaft.model_validate(RIGID).unbalances)
    assert data["amplitude_m"] == pytest.approx(spec_default.amplitude_m, rel=1e-9)
    assert (tmp_path / "b.png").stat().st_size > 10_000


@pytest.mark.parametrize(("change", "args", "message"), [
    ({"elements": [{"L": 0.0, "odl": 0.12, "material": "steel"}] * 4}, (),
     "shaft.elements[0].L: Input should be greater than 0"),
    ({"disks": [{"node": 5, "m": 10.0, "Id": 0.05, "Ip": 0.09}]}, (),
     "shaft.disks[0].node: no node 5; the shaft's nodes are 0 to 4"),
    ({}, ("--critical-speeds", "--speeds", "0:100:3"),
     "--speeds: 0 to 100 rpm passes no mode's crossing with 1X"),
])
def test_bad_input_is_one_line_and_exit_2(cli, tmp_path, change, args, message):
    """(negative lengths and bearings at missing nodes: tests/fe/test_elements.py)"""
    spec = write_spec(tmp_path / "rigid-rotor.toml", {**RIGID, **change})
    res = cli("campbell", spec, *(args or ("--speeds", "0:3000:4")), cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and message in res.stderr, res.stderr
    assert not list(tmp_path.glob("*.png"))
