"""The one-pass chart point (``analysis.sweeps.points``) against the two-pass one it replaces
(``chart.chart_point_two_pass``: ``simulate`` keeping every state, then ``lyapunov``) and
against ``lyapunov`` run on the same setting.

The one-pass run makes the same RK4 steps at the same times k·dt as ``simulate``, so the
amplitudes and section points must be the two-pass run's bit for bit, and the class the
same; λ1 comes from another window and start of the tangent, so it must agree with
``lyapunov``'s estimate within the two 95 % intervals.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import SimulationError
from analysis.model import as_system
from analysis.signal.poincare import poincare_section
from analysis.stability.classify import default_section
from analysis.stability.lyapunov import lyapunov
from analysis.sweeps.chart import chart_point_two_pass, stability_chart
from analysis.sweeps.grid import Axis, Setting, record
from analysis.sweeps.points import chart_point, chart_points, one_pass

CALM = {"radial_load": 50.0}
"""Radial load 50 N: a periodic orbit for the balanced rotor, a two-frequency torus with
unbalance (``tests/stability/test_classify.py``)."""

BLOW_UP = {"radial_clearance": 1e-9, "unbalance_force": 1e5}
"""A 1 nm clearance (blow-up limit 1 µm) and a 100 kN unbalance: out of bounds in one step."""

CASES = [  # (model, N_b, values, nature)
    ("balanced-rotor", 8, {**CALM, "speed_rpm": 5000.0}, "periodic-1"),
    ("balanced-rotor", 8, {**CALM, "speed_rpm": 3000.0}, "periodic-1"),
    ("vakharia2015", 8, {**CALM, "speed_rpm": 5000.0}, "quasi-periodic"),
    ("vakharia2015", 8, {**CALM, "speed_rpm": 3000.0}, "quasi-periodic"),
]


def _setting(model: str, transient: float = 0.5, samples: int = 40) -> Setting:
    return Setting(model, None, {}, transient=transient, samples=samples, lyapunov=True)


def _system(setting: Setting, n_balls: int, values: dict[str, float]):
    return as_system(setting.model, n_balls, None, **values)


def _one_pass(setting: Setting, n_balls: int, values: dict[str, float]):
    system = _system(setting, n_balls, values)
    duration = setting.seconds(system)
    return one_pass(system, duration, setting.transient, setting.step(), None), duration


@pytest.mark.parametrize(("model", "n_balls", "values", "nature"), CASES)
def test_one_pass_equals_two_pass_on_non_chaotic_points(model, n_balls, values, nature):
    setting = _setting(model)
    one = chart_point(setting, _system(setting, n_balls, values))
    two = chart_point_two_pass(setting, _system(setting, n_balls, values))
    assert one["nature"] == two["nature"] == nature
    assert one["period"] == two["period"]
    assert one["nature_code"] == two["nature_code"]
    amplitudes = [k for k in two if k.startswith("amplitude_")]
    assert amplitudes and sorted(amplitudes) == sorted(k for k in one if
                                                       k.startswith("amplitude_"))
    for k in amplitudes:  # the same RK4 steps at the same times: bit for bit
        assert one[k] == two[k], k
    np.testing.assert_equal(one["graph_ratio"], two["graph_ratio"])

    # section points: those of the full record of the two-pass run
    out, duration = _one_pass(setting, n_balls, values)
    run = record(setting, _system(setting, n_balls, values))
    want = poincare_section(run, default_section(run))
    got = out.points
    np.testing.assert_array_equal(got.k.values, want.k.values)
    np.testing.assert_array_equal(got.t.values, want.t.values)
    for v in run.attrs["state_names"].split():
        scale = np.abs(want[v].values).max()
        np.testing.assert_allclose(got[v].values, want[v].values, rtol=0, atol=1e-12 * scale)

    # λ1: lyapunov's own estimate on the same setting (averaged over the record)
    ref = lyapunov(model, n_balls, duration=duration - setting.transient,
                   transient=setting.transient, n_exponents=1, **values)
    lam, ci = float(ref.exponents[0]), float(ref.ci95[0])
    assert abs(one["lyapunov"] - lam) <= one["ci95"] + ci
    assert one["lyapunov"] == out.lyapunov and one["ci95"] == out.ci95


def test_paper_case_is_chaotic_both_ways():
    """vakharia2015, N_b = 6, the paper's parameters: chaotic
    (``tests/stability/test_lyapunov.py``)."""
    setting = _setting("vakharia2015", transient=1.0, samples=100)
    one = chart_point(setting, _system(setting, 6, {}))
    two = chart_point_two_pass(setting, _system(setting, 6, {}))
    assert one["nature"] == two["nature"] == "chaotic"
    assert one["lyapunov"] - one["ci95"] > 0
    for k in ("amplitude_x", "amplitude_y"):
        assert one[k] == two[k]


def test_a_point_that_blows_up_raises_simulation_error_like_the_two_pass_path():
    """From rest at the bearing centre (the default start, 1.41 µm off centre, lies beyond
    this clearance's blow-up limit and is refused before any step: ``StartLimits``)."""
    setting = _setting("vakharia2015", transient=0.05, samples=5)
    system = _system(setting, 8, BLOW_UP)
    system = system.replace(state=np.zeros_like(system.state))
    with pytest.raises(SimulationError, match="blew up"):
        chart_point_two_pass(setting, system)
    with pytest.raises(SimulationError, match="blew up"):
        chart_point(setting, system)


def test_chart_without_lyapunov_runs_the_states_only():
    """``lyapunov=False``: no tangent; λ1 only when the section cannot decide."""
    setting = Setting("balanced-rotor", 8, CALM, transient=0.5, samples=40, lyapunov=False)
    one = chart_point(setting, _system(setting, 8, {**CALM, "speed_rpm": 5000.0}))
    two = chart_point_two_pass(setting, _system(setting, 8, {**CALM, "speed_rpm": 5000.0}))
    assert one["nature"] == two["nature"] == "periodic-1"
    assert np.isnan(one["lyapunov"]) and np.isnan(two["lyapunov"])
    assert one["amplitude_x"] == two["amplitude_x"]


def test_chart_uses_the_kernel_points(tmp_path):
    setting = Setting("balanced-rotor", 8, {}, transient=0.5, samples=40)
    chart = stability_chart(setting, Axis.parse("speed_rpm:3000:5000:2"),
                            Axis.parse("radial_load:50:50:1"), tmp_path / "c.nc")
    for ix, speed in enumerate((3000.0, 5000.0)):
        want = chart_points(setting, [_system(setting, 8, {"speed_rpm": speed,
                                                           "radial_load": 50.0})])[0]
        assert float(chart.lyapunov.values[0, ix]) == want["lyapunov"]
