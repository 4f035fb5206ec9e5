"""1X phasors (amplitude and phase lag against the shaft angle) on an analytic signal and on a
simulated linear oscillator swept through its resonance, whose response to a force
F cos(ωt) is known in closed form: amplitude F/|k − mω² + icω|, lag atan2(cω, k − mω²),
90° at the natural frequency. The sweep's 1X record and its Bode and polar figures."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError
from analysis.signal.phasor import phase_lag, phasor_record, synchronous_phasor

X_HZ = 83.3333


def _signal(values, t, **attrs):
    return xr.Dataset({"x": ("t", values, {"units": "m"}), "vx": ("t", np.gradient(values, t))},
                      coords={"t": t}, attrs={"shaft_hz": X_HZ, "state_names": "x vx", **attrs})


def test_an_analytic_signal_gives_its_amplitude_and_lag_beside_other_lines():
    t = np.arange(0.0, 0.6, 2e-5)  # 50 revolutions, not a whole number of VC periods
    a, lag = 2.5e-6, math.radians(137.0)
    phi = 2 * math.pi * X_HZ * t
    values = (4e-6 + a * np.cos(phi - lag) + 1.5e-6 * np.cos(2 * math.pi * 199.34 * t + 0.4)
              + 0.7e-6 * np.cos(2 * phi + 1.0))
    s = synchronous_phasor(_signal(values, t), "x")
    assert abs(s) == pytest.approx(a, rel=1e-4)
    assert math.degrees(phase_lag(s)) == pytest.approx(137.0, abs=0.01)
    s2 = synchronous_phasor(_signal(values, t), "x", order=2)
    assert abs(s2) == pytest.approx(0.7e-6, rel=1e-3)
    assert math.degrees(phase_lag(s2)) == pytest.approx(-math.degrees(1.0) % 360, abs=0.05)


def test_a_carried_shaft_angle_is_the_reference():
    """The hook for runs whose speed follows a profile: the angle variable, not ω·t."""
    t = np.arange(0.0, 1.0, 2e-5)
    angle = 2 * math.pi * (50.0 * t + 20.0 * t**2)  # 50 Hz rising to 90 Hz
    ds = _signal(3e-6 * np.cos(angle - 0.5), t).assign(shaft_angle=("t", angle))
    s = synchronous_phasor(ds, "x")
    assert abs(s) == pytest.approx(3e-6, rel=1e-4)
    assert phase_lag(s) == pytest.approx(0.5, abs=1e-4)


def test_no_shaft_means_no_phasor():
    t = np.arange(0.0, 1.0, 1e-3)
    ds = _signal(np.cos(t), t, shaft_hz=0.0)
    with pytest.raises(InputError, match="shaft_hz"):
        synchronous_phasor(ds, "x")
    assert all(math.isnan(v) for v in phasor_record(ds, ("x",)).values())


M, K, ZETA, F = 1.0, (2 * math.pi) ** 2, 0.05, 1.0  # natural frequency 1 Hz = 60 rpm
C = 2 * ZETA * math.sqrt(K * M)


@pytest.fixture(scope="module")
def linear_sweep(tmp_path_factory):
    """The duffing model without its cubic term: M x'' + C x' + K x = F cos(ωt), swept
    through 60 rpm."""
    from analysis.sweeps.diagram import bifurcation_diagram
    from analysis.sweeps.grid import Axis, Setting

    setting = Setting("duffing", None, {"linear_stiffness": K, "cubic_stiffness": 0.0,
                                        "damping": C, "forcing_amplitude": F,
                                        "rotor_mass": M}, transient=40.0, samples=20,
                      dt=0.005)
    path = tmp_path_factory.mktemp("bode") / "linear.nc"
    ds = bifurcation_diagram(setting, Axis.linear("speed_rpm", 30, 90, 13), path,
                             direction="up", follow=False)
    return ds, path


def test_the_linear_oscillator_lags_as_its_transfer_function(linear_sweep):
    ds, _ = linear_sweep
    w = 2 * math.pi * ds.speed_rpm.values / 60
    h = F / (K - M * w**2 + 1j * C * w)
    lag = np.degrees(ds.phase1x_x.isel(direction=0).values)
    assert np.allclose(ds.amplitude1x_x.isel(direction=0).values, np.abs(h), rtol=1e-4)
    assert np.allclose(lag, np.degrees(np.arctan2(C * w, K - M * w**2)), atol=0.01)
    at_resonance = int(np.argmin(np.abs(ds.speed_rpm.values - 60.0)))
    assert lag[at_resonance] == pytest.approx(90.0, abs=0.01)
    assert np.all(lag[:at_resonance] < 90) and np.all(lag[at_resonance + 1:] > 90)
    assert ds.phase1x_x.attrs["units"] == "rad" and ds.amplitude1x_x.attrs["units"] == "m"


def test_bode_and_polar_figures_draw_the_record(linear_sweep):
    from analysis.reports.bode_plots import bode_figure, polar_figure

    ds, _ = linear_sweep
    fig = bode_figure(ds)
    top, bottom = fig.axes
    (amp_line,), (lag_line,) = top.lines, bottom.lines  # y stays at rest: not drawn
    assert np.allclose(lag_line.get_ydata(), np.degrees(ds.phase1x_x.values[0]))
    assert np.allclose(amp_line.get_ydata(), ds.amplitude1x_x.values[0])  # 0.25 m: metres
    assert "(m)" in top.get_ylabel() and "degrees" in bottom.get_ylabel()
    polar = polar_figure(ds)
    line = polar.axes[0].lines[0]
    assert np.allclose(line.get_xdata(), ds.phase1x_x.values[0])


def test_a_plain_run_or_an_old_diagram_is_refused(linear_sweep, tmp_path):
    from analysis.reports.bode_plots import bode_figure

    ds, _ = linear_sweep
    with pytest.raises(InputError, match="no 1X amplitude"):
        bode_figure(ds.drop_vars(["amplitude1x_x", "phase1x_x", "amplitude1x_y",
                                  "phase1x_y"]))
    with pytest.raises(InputError, match="not a sweep's diagram"):
        bode_figure(ds.assign_attrs(kind="chart"))
    with pytest.raises(InputError, match="no 1X record of 'vx'"):
        bode_figure(ds, ["vx"])


def test_the_plot_command_draws_bode_and_polar(linear_sweep, tmp_path, cli):
    _, path = linear_sweep
    for option in ("--bode", "--polar"):
        out = tmp_path / f"{option[2:]}.png"
        result = cli("plot", str(path), option, "-o", str(out))
        assert result.returncode == 0, result.stderr
        assert out.stat().st_size > 0
    refused = cli("plot", str(path), "--orbit", "-o", str(tmp_path / "orbit.png"))
    assert refused.returncode == 2 and "needs a run" in refused.stderr
    assert refused.stderr.strip().count("\n") == 0 and not (tmp_path / "orbit.png").exists()
