"""Roles instead of names: a generated module says which parameter plays which role
(``ROLES``, written from what its terms read), and the analysis layer asks for the role, so
a spec that names its clearance otherwise keeps its blow-up bound and its RK4 probe."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
import tomli_w

from analysis.integrate.checks import probe_states, stable_step
from analysis.integrate.simulate import blow_up_limit
from analysis.model import LEGACY_ROLES, Model, System, load_model
from modelgen.errors import SpecError
from modelgen.spec import load_spec
from modelgen.terms.base import ROLE_NAMES
from tests.conftest import SPECS


def renamed_clearance(folder: Path, name: str = "gap-rotor") -> Path:
    """balanced-rotor with its clearance parameter called ``gap``, bound to the contact."""
    data = tomllib.loads((SPECS / "balanced-rotor.toml").read_text())
    data["model"]["name"] = name
    data["parameters"]["gap"] = {**data["parameters"].pop("radial_clearance"),
                                 "low": -1e-3, "high": 1e-3}
    data["terms"][0]["bind"] = {"radial_clearance": "gap"}
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps(data))
    return path


def test_the_role_names_of_modelgen_and_of_the_analysis_fallback_agree():
    assert tuple(LEGACY_ROLES) == ROLE_NAMES


def test_shipped_models_say_which_parameter_plays_which_role():
    balanced = load_model("balanced-rotor")
    assert balanced.role("clearance") == ("radial_clearance",)
    assert balanced.role("contact_stiffness") == ("contact_stiffness",)
    assert balanced.role("unbalance_force") == ()
    assert load_model("mathieu").role("forcing_period") == ("forcing_period",)
    assert load_model("nu205-roller").role("contact_stiffness") == ()  # line contact: no k
    assert load_model("two-bearing-rotor").role("unbalance_force") == ("unbalance_force",)
    with pytest.raises(ValueError, match="role: must be one of clearance"):
        balanced.role("gap")


def test_a_renamed_clearance_keeps_the_blow_up_bound_and_the_rk4_probe(user_cache):
    model = load_model(renamed_clearance(user_cache))
    assert model.role("clearance") == ("gap",)
    reference = load_model("balanced-rotor")
    values, ref_values = model.defaults, reference.defaults
    assert blow_up_limit(model, values) == blow_up_limit(reference, ref_values) == 1000 * 10e-6
    system, ref_system = System.make(model, 8), System.make(reference, 8)
    assert len(probe_states(system)) == len(probe_states(ref_system)) > 1
    assert stable_step(system) == stable_step(ref_system)


def test_a_binding_names_a_parameter_the_term_reads(tmp_path):
    path = renamed_clearance(tmp_path, "bad-bind")
    data = tomllib.loads(path.read_text())
    data["terms"][0]["bind"] = {"radial_clearence": "gap"}
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(SpecError, match=re.escape(
            "terms[0] (hertz_contact).bind.radial_clearence: the term reads no parameter "
            "'radial_clearence' (did you mean 'radial_clearance'?)")):
        load_spec(path)


def test_a_folder_generated_before_roles_falls_back_to_the_old_names(user_cache):
    from modelgen.codegen import generate

    out = user_cache / "old"
    spec = user_cache / "old-rotor.toml"
    data = tomllib.loads((SPECS / "balanced-rotor.toml").read_text())
    data["model"]["name"] = "old-rotor"
    spec.write_text(tomli_w.dumps(data))
    generate([spec], root=out)
    init = out / "old_rotor" / "__init__.py"
    text = init.read_text()
    init.write_text(re.sub(r"\nROLES = \{.*?\n\}\n", "\n", text, flags=re.S))
    for manifest in out.rglob("MANIFEST.json"):  # folders from before ROLES had none either
        manifest.unlink()
    model = load_model(out / "old_rotor")
    assert not hasattr(model.module, "ROLES")
    assert isinstance(model, Model)
    assert model.role("clearance") == ("radial_clearance",)
    assert model.role("forcing_period") == ()
    assert blow_up_limit(model, model.defaults) == 1000 * 10e-6
