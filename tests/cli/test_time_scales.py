"""Stability commands on the model's own time scales: the spec's step and durations by
default (Duffing: dt = 0.01 s, not the bearing models' 1e-5 s), and a clear error for a
VC period of a model without bearings."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.model import System, load_model
from analysis.stability.periodic import default_settle, shoot

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
SETS = [arg for name, value in DUFFING.items() for arg in ("--set", f"{name}={value}")]


def test_duffing_spec_has_its_own_step():
    assert load_model("duffing").simulation_defaults["dt"] == 0.01


def test_floquet_duffing_runs_on_the_spec_step(cli):
    """One shaft period (2π s at 1 rad/s) in ceil(2π / 0.01) = 629 steps of ≈ 0.01 s."""
    res = cli("floquet", "duffing", "--period", "shaft", *SETS, "--json")
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert out["n_steps"] == math.ceil(2 * math.pi / 0.01) == 629
    assert 0.0099 < out["period_s"] / out["n_steps"] <= 0.01  # the spec's dt, fitted to T
    assert out["converged"] and out["stability"] == "stable"


def test_floquet_vc_without_bearings_is_one_clear_error(cli):
    res = cli("floquet", "duffing", "--period", "vc")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "no bearings" in lines[0] and "ZeroDivision" not in res.stderr


@pytest.mark.parametrize("period", ["vc", "vc:2", "ratio:3/2"])
def test_shoot_vc_without_bearings_raises_input_error(period):
    with pytest.raises(InputError, match="has no bearings"):
        shoot("duffing", None, period, **DUFFING)


def test_shoot_defaults_to_the_spec_step_and_time_scales():
    orbit = shoot("duffing", None, "shaft", **DUFFING)
    assert orbit.converged and orbit.n_steps == 629
    system = System.make(load_model("duffing"), None, None, **DUFFING)
    from analysis.integrate.flow import Period

    assert default_settle(system, Period.parse("shaft")) == 300.0  # the spec's transient
    mathieu = System.make(load_model("mathieu"), None, None)
    # no transient in the Mathieu spec: at least 20 forcing periods
    assert default_settle(mathieu, Period.parse("param:forcing_period")) == pytest.approx(
        20 * mathieu.parameters["forcing_period"])
    # an explicit dt still rules: 2π / 0.02 -> 315 steps
    assert shoot("duffing", None, "shaft", np.array(orbit.z0), 0.0, dt=0.02,
                 **DUFFING).n_steps == 315


def test_continuation_and_lyapunov_default_to_the_spec_step():
    from analysis.stability.continuation import continue_orbits
    from analysis.stability.lyapunov import lyapunov

    rpm = 30 / math.pi
    branch = continue_orbits("duffing", param="speed_rpm", start=1.0 * rpm, stop=1.05 * rpm,
                             period="shaft", max_points=3, settle=100.0, **DUFFING)
    assert branch.attrs["steps_per_period"] == 629  # the longer period, at 1 rad/s
    res = lyapunov("duffing", duration=20.0, transient=0.0, **DUFFING)
    assert res.attrs["dt"] == 0.01
