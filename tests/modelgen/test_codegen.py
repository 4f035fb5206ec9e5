"""Generated code: matches the committed tree, is deterministic, and computes the equations."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import sympy as sp

from analysis.errors import StaleModelError
from analysis.model import check_fresh, load_model
from modelgen.assemble import assemble
from modelgen.codegen import generate, render
from modelgen.spec import load_spec, shipped_spec_names
from tests.conftest import SPECS


def test_committed_generated_tree_is_fresh():
    assert generate(shipped_spec_names(), check=True) == []


def test_regeneration_is_byte_identical():
    first, second = render("vakharia2015").files, render("vakharia2015").files
    assert first == second
    digest = load_model("vakharia2015").spec_sha256
    for rel, text in first.items():
        assert digest in text, f"{rel} records the spec hash"
        assert "sympy 1.14.0" in text and "casadi 3.8.2" in text


def test_check_fails_after_spec_edit(tmp_path):
    spec = tmp_path / "vakharia2015.toml"
    shutil.copy(SPECS / "vakharia2015.toml", spec)
    root = tmp_path / "gen"
    generate([spec], root=root)
    assert generate([spec], root=root, check=True) == []
    spec.write_text(spec.read_text().replace("value = 200.0", "value = 150.0"))
    stale = generate([spec], root=root, check=True)
    assert "vakharia2015/__init__.py" in stale and "vakharia2015/MODEL.md" in stale


def test_stale_model_is_an_error():
    module = load_model("vakharia2015").module

    class Edited:
        SPEC_FILE = module.SPEC_FILE
        SPEC_SHA256 = "0" * 64

    with pytest.raises(StaleModelError, match="bearingdyn generate vakharia2015"):
        check_fresh(Edited, "vakharia2015")


@pytest.mark.parametrize("name", ["vakharia2015", "vakharia2015-consistent", "balanced-rotor"])
@pytest.mark.parametrize("n_balls", [3, 7, 10])
def test_generated_rhs_matches_plain_sympy(name, n_balls):
    """CasADi rhs (CSE, angle addition, d·√d) vs lambdify of the unoptimised SymPy equations."""
    spec = load_spec(name)[0]
    eq = assemble(spec)
    ctx = eq.ctx
    exact = sp.lambdify([ctx.t, *ctx.state, *ctx.params.values()], eq.first_order(n_balls),
                        modules="numpy")
    model = load_model(name)
    rhs = model.functions(n_balls).rhs
    rng = np.random.default_rng(n_balls)
    base = model.defaults
    for _ in range(20):
        values = {k: v * rng.uniform(0.5, 1.5) for k, v in base.items()}
        values["speed_rpm"] = rng.uniform(0, 30000)
        z = np.concatenate([rng.uniform(-15e-6, 15e-6, 2), rng.uniform(-0.05, 0.05, 2)])
        t = rng.uniform(0, 1)
        got = np.asarray(rhs(t, z, model.parameter_vector(values))).ravel()
        want = np.asarray(exact(t, *z, *values.values()), dtype=float).ravel()
        scale = np.abs(want[2:]).max() + 1e-300
        np.testing.assert_allclose(got[:2], want[:2], rtol=1e-15)
        np.testing.assert_allclose(got[2:], want[2:], rtol=1e-12, atol=1e-12 * scale)


def test_jacobian_is_finite_where_a_ball_leaves_contact():
    model = load_model("balanced-rotor")
    funcs = model.functions(8)
    p = model.parameter_vector(model.defaults)
    gamma = model.defaults["radial_clearance"]
    z = np.array([gamma, 0.0, 0.0, 0.0])  # ball 0 exactly at δ = 0 at t = 0
    jac = np.asarray(funcs.jac(0.0, z, p))
    assert np.all(np.isfinite(jac))
    # second derivative through the switch is finite too (what Floquet/Newton need)
    import casadi as ca

    zs = ca.SX.sym("z", 4)
    hess = ca.Function("h", [zs], [ca.jacobian(funcs.jac(0.0, zs, p)[2, 0], zs)])
    assert np.all(np.isfinite(np.asarray(hess(z))))


def test_generated_models_run_without_sympy():
    """The import walls: a generated model and the analysis layer never load SymPy or
    modelgen's internals (``modelgen.locations``, standard library only, locates the spec
    files and the user cache)."""
    import subprocess
    import sys

    code = ("import sys\n"
            "from analysis import simulate, find_peaks\n"
            "ds = simulate('vakharia2015', 6, duration=0.05, transient=0.0)\n"
            "find_peaks(ds, 'x')\n"
            "bad = [m for m in sys.modules if m.split('.')[0] == 'sympy'\n"
            "       or (m.startswith('modelgen.') and m != 'modelgen.locations')]\n"
            "print(bad)\n"
            "assert not bad, bad\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr + res.stdout
