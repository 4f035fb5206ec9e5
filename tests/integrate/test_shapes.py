"""Models of any shape against independent codes: the rotor in a sprung housing against a
hand-written NumPy RK4 of the same equations, its stiff-housing limit against the one-body
model, and the two-bearing rotor's static equilibrium against a root finder of the static
balance written out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from analysis import simulate
from analysis.model import System, load_model

CALM = {"radial_load": 50.0, "damping": 2000.0}
"""A non-chaotic setting of the paper's bearing: the rotor settles into the loaded zone."""


def housing_rhs(t: float, z: np.ndarray, v: dict[str, float], n_balls: int) -> np.ndarray:
    """d/dt [x_r, y_r, x_h, y_h, vx_r, vy_r, vx_h, vy_h] of a rotor in a ball bearing whose
    outer race is a housing on springs and dampers to ground, written out by hand."""
    xr, yr, xh, yh, vxr, vyr, vxh, vyh = z
    omega = math.pi / 30 * v["speed_rpm"]
    d_i, d_o = v["inner_race_diameter"], v["outer_race_diameter"]
    theta = 2 * np.pi * np.arange(n_balls) / n_balls + omega * d_i / (d_i + d_o) * t
    delta = (xr - xh) * np.cos(theta) + (yr - yh) * np.sin(theta) - v["radial_clearance"]
    q = v["contact_stiffness"] * np.where(delta > 0, np.abs(delta) ** 1.5, 0.0)
    qx, qy = np.sum(q * np.cos(theta)), np.sum(q * np.sin(theta))
    c = v["damping"]
    fxr = v["radial_load"] + v["unbalance_force"] * math.cos(omega * t) - c * (vxr - vxh) - qx
    fyr = v["unbalance_force"] * math.sin(omega * t) - c * (vyr - vyh) - qy
    k_h, c_h = v["housing_stiffness"], v["housing_damping"]
    fxh = -k_h * xh - c_h * vxh + c * (vxr - vxh) + qx
    fyh = -k_h * yh - c_h * vyh + c * (vyr - vyh) + qy
    m_r, m_h = v["rotor_mass"], v["housing_mass"]
    return np.array([vxr, vyr, vxh, vyh, fxr / m_r, fyr / m_r, fxh / m_h, fyh / m_h])


def numpy_rk4(rhs, z0: np.ndarray, h: float, n_steps: int) -> np.ndarray:
    """Classical RK4 in a Python loop; the final state."""
    z, t = np.array(z0, dtype=float), 0.0
    for k in range(n_steps):
        t = k * h
        k1 = rhs(t, z)
        k2 = rhs(t + h / 2, z + h / 2 * k1)
        k3 = rhs(t + h / 2, z + h / 2 * k2)
        k4 = rhs(t + h, z + h * k3)
        z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return z


def test_rotor_housing_equals_a_hand_written_rk4():
    """Generated code vs the equations written out by hand, same RK4 step, 0.05 s."""
    system = System.make("rotor-housing", **CALM)
    values = dict(system.parameters)
    n_steps = 5000
    ds = simulate(system, duration=n_steps * 1e-5, transient=0.0)
    ours = np.array([float(ds[v][-1]) for v in system.state_names])
    hand = numpy_rk4(lambda t, z: housing_rhs(t, z, values, 8), system.state, 1e-5, n_steps)
    scale = np.array([*[np.abs(ds[v]).max() for v in system.state_names]])
    assert np.max(np.abs(ours - hand) / scale) < 1e-8
    assert ds.x_housing.attrs["units"] == "m" and ds.vy_rotor.attrs["units"] == "m/s"


def test_stiff_light_housing_approaches_the_one_body_model():
    """With the housing ever stiffer (and light), the rotor moves as on a rigid support
    (vakharia2015 with the same bearing, loads and damping): the difference falls in
    proportion to the housing's compliance."""
    one = simulate("vakharia2015", 8, duration=0.03, transient=0.0, **CALM)
    errors = []
    for k_h in (1e9, 1e10):
        ds = simulate("rotor-housing", 8, duration=0.03, transient=0.0, dt=2e-7,
                      housing_stiffness=k_h, housing_mass=1e-3, housing_damping=100.0, **CALM)
        ds = ds.isel(t=slice(None, None, 50))  # the one-body run's 1e-5 s samples
        assert np.allclose(ds.t, one.t, rtol=0, atol=1e-12)
        size = float(np.abs(one.x).max())
        errors.append(max(float(np.abs(ds.x_rotor - one.x).max()),
                          float(np.abs(ds.y_rotor - one.y).max())) / size)
    assert errors[1] < 2e-3
    assert errors[1] < errors[0] / 5  # compliance ten times smaller, difference about too


def test_two_bearing_rotor_settles_at_the_static_balance():
    """At rest (speed 0: the balls do not move) under a radial load, the rotor settles where
    the two bearings' Hertz forces and their moments balance the load: a 4 × 4 root of the
    static balance written out by hand (fsolve) gives the same translation and tilt."""
    values = {"speed_rpm": 0.0, "unbalance_force": 0.0, "damping": 2000.0, "radial_load": 40.0}
    model = load_model("two-bearing-rotor")
    v = model.parameters(values)
    ds = simulate(model, duration=0.3, transient=0.29, **values)
    settled = np.array([float(ds[n][-1]) for n in ("x", "y", "tx", "ty")])

    def force(q: np.ndarray) -> np.ndarray:
        x, y, tx, ty = q
        total = np.array([v["radial_load"], 0.0, 0.0, 0.0])
        for bearing, n in (("left", 8), ("right", 10)):
            a = v[f"station_{bearing}"]
            theta = 2 * np.pi * np.arange(n) / n
            delta = (x + a * tx) * np.cos(theta) + (y + a * ty) * np.sin(theta) \
                - v["radial_clearance"]
            q_i = v["contact_stiffness"] * np.maximum(delta, 0) ** 1.5
            fx, fy = -np.sum(q_i * np.cos(theta)), -np.sum(q_i * np.sin(theta))
            total += [fx, fy, a * fx, a * fy]
        return total / np.array([1.0, 1.0, 0.1, 0.1])

    assert np.max(np.abs(force(settled))) < 1e-9 * v["radial_load"]
    root = fsolve(force, settled * 1.05, xtol=1e-14)
    assert np.max(np.abs(force(root))) < 1e-9 * v["radial_load"]
    # x and the tilt in the load plane are set by the loaded balls; y and ty only by balls at
    # the edge of the loaded zone, which may leave a flat direction: compare the determinate
    # pair, and the residual of the whole balance above
    assert settled[[0, 2]] == pytest.approx(root[[0, 2]], rel=1e-6)
    assert abs(settled[2]) > 1e-7  # the bearings are unequal: the rotor does tilt


def test_mathieu_has_one_coordinate():
    """The 1-DOF model has no dummy coordinate: state x, vx; with ε = 0 it is a harmonic
    oscillator of ω² = δ/m, and RK4 follows cos(ωt) to its truncation error."""
    ds = simulate("mathieu", duration=20.0, transient=0.0, dt=1e-3, stiffness_amplitude=0.0,
                  stiffness_mean=4.0)
    assert list(ds.data_vars) == ["x", "vx"]
    exact = 1e-3 * np.cos(2.0 * ds.t.values)
    assert np.max(np.abs(ds.x.values - exact)) < 1e-12
