"""Spec loading and validation: shipped specs load; bad specs are rejected field by field."""

from __future__ import annotations

import tomllib

import pytest
import tomli_w

from modelgen.spec import SpecError, load_spec, parse_spec, shipped_spec_names

SHIPPED = ["balanced-rotor", "duffing", "vakharia2015", "vakharia2015-consistent"]


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


def _problems(data: dict) -> str:
    with pytest.raises(SpecError) as info:
        parse_spec(data, "test.toml")
    return "\n".join(info.value.problems)


def test_unknown_term_names_allowed_kinds():
    data = _data()
    data["terms"][0]["kind"] = "hertz_contakt"
    msg = _problems(data)
    assert "terms.0.kind" in msg and "hertz_contakt" in msg
    assert "did you mean 'hertz_contact'" in msg and "allowed:" in msg


def test_missing_parameter_names_term_and_range():
    data = _data()
    del data["parameters"]["contact_stiffness"]
    msg = _problems(data)
    assert "parameters.contact_stiffness: missing" in msg
    assert "hertz_contact" in msg and "(0, 1e+13] N/m^1.5" in msg


def test_negative_mass_rejected_with_range():
    data = _data()
    data["parameters"]["rotor_mass"]["value"] = -0.6
    msg = _problems(data)
    assert "parameters.rotor_mass.value: must be in (0, 100000] kg, got -0.6" in msg


def test_too_few_balls():
    data = _data()
    data["structure"]["n_balls"] = 2
    assert "structure.n_balls: must be in [3, 64], got 2" in _problems(data)


def test_non_positive_time_step():
    data = _data()
    data["simulation"]["dt"] = 0.0
    assert "simulation.dt: must be in (0, 10] s, got 0.0" in _problems(data)


def test_nan_and_unit_and_typo():
    data = _data()
    data["parameters"]["damping"]["value"] = float("nan")
    data["parameters"]["radial_load"]["unit"] = "kN"
    data["parameters"]["dampign"] = {"value": 1.0, "unit": "N*s/m", "source": "x"}
    data["structure"]["n_bals"] = 6
    msg = _problems(data)
    assert "parameters.damping.value" in msg and "finite" in msg
    assert "structure.n_bals: unknown field (did you mean 'n_balls'?)" in msg
    # the unit and unknown-parameter checks run after field validation succeeds
    data = _data()
    data["parameters"]["radial_load"]["unit"] = "kN"
    data["parameters"]["dampign"] = {"value": 1.0, "unit": "N*s/m", "source": "x"}
    msg = _problems(data)
    assert "parameters.radial_load.unit: must be 'N', got 'kN'" in msg
    assert "parameters.dampign: unknown parameter (did you mean 'damping'?)" in msg


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
