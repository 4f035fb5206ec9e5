"""The brute-force diagram (``sweep --no-follow``) on the member kernels
(``bifurcation_diagram(device="cpu")``, ``diagram.ensemble_points``) against the value-by-
value diagram: vakharia2015, N_b = 10, 4000–6000 rpm. Where the shaft period is a whole
number of steps (4000, 5000, 6000 rpm at dt = 1e-5 s) the section points and amplitudes are
the same bits; elsewhere the step is the largest h <= dt dividing the period, and the points
move by the difference of the two RK4 solutions (measured: below 1e-5 of the largest
value of each variable)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting

SETTING = Setting("vakharia2015", 10, {}, transient=0.3, samples=20)
AXIS = Axis.parse("speed_rpm:4000:6000:5")  # 4000, 4500, 5000, 5500, 6000


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diagram")
    seen = []
    per_value = bifurcation_diagram(SETTING, AXIS, folder / "a.nc", follow=False)
    ensemble = bifurcation_diagram(SETTING, AXIS, folder / "b.nc", follow=False,
                                   device="cpu", progress=lambda d, t: seen.append((d, t)))
    return per_value, ensemble, seen


def test_section_points_are_the_value_by_value_points(both):
    a, b, seen = both
    assert seen and seen[-1] == (5, 5)
    assert list(b.status.values[0]) == [""] * 5
    whole = [0, 2, 4]  # periods of whole steps: the same bits
    for v in ("x", "y", "vx", "vy"):
        assert np.array_equal(a[v].values[0, whole], b[v].values[0, whole]), v
        scale = np.abs(a[v].values).max()
        assert np.abs(a[v].values - b[v].values).max() <= 1e-5 * scale, v
    for v in ("amplitude_x", "amplitude_y"):
        assert np.array_equal(a[v].values[0, whole], b[v].values[0, whole])
        np.testing.assert_allclose(b[v].values, a[v].values, rtol=1e-4)
    assert np.all(np.isnan(b["amplitude1x_x"].values))


def test_a_followed_diagram_refuses_a_device(tmp_path):
    with pytest.raises(InputError, match="--device"):
        bifurcation_diagram(SETTING, AXIS, tmp_path / "c.nc", follow=True, device="cpu")
    assert not (tmp_path / "c.nc").exists()
