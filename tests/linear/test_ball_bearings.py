"""Ball bearings on the shaft, linearised at the static equilibrium (no ROSS needed).

* The static loads follow the lever rule: a load W at distance a from the left bearing of a
  span L puts W (L − a)/L on the left one and W a / L on the right one, and each bearing's
  coefficients are those `bearingdyn stiffness` gives its one-bearing model at that load.
* The limit of a very stiff shaft: a disk midway between two equal ball bearings, total mass
  2m and load 2W, is two copies of the rigid one-bearing model (mass m, load W): its
  translation modes have the rigid model's linearised frequencies sqrt(k/m − (c/2m)²).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tomli_w

from analysis.linear import campbell
from analysis.linear.rotor import load_rotor
from analysis.stability.statics import coefficients

MODEL = "balanced-rotor"  # hertz_contact + viscous_damping: the seed model's contact terms


def ball_spec(path, *, load_node: int, load: float, e: float = 211e9, rho: float = 7810.0,
              disk: tuple[float, float] = (2.0, 1e-3), n_elements: int = 8,
              odl: float = 0.03) -> str:
    spec = {
        "model": {"name": path.stem, "title": "t"},
        "bearings": [{"name": "left", "inner": "shaft", "node": 0, "n_balls": 8},
                     {"name": "right", "inner": "shaft", "node": n_elements, "n_balls": 8}],
        "shaft": {"materials": [{"name": "m", "E": e, "nu": 0.3, "rho": rho}],
                  "elements": [{"L": 0.4 / n_elements, "odl": odl, "material": "m"}]
                  * n_elements,
                  "disks": [{"node": n_elements // 2, "m": disk[0], "Id": disk[1],
                             "Ip": 2 * disk[1]}]},
        "parameters": {"speed_rpm": {"value": 3000.0}, "damping": {"value": 150.0},
                       "radial_load": {"value": load},
                       "radial_clearance": {"value": 8e-6}},
        "terms": [{"kind": "hertz_contact", "bearing": "left"},
                  {"kind": "hertz_contact", "bearing": "right"},
                  {"kind": "viscous_damping", "bearing": "left"},
                  {"kind": "viscous_damping", "bearing": "right"},
                  {"kind": "radial_load", "body": f"node{load_node}"}]}
    path.write_text(tomli_w.dumps(spec))
    return str(path)


def test_static_loads_follow_the_lever_rule_and_give_the_one_bearing_coefficients(tmp_path):
    rotor = load_rotor(ball_spec(tmp_path / "lever.toml", load_node=2, load=80.0), [1000.0])
    left, right = rotor.shaft.bearings
    expected = {0: 80.0 * 6 / 8, 8: 80.0 * 2 / 8}  # a = 0.1 m of L = 0.4 m
    for bearing in (left, right):
        ds = coefficients(MODEL, 8, radial_load=expected[bearing.node], damping=150.0,
                          radial_clearance=8e-6, speed_rpm=1000.0)
        k = ds.stiffness_mean.values
        assert bearing.kxx == pytest.approx(k[0, 0], rel=1e-6)
        assert bearing.kyy == pytest.approx(k[1, 1], rel=1e-6)
        assert bearing.cxx == pytest.approx(150.0)
    assert left.kxx > 1.3 * right.kxx  # three times the load: stiffer (Hertz: ~ 3^(1/3))
    assert rotor.lines["VC"] == pytest.approx(8 * (1 - 4.762 / 23.5) / 2, rel=1e-12)


def test_a_very_stiff_shaft_has_the_rigid_one_bearing_model_s_frequencies(tmp_path):
    m, w = 0.6, 6.0  # the rigid model's rotor mass (kg) and load (N)
    shaft_mass = 1.0 * math.pi * 0.1**2 / 4 * 0.4  # 100 mm, 1e13 Pa: 1000 x the bearings
    spec = ball_spec(tmp_path / "stiff.toml", load_node=4, load=2 * w, e=1e13, rho=1.0,
                     disk=(2 * m - shaft_mass, 1e-7), odl=0.1)
    rotor = load_rotor(spec, [0.0])
    found = campbell(rotor.matrices, [0.0], n_modes=4).frequency_hz[:, 0]
    k = coefficients(MODEL, 8, radial_load=w, damping=150.0, radial_clearance=8e-6
                     ).stiffness_mean.values
    rigid = [math.sqrt(k[i, i] / m - (150.0 / (2 * m)) ** 2) / (2 * math.pi) for i in (1, 0)]
    assert np.sort(found)[:2] == pytest.approx(sorted(rigid), rel=1e-3)


def test_a_ball_bearing_without_load_is_refused(tmp_path):
    from analysis.errors import InputError

    with pytest.raises(InputError, match="carry no static load"):
        load_rotor(ball_spec(tmp_path / "free.toml", load_node=2, load=0.0), [1000.0])
