"""Hunt–Crossley contact damping (damping = "hunt_crossley", paper Eq. 10 per ball)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from modelgen.assemble import assemble
from tests.model_variants import parameter, spec_data, variant

ALPHA = 0.3  # s/m


@pytest.fixture(scope="module")
def damped(tmp_path_factory):
    """vakharia2015-consistent with Hunt–Crossley contacts instead of viscous damping."""
    terms = [{"kind": "hertz_contact", "cage": "race_diameters", "damping": "hunt_crossley"},
             {"kind": "centrifugal", "variant": "loaded_zone"},
             {"kind": "radial_load"}, {"kind": "unbalance"}]
    return variant(tmp_path_factory.mktemp("hc"), "vakharia2015-consistent", "hunt-crossley",
                   terms=terms, drop=("damping",),
                   parameters={"hunt_crossley_damping": parameter(ALPHA, "s/m")})


def hand_load(values: dict, cage: float, theta: float, z: np.ndarray) -> float:
    """K δ^1.5 (1 + 3/2 α δ̇) − F_c, clamped at 0, written out by hand."""
    x, y, vx, vy = z
    c, s = np.cos(theta), np.sin(theta)
    delta = x * c + y * s - values["radial_clearance"]
    rate = vx * c + vy * s + cage * (-x * s + y * c)
    m_b = values["ball_density"] * np.pi * values["ball_diameter"] ** 3 / 6
    f_c = 0.5 * m_b * values["pitch_diameter"] * cage**2
    elastic = values["contact_stiffness"] * max(delta, 0.0) ** 1.5
    return max(0.0, elastic * max(0.0, 1 + 1.5 * values["hunt_crossley_damping"] * rate) - f_c)


def test_ball_load_matches_hand_computation(damped):
    """Per-ball load of the generated code vs the law by hand, with the cage moving."""
    model, _ = damped
    rng = np.random.default_rng(3)
    for _ in range(200):
        values = {**model.defaults, "speed_rpm": rng.uniform(0, 20000)}
        p = model.parameter_vector(values)
        cage = float(model.cage_speed("bearing", p))
        theta, t = rng.uniform(0, 2 * np.pi), rng.uniform(0, 1)
        z = np.concatenate([rng.uniform(-20e-6, 20e-6, 2), rng.uniform(-0.3, 0.3, 2)])
        got = float(model.module.ball_load_bearing(np.cos(theta), np.sin(theta), 1, 6, z, t, p))
        assert got == pytest.approx(hand_load(values, cage, theta, z), rel=1e-12, abs=1e-12)


def test_a_ball_never_pulls(damped):
    """Separating fast (1 + 3/2 α δ̇ < 0) the load is 0, not negative."""
    model, _ = damped
    p = model.parameter_vector(model.defaults)
    z = np.array([20e-6, 0.0, -10.0, 0.0])  # compressed 10 µm, leaving at 10 m/s
    assert float(model.module.ball_load_bearing(1.0, 0.0, 1, 6, z, 0.0, p)) == 0.0


def test_restitution_of_a_single_ball_impact(damped):
    """Hunt & Crossley (1975): a Hertz contact with this damping returns an impact at speed
    v with the coefficient of restitution e = 1 − α v + O((α v)²). One ball at θ = 0, no
    rotation, no other force: the rotor hits it at v and leaves at e·v."""
    _, spec = damped
    eq = assemble(spec)
    ctx = eq.ctx
    load = sp.lambdify([ctx.x, ctx.vx, *ctx.params.values()],
                       eq.ball_load.subs({ctx.c: 1, ctx.s: 0, ctx.y: 0, ctx.vy: 0}))
    values = {**spec.parameter_values(), "speed_rpm": 0.0}
    gamma, mass = values["radial_clearance"], values["rotor_mass"]
    args = list(values.values())

    def restitution(v_in: float) -> float:
        def rhs(_t, state):
            x, v = state
            return [v, -float(load(x, v, *args)) / mass]

        def leave(_t, state):
            return state[0] - gamma
        leave.terminal, leave.direction = True, -1
        run = solve_ivp(rhs, [0, 1e-2], [gamma + 1e-15, v_in], events=leave, rtol=1e-11,
                        atol=1e-16, max_step=1e-6)
        return -run.y_events[0][0][1] / v_in

    for v in (0.01, 0.03, 0.1):
        e = restitution(v)
        assert 1 - e == pytest.approx(ALPHA * v, rel=0.05 + 2 * ALPHA * v)
    # and the deviation is second order: (1 − e)/(α v) → 1 as v → 0
    dev = [abs((1 - restitution(v)) / (ALPHA * v) - 1) for v in (0.02, 0.01)]
    assert dev[1] < 0.6 * dev[0]


def test_phase_space_contraction_is_not_constant(damped):
    """With viscous damping div f = −2c/M_R everywhere; with contact damping it is
    −(3/2) α K/M_R · Σ δ_i^{3/2} over the balls in contact (0 with all balls free)."""
    model, _ = damped
    funcs = model.functions(6)
    values = model.defaults
    p = model.parameter_vector(values)
    traces = []
    for x in (0.0, 14e-6, 18e-6):
        z = np.array([x, 0.0, 0.0, 0.0])
        jac = np.asarray(funcs.jac(0.0, z, p))
        theta = 2 * np.pi * np.arange(6) / 6
        delta = np.maximum(x * np.cos(theta) - values["radial_clearance"], 0.0)
        expected = -1.5 * ALPHA * values["contact_stiffness"] / values["rotor_mass"] * np.sum(
            delta**1.5)
        assert np.trace(jac) == pytest.approx(expected, rel=1e-12, abs=1e-12)
        traces.append(np.trace(jac))
    assert traces[0] == 0.0 and traces[2] < traces[1] < 0


def test_spec_option_names_its_parameter():
    data = spec_data("vakharia2015-consistent")
    data["terms"][0]["damping"] = "hunt_crossley"
    from modelgen.spec import SpecError, parse_spec

    with pytest.raises(SpecError, match="hunt_crossley_damping: missing"):
        parse_spec(data)
