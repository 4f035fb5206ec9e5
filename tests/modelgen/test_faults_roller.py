"""The roller bearing's line-contact law against Palmgren's formula as printed (mm, N), and
its static equilibrium under a radial load against the sum of that law over the rollers."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize

from analysis.integrate.simulate import simulate
from analysis.model import load_model
from tests.conftest import run_cli


def palmgren_load(approach_m: float, length_m: float) -> float:
    """Q (N) of a roller whose two race contacts share the approach (m): Palmgren,
    δ_c = 3.84e-5 Q^0.9 / l^0.8 per contact in mm, δ = 2 δ_c."""
    per_contact_mm = max(approach_m, 0.0) * 1e3 / 2
    return (per_contact_mm * (length_m * 1e3) ** 0.8 / 3.84e-5) ** (1 / 0.9)


def test_the_generated_roller_load_is_palmgrens_law():
    model = load_model("nu205-roller")
    p = model.parameter_vector(model.defaults)
    gap = model.defaults["radial_clearance"]
    length = model.defaults["roller_length"]
    for approach in (0.0, 1e-7, 1e-6, 5e-6, 2e-5):
        z = [gap + approach, 0.0, 0.0, 0.0]
        q = float(model.module.ball_load_bearing(1.0, 0.0, 1, 13, z, 0.0, p))
        assert q == pytest.approx(palmgren_load(approach, length), rel=1e-12, abs=1e-12)
    z = [gap - 1e-6, 0.0, 0.0, 0.0]  # open
    assert float(model.module.ball_load_bearing(1.0, 0.0, 1, 13, z, 0.0, p)) == 0.0
    # the exponent: doubling the approach multiplies the load by 2^(10/9)
    q1, q2 = (float(model.module.ball_load_bearing(1.0, 0.0, 1, 13, [gap + a, 0, 0, 0],
                                                   0.0, p)) for a in (3e-6, 6e-6))
    assert q2 / q1 == pytest.approx(2 ** (10 / 9), rel=1e-12)


def test_static_equilibrium_under_the_radial_load():
    """At rest (0 rpm, no unbalance) the damped rotor settles where the rollers' loads by
    Palmgren's law, summed over the roller angles, carry the radial load."""
    model = load_model("nu205-roller")
    d = model.defaults
    n, gap, length, load = 13, d["radial_clearance"], d["roller_length"], d["radial_load"]
    angles = 2 * math.pi * np.arange(n) / n

    def residual(x: float) -> float:
        return sum(palmgren_load(x * math.cos(a) - gap, length) * math.cos(a)
                   for a in angles) - load

    expected = scipy.optimize.brentq(residual, gap, gap + 1e-4, xtol=1e-16)
    ds = simulate("nu205-roller", duration=0.15, transient=0.1, speed_rpm=0.0,
                  unbalance_force=0.0)
    x = ds["x"].values
    assert np.ptp(x) < 1e-6 * expected  # at rest
    assert x[-1] == pytest.approx(expected, rel=1e-6)
    assert abs(ds["y"].values[-1]) < 1e-12


def test_the_roller_spec_runs_with_another_geometry(tmp_path):
    out = tmp_path / "r.nc"
    done = run_cli("simulate", "nu205-roller", "-o", str(out), "--duration", "0.25",
                   "--transient", "0.05", "--n-balls", "12", "--set", "ball_diameter=7e-3",
                   "--set", "pitch_diameter=39e-3", "--set", "inner_race_diameter=31e-3",
                   "--set", "outer_race_diameter=46e-3", "--set", "roller_length=8e-3")
    assert done.returncode == 0, done.stderr
    done = run_cli("spectrum", str(out), "--faults", "--var", "x", "--max-peaks", "3")
    assert done.returncode == 0, done.stderr
    g = 7e-3 / 39e-3
    bpfo = 12 * 50.0 / 2 * (1 - g)
    assert f"BPFO = {bpfo:.2f} Hz" in run_cli("spectrum", str(out), "--envelope", "--var",
                                              "x").stdout
