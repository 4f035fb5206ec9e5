"""Campbell and unbalance results against ROSS on the same rotors (needs the [ross] extra).

Two rotors: ROSS's own ``rotor_example()`` (saved by ROSS, read back by ``import-ross``'s
reader) and a rotor of our own with three disks on anisotropic, damped, cross-coupled
bearings, built in ROSS and in our schema from the same numbers. ROSS has 6 DOFs a node
(axial and torsional too); its lateral modes (``Shape.mode_type``) are compared with ours:
damped frequencies within 1e-3, log decrements within 5 % (and 1e-6 absolute where they are
zero), the whirl where ROSS calls it forward or backward, and the 1X unbalance response
(amplitude and phase of x) within 2 % away from the critical speeds.
"""

from __future__ import annotations

import numpy as np
import pytest

from modelgen.fe.assembly import assemble
from modelgen.fe.schema import Shaft, Unbalance
from tests.extras import require_all

pytestmark = pytest.mark.needs_extra

SPEEDS = (0.0, 300.0, 900.0)
"""rad/s."""
MODES = 8


@pytest.fixture(scope="module")
def rs():
    """ROSS, imported once (it takes seconds); its dense solves on one BLAS thread (many
    times faster on a shared machine)."""
    require_all(("ross",), "ross")
    from analysis.threads import blas_threads
    from modelgen.fe.ross_import import import_ross

    module = import_ross()
    with blas_threads():
        yield module


def three_disk_numbers() -> dict:
    return {"L": [0.1] * 12, "odl": 0.045, "disks": [(3, 12.0, 0.06, 0.11),
                                                      (6, 20.0, 0.12, 0.22),
                                                      (9, 9.0, 0.04, 0.07)],
            "bearings": [dict(n=0, kxx=2.0e7, kyy=3.5e7, kxy=2.0e6, kyx=-1.5e6, cxx=900.0,
                              cyy=1300.0, cxy=50.0, cyx=-30.0),
                         dict(n=12, kxx=1.2e7, kyy=2.6e7, kxy=-1.0e6, kyx=1.0e6, cxx=700.0,
                              cyy=1100.0)]}


def three_disk_ross(rs):
    data = three_disk_numbers()
    steel = rs.Material(name="steel", rho=7850.0, E=205e9, G_s=79e9)
    shaft = [rs.ShaftElement(L=length, idl=0.0, odl=data["odl"], material=steel)
             for length in data["L"]]
    disks = [rs.DiskElement(n=n, m=m, Id=i_d, Ip=i_p) for n, m, i_d, i_p in data["disks"]]
    bearings = [rs.BearingElement(**b) for b in data["bearings"]]
    return rs.Rotor(shaft, disks, bearings)


def three_disk_ours() -> Shaft:
    data = three_disk_numbers()
    return Shaft.model_validate({
        "materials": [{"name": "steel", "E": 205e9, "G_s": 79e9, "rho": 7850.0}],
        "elements": [{"L": length, "odl": data["odl"], "material": "steel"}
                     for length in data["L"]],
        "disks": [{"node": n, "m": m, "Id": i_d, "Ip": i_p} for n, m, i_d, i_p in data["disks"]],
        "bearings": [{"node": b["n"], **{k: v for k, v in b.items() if k != "n"}}
                     for b in data["bearings"]]})


def example_ours(rs, tmp_path) -> Shaft:
    from modelgen.fe.ross_import import shaft_from_ross

    path = tmp_path / "rotor.toml"
    rs.rotor_example().save(path)
    return shaft_from_ross(path)


def ross_lateral(rotor, speed):
    """(wd rad/s, log dec, whirl) of ROSS's first MODES lateral modes at ``speed``."""
    modal = rotor.run_modal(speed, num_modes=4 * MODES, sparse=False)
    lateral = np.array([s.mode_type == "Lateral" for s in modal.shapes])
    whirl = np.array([s.whirl for s in modal.shapes])
    return (np.asarray(modal.wd)[lateral][:MODES], np.asarray(modal.log_dec)[lateral][:MODES],
            whirl[lateral][:MODES])


def compare_modes(rotor, shaft):
    from analysis.linear import campbell

    rpm = np.array(SPEEDS) * 30 / np.pi
    ours = campbell(assemble(shaft), rpm, n_modes=MODES)
    worst_f = worst_ld = 0.0
    for j, speed in enumerate(SPEEDS):
        wd, log_dec, whirl = ross_lateral(rotor, speed)
        freq = ours.frequency_hz[:, j] * 2 * np.pi
        worst_f = max(worst_f, float(np.max(np.abs(freq / wd - 1))))
        assert freq == pytest.approx(wd, rel=1e-3)
        assert ours.log_dec[:, j] == pytest.approx(log_dec, rel=0.05, abs=1e-6)
        scale = np.maximum(np.abs(log_dec), 1e-6)
        worst_ld = max(worst_ld, float(np.max(np.abs(ours.log_dec[:, j] - log_dec) / scale)))
        if speed > 0:  # at rest an anisotropic rotor's orbits are lines: no whirl to compare
            for mine, theirs in zip(ours.whirl[:, j], whirl, strict=True):
                if theirs in ("Forward", "Backward"):
                    assert mine == theirs.lower()
    return worst_f, worst_ld


def test_rotor_example_modes_equal_ross(rs, tmp_path):
    worst_f, _ = compare_modes(rs.rotor_example(), example_ours(rs, tmp_path))
    assert worst_f < 1e-9  # the same element matrices: agreement to rounding


def test_three_disk_rotor_modes_equal_ross(rs):
    worst_f, worst_ld = compare_modes(three_disk_ross(rs), three_disk_ours())
    assert worst_f < 1e-9 and worst_ld < 1e-6


def test_rotor_with_structural_damping_equals_ross_state_matrix(rs):
    """ROSS's ``rotor_example_with_damping`` (33 elements with C = alpha M + beta K): the
    eigenvalues of ROSS's own state matrix ``Rotor.A(speed)``, its lateral ones (90 % of the
    eigenvector in x, y, alpha, beta) that are not overdamped in all but name (as ours:
    ``OVERDAMPED``; ROSS's ``run_modal`` lists those first, with damped frequencies near 0)."""
    import scipy.linalg as la

    from analysis.linear import campbell
    from analysis.linear.campbell import OVERDAMPED
    from modelgen.fe.ross_import import shaft_data
    from modelgen.fe.schema import parse_shaft

    rotor = rs.rotor_example_with_damping()
    ours = campbell(assemble(parse_shaft(shaft_data(rotor))),
                    np.array(SPEEDS) * 30 / np.pi, n_modes=MODES)
    lateral = np.array([i for i in range(rotor.ndof) if i % 6 in (0, 1, 3, 4)])
    for j, speed in enumerate(SPEEDS):
        lam, vec = la.eig(rotor.A(speed=speed))
        share = (np.abs(vec[lateral]) ** 2).sum(0) / (np.abs(vec[:rotor.ndof]) ** 2).sum(0)
        keep = (lam.imag > 0) & (share > 0.9) & (lam.imag >= OVERDAMPED * np.abs(lam))
        theirs = np.sort_complex(lam[keep] * -1j)[:MODES] * 1j  # ascending imaginary part
        assert ours.frequency_hz[:, j] * 2 * np.pi == pytest.approx(theirs.imag, rel=1e-3)
        assert ours.frequency_hz[:, j] * 2 * np.pi == pytest.approx(theirs.imag, rel=1e-8)
        log_dec = -2 * np.pi * theirs.real / theirs.imag
        assert ours.log_dec[:, j] == pytest.approx(log_dec, rel=0.05)
        assert ours.log_dec[:, j] == pytest.approx(log_dec, rel=1e-6)


@pytest.mark.parametrize("which", ["example", "three_disk"])
def test_unbalance_response_equals_ross(rs, which, tmp_path):
    from analysis.linear import campbell, unbalance_response

    if which == "example":
        rotor, shaft, node, probe = rs.rotor_example(), example_ours(rs, tmp_path), 3, 2
    else:
        rotor, shaft, node, probe = three_disk_ross(rs), three_disk_ours(), 6, 3
    omega = np.linspace(10.0, 1500.0, 60)
    response = rotor.run_unbalance_response([node, 0], [1e-4, 5e-5], [0.0, np.pi / 3], omega)
    theirs = response.forced_resp[rotor.number_dof * probe]
    rotor_matrices = assemble(shaft)
    ours = unbalance_response(rotor_matrices, probe, omega * 30 / np.pi,
                              [Unbalance(node=node, magnitude=1e-4, phase=0.0),
                               Unbalance(node=0, magnitude=5e-5, phase=np.pi / 3)])
    critical = [c.speed_rpm * np.pi / 30 for c in campbell(
        rotor_matrices, omega * 30 / np.pi, n_modes=MODES).critical]
    away = np.array([all(abs(w / c - 1) > 0.1 for c in critical) for w in omega])
    assert away.sum() > 20
    assert ours.amplitude_m[away] == pytest.approx(np.abs(theirs[away]), rel=0.02)
    assert ours.x[away] == pytest.approx(theirs[away], rel=0.02)  # phase too
    assert np.max(np.abs(ours.x / theirs - 1)) < 1e-6  # everywhere, in fact


def test_import_ross_swaps_a_bearing_and_refuses_what_ross_cannot_read(rs, tmp_path):
    import tomllib

    from analysis.cli.import_ross import parse_ball_bearings
    from analysis.errors import InputError
    from modelgen.errors import SpecError
    from modelgen.fe.ross_import import ross_spec_text

    rotor_file = tmp_path / "rotor.toml"
    rs.rotor_example().save(rotor_file)
    text = ross_spec_text(rotor_file, tmp_path / "ross-example.toml",
                          parse_ball_bearings(["6=6205"]))
    spec = tomllib.loads(text)
    assert spec["model"]["name"] == "ross-example"
    assert spec["bearings"] == [{"name": "b6", "inner": "shaft", "node": 6, "n_balls": 9}]
    assert [b["node"] for b in spec["shaft"]["bearings"]] == [0]  # node 6's linear one gone
    assert spec["parameters"]["ball_diameter"]["value"] == pytest.approx(4.762e-3)
    assert {t["kind"] for t in spec["terms"]} == {"hertz_contact", "viscous_damping"}
    assert len(spec["shaft"]["elements"]) == 6 and len(spec["shaft"]["disks"]) == 2
    with pytest.raises(SpecError, match="no bearing at node 3 to swap"):
        ross_spec_text(rotor_file, tmp_path / "x.toml", parse_ball_bearings(["3=6205"]))
    with pytest.raises(InputError, match="--ball-bearing: no bearing 'nonesuch'"):
        parse_ball_bearings(["6=nonesuch"])
    with pytest.raises(InputError, match="--ball-bearing: expected NODE=NAME"):
        parse_ball_bearings(["six=6205"])
    bad = tmp_path / "broken.toml"  # the command's error edge: tests/linear/test_linear.py
    bad.write_text('[parameters]\n["ShaftElement_0"]\nL = "long"\n')
    with pytest.raises(SpecError, match=r"broken\.toml: ROSS cannot read it as a rotor") as info:
        ross_spec_text(bad, tmp_path / "x.toml")
    assert "\n" not in str(info.value)
    assert not (tmp_path / "x.toml").exists()
