"""A shaft's unbalances play the ``unbalance_force`` role: ``three-disk-rotor`` scales its
``[[shaft.unbalances]]`` by the parameter ``unbalance_scale`` (default 1), so its runs say
they are unbalanced and the classifier counts X among the forcing frequencies, as for the
rigid ``vakharia2015`` with its ``unbalance_force``; at ``unbalance_scale = 0`` the only
forcing is VC and ``vc[left]`` is a period of it again.

Checked against what does not share the code under test: the spec's m·e (read from the
TOML) times Ω² through the generated ``NODE_MAP`` for the force, and the run attrs written
by ``simulate`` (the library's own writer) for the forcing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.forcing import run_unbalance
from analysis.integrate.flow import Period
from analysis.integrate.simulate import simulate
from analysis.model import as_system, load_model
from analysis.stability.classify import commensurate_groups, forcing_frequencies
from modelgen.spec import load_spec
from tests.conftest import SPECS

MODEL = "three-disk-rotor"


def _force(model, scale: float, t: float) -> np.ndarray:
    values = {**model.defaults, "unbalance_scale": scale}
    return np.array(model.module.external_force([0.0] * model.n_state, t,
                                                list(values.values())), dtype=float)


def test_unbalance_scale_plays_the_unbalance_role_and_scales_the_shaft_force():
    model = load_model(MODEL)
    assert model.role("unbalance_force") == ("unbalance_scale",)
    spec, _ = load_spec(SPECS / f"{MODEL}.toml")
    (unbalance,) = spec.shaft.unbalances
    omega = math.pi / 30 * model.defaults["speed_rpm"]
    amplitude = unbalance.magnitude * omega**2  # m e Ω², N
    rows = model.module.NODE_MAP[unbalance.node]
    for t, (fx, fy) in ((0.0, (amplitude, 0.0)), (math.pi / (2 * omega), (0.0, amplitude))):
        expected = np.zeros(model.n_state // 2)
        for j, a, b in rows:  # T_node^T f: the unbalance's generalised force
            expected[j] += a * fx + b * fy
        one = _force(model, 1.0, t) - _force(model, 0.0, t)
        np.testing.assert_allclose(one, expected, rtol=1e-9, atol=1e-12 * amplitude)
        np.testing.assert_allclose(_force(model, 2.5, t) - _force(model, 0.0, t), 2.5 * one,
                                   rtol=1e-9, atol=1e-12 * amplitude)


@pytest.mark.parametrize(("model", "parameter"), [(MODEL, "unbalance_scale"),
                                                  ("vakharia2015", "unbalance_force")])
def test_runs_count_x_as_a_forcing_while_unbalanced(model, parameter):
    """The same verdict for the flexible and the rigid rotor: unbalanced, X joins VC and the
    forcing has two incommensurate groups (no period of the map); balanced, VC alone."""
    runs = {scale: simulate(model, duration=5e-5, transient=0.0, dt=1e-5,
                            **{parameter: scale * load_model(model).defaults[parameter]})
            for scale in (1.0, 0.0)}
    unbalanced, balanced = runs[1.0].attrs, runs[0.0].attrs
    assert run_unbalance(unbalanced) > 0 and run_unbalance(balanced) == 0.0
    shaft_hz = load_model(model).defaults["speed_rpm"] / 60
    forced = forcing_frequencies(unbalanced)
    assert forced["X"] == pytest.approx(shaft_hz)
    assert len(forced) == 2 and len(commensurate_groups(forced)) == 2
    calm = forcing_frequencies(balanced)
    assert "X" not in calm and len(calm) == 1
    (vc_hz,) = calm.values()
    vc = Period.parse("vc[left]" if model == MODEL else "vc")
    assert 1.0 / vc_hz == pytest.approx(vc.seconds_in(as_system(model, **{parameter: 0.0})),
                                        rel=1e-12)


def test_cli_refuses_a_negative_unbalance_scale(cli):
    res = cli("simulate", MODEL, "--set", "unbalance_scale=-1", "--duration", "1e-4",
              "-o", "never.nc")
    assert res.returncode == 2
    assert "unbalance_scale" in res.stderr
