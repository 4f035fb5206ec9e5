"""The classifier on known motions: periodic-1, periodic-2, two-frequency torus, chaos."""

from __future__ import annotations

import math

from analysis.integrate.simulate import simulate
from analysis.stability.classify import classify

RPM = 30 / math.pi


def test_known_periodic_orbit_is_periodic_1():
    ds = simulate("balanced-rotor", 8, duration=1.2, transient=1.0, radial_load=50.0)
    c = classify(ds)
    assert c.section == "vc" and c.nature == "periodic-1" and c.period == 1


def test_known_period_2_orbit_is_periodic_2():
    w = 1.3
    period = 2 * math.pi / w
    ds = simulate("duffing", duration=400 * period, transient=360 * period, dt=period / 100,
                  speed_rpm=w * RPM, linear_stiffness=1.0, cubic_stiffness=1.0,
                  damping=0.2, forcing_amplitude=20.0)
    assert classify(ds).nature == "periodic-2"


def test_two_frequency_torus_is_quasi_periodic():
    ds = simulate("vakharia2015", 8, duration=2.0, transient=1.0, radial_load=50.0)
    c = classify(ds)
    assert c.section == "shaft" and c.nature == "quasi-periodic"
    assert "two-frequency torus" in c.detail and c.graph_ratio < 0.2
    assert c.largest_exponent is None  # the section decided alone


def test_ueda_attractor_is_chaotic():
    ds = simulate("duffing")  # Ueda's parameters, 300 s after a 300 s transient
    c = classify(ds, lyapunov_duration=1500.0)
    assert c.nature == "chaotic" and c.largest_exponent - c.ci95 > 0
