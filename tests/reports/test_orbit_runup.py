"""`plot --orbit` of a run-up is coloured by shaft speed, with a colour bar, not one
overplotted colour (issue 32, section 4)."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection

from analysis import simulate
from analysis.integrate.speed_profile import SpeedProfile
from analysis.reports.orbit_plots import orbit_figure


def _speed_bar(fig):
    return [ax for ax in fig.axes if ax.get_ylabel() == "shaft speed (rpm)"]


def test_a_run_up_orbit_is_coloured_by_speed():
    ds = simulate("vakharia2015", n_balls=8, speed_rpm=SpeedProfile.ramp(2000, 6000),
                  duration=0.1,
                  transient=0.0)
    fig = orbit_figure(ds)
    orbit_axes = [ax for ax in fig.axes if ax.get_xlabel().startswith("X (")]
    paths = [c for ax in orbit_axes for c in ax.collections if isinstance(c, LineCollection)]
    assert len(orbit_axes) == 1 and len(paths) == 1
    speeds = paths[0].get_array()
    assert abs(float(np.min(speeds)) - 2000) < 5 and abs(float(np.max(speeds)) - 6000) < 5
    assert np.all(np.diff(speeds) >= 0)  # the ramp, in time order
    assert len(_speed_bar(fig)) == 1
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].reshape(-1, 3)
    # viridis's two ends (2000 and 6000 rpm) both appear on the drawn figure
    for end in ((68, 1, 84), (253, 231, 37)):
        assert np.any(np.abs(rgb.astype(int) - end).sum(axis=1) < 40), end
    assert "2000…6000 rpm" in fig._suptitle.get_text()


def test_a_constant_speed_orbit_keeps_one_colour():
    ds = simulate("vakharia2015", n_balls=8, duration=0.05, transient=0.0)
    fig = orbit_figure(ds)
    assert not _speed_bar(fig)
    assert not [c for ax in fig.axes for c in ax.collections if isinstance(c, LineCollection)]
