"""Options of the hertz_contact term: clearance convention and stiffness from the geometry."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import load_model
from modelgen.hertz import combined_stiffness, race_contact
from modelgen.spec import SpecError, parse_spec
from tests.model_variants import parameter, spec_data, variant

GEOMETRY = {"groove_conformity_inner": parameter(0.52, "1"),
            "groove_conformity_outer": parameter(0.52, "1"),
            "youngs_modulus": parameter(208e9, "Pa"), "poisson_ratio": parameter(0.3, "1")}


def random_states(model, seed: int, count: int = 30):
    """(t, z, p) at random states and parameters around the defaults."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        values = {k: v * rng.uniform(0.8, 1.2) for k, v in model.defaults.items()}
        values["speed_rpm"] = rng.uniform(0, 30000)
        z = np.concatenate([rng.uniform(-25e-6, 25e-6, 2), rng.uniform(-0.05, 0.05, 2)])
        yield rng.uniform(0, 1), z, values


def test_diametral_clearance_of_twice_the_radial_is_the_same_model(tmp_path):
    """clearance = "diametral" with P_d = 2 γ_0 gives the rhs of the radial-clearance model
    (vakharia2015-consistent) exactly (γ_0 = P_d/2 is exact in binary)."""
    data = spec_data("vakharia2015-consistent")
    terms = [{**data["terms"][0], "clearance": "diametral"}, *data["terms"][1:]]
    gamma = data["parameters"]["radial_clearance"]["value"]
    model, _ = variant(tmp_path, "vakharia2015-consistent", "diametral", terms=terms,
                       drop=("radial_clearance",),
                       parameters={"diametral_clearance": parameter(2 * gamma, "m")})
    reference = load_model("vakharia2015-consistent")
    rhs, rhs_ref = model.functions(7).rhs, reference.functions(7).rhs
    for t, z, values in random_states(reference, 1):
        diametral = {k: v for k, v in values.items() if k != "radial_clearance"}
        diametral["diametral_clearance"] = 2 * values["radial_clearance"]
        np.testing.assert_array_equal(np.asarray(rhs(t, z, model.parameter_vector(diametral))),
                                      np.asarray(rhs_ref(t, z,
                                                         reference.parameter_vector(values))))


def test_geometry_stiffness_is_the_given_stiffness_it_computes(tmp_path):
    """stiffness = "geometry" and stiffness = "given" with k set to the geometric K agree."""
    data = spec_data("vakharia2015-consistent")
    terms = [{**data["terms"][0], "stiffness": "geometry"}, *data["terms"][1:]]
    model, _ = variant(tmp_path, "vakharia2015-consistent", "geometry", terms=terms,
                       drop=("contact_stiffness",), parameters=GEOMETRY)
    reference = load_model("vakharia2015-consistent")
    rhs, rhs_ref = model.functions(8).rhs, reference.functions(8).rhs
    for t, z, values in random_states(reference, 2):
        geometry = {k: v for k, v in values.items() if k != "contact_stiffness"}
        geometry.update({k: v["value"] for k, v in GEOMETRY.items()})
        k = combined_stiffness(*(race_contact(
            values["ball_diameter"], values["pitch_diameter"], 0.52, 208e9, 0.3, race
        ).stiffness for race in ("inner", "outer")))
        got = np.asarray(rhs(t, z, model.parameter_vector(geometry))).ravel()
        want = np.asarray(rhs_ref(t, z, reference.parameter_vector(
            {**values, "contact_stiffness": k}))).ravel()
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize(("option", "missing"), [
    ({"stiffness": "geometry"}, "groove_conformity_inner"),
    ({"clearance": "diametral"}, "diametral_clearance"),
])
def test_options_ask_for_their_parameters(option, missing):
    data = spec_data("vakharia2015-consistent")
    data["terms"][0].update(option)
    with pytest.raises(SpecError, match=f"parameters.{missing}: missing; terms\\[0\\] "
                                        "\\(hertz_contact\\) needs it"):
        parse_spec(data)
