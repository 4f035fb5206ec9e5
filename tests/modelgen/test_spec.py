"""Spec loading and validation: shipped specs load; bad specs are rejected field by field."""

from __future__ import annotations

import tomllib

import pytest
import tomli_w

from modelgen.spec import load_spec, parse_spec, shipped_spec_names

SHIPPED = ["6205-ball-defect", "6205-inner-defect", "6205-outer-defect", "balanced-rotor",
           "duffing", "mathieu", "nu205-roller", "rotor-housing", "three-disk-rotor",
           "two-bearing-rotor",
           "vakharia2015", "vakharia2015-calibrated", "vakharia2015-consistent",
           "vakharia2015-two-contact"]


def test_shipped_specs_load():
    assert shipped_spec_names() == SHIPPED
    for name in SHIPPED:
        spec, path = load_spec(name)
        assert spec.model.name == name == path.stem
        for par in spec.parameters.values():
            assert par.source.strip(), "every parameter names its source"


def test_paper_values_are_the_papers():
    spec, _ = load_spec("vakharia2015")
    p = spec.parameter_values()
    assert p["radial_load"] == 6.0 and p["unbalance_force"] == pytest.approx(0.1 * 6.0)
    assert p["radial_clearance"] == 10e-6 and p["speed_rpm"] == 5000
    assert (p["inner_race_diameter"], p["outer_race_diameter"]) == (18.738e-3, 28.262e-3)
    assert (p["pitch_diameter"], p["ball_diameter"]) == (26.725e-3, 4.762e-3)
    for assumed in ("rotor_mass", "contact_stiffness", "damping"):
        assert "assumption" in spec.parameters[assumed].source
    consistent, _ = load_spec("vakharia2015-consistent")
    d = consistent.parameter_values()
    assert d["pitch_diameter"] == pytest.approx((18.738e-3 + 28.262e-3) / 2)


def _data(name: str = "vakharia2015") -> dict:
    _, path = load_spec(name)
    return tomllib.loads(path.read_text())


def test_spec_file_is_data_never_code(tmp_path):
    evil = _data()
    evil["model"]["title"] = "__import__('os').system('touch PWNED')"
    evil["model"]["name"] = "evil"
    path = tmp_path / "evil.toml"
    path.write_text(tomli_w.dumps(evil))
    spec, _ = load_spec(path)
    assert spec.model.title.startswith("__import__")  # kept as text
    assert not (tmp_path / "PWNED").exists()


def test_round_trip_through_toml(tmp_path):
    spec, _ = load_spec("vakharia2015-consistent")
    text = tomli_w.dumps(spec.model_dump())
    again = parse_spec(tomllib.loads(text))
    assert again == spec
