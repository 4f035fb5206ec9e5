"""The brute-force diagram (``sweep --no-follow``) on the member kernels
(``bifurcation_diagram(device="cpu")``, ``diagram.ensemble_points``) against the value-by-
value diagram: vakharia2015, N_b = 10, 4000–6000 rpm. Where the shaft period is a whole
number of steps (4000, 5000, 6000 rpm at dt = 1e-5 s) the section points and amplitudes are
the same bits; elsewhere the step is the largest h <= dt dividing the period, and the points
move by the difference of the two RK4 solutions (measured: below 1e-5 of the largest
value of each variable)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError
from analysis.io import open_result
from analysis.sweeps import diagram
from analysis.sweeps.diagram import bifurcation_diagram
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.store import BLOCK, PointStore

SETTING = Setting("vakharia2015", 10, {}, transient=0.3, samples=20)
AXIS = Axis.parse("speed_rpm:4000:6000:5")  # 4000, 4500, 5000, 5500, 6000


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    folder = tmp_path_factory.mktemp("diagram")
    seen = []
    per_value = bifurcation_diagram(SETTING, AXIS, folder / "a.nc", follow=False)
    ensemble = bifurcation_diagram(SETTING, AXIS, folder / "b.nc", follow=False,
                                   device="cpu", progress=lambda d, t: seen.append((d, t)))
    return per_value, ensemble, seen, folder / "b.nc"


def test_section_points_are_the_value_by_value_points(both):
    a, b, seen, _ = both
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
    with pytest.raises(InputError, match=r"^device: ") as refused:  # the parameter named
        bifurcation_diagram(SETTING, AXIS, tmp_path / "c.nc", follow=True, device="cpu")
    assert refused.value.field == "device"
    assert not (tmp_path / "c.nc").exists()


def test_an_interrupted_diagram_resumes_block_by_block_to_the_same_file(both, tmp_path,
                                                                          monkeypatch):
    """Blocks of 2 values (``ENSEMBLE_BLOCK``): Ctrl-C after the first block is stored keeps
    one entry of 2 points; the rerun computes the 3 others, in blocks of 2 and 1, and writes
    the file of the uninterrupted run (blocks of 64)."""
    monkeypatch.setitem(diagram.ENSEMBLE_BLOCK, "cpu", 2)
    save_block = PointStore.save_block

    def stop_after_first(self, points):
        save_block(self, points)
        raise KeyboardInterrupt

    monkeypatch.setattr(PointStore, "save_block", stop_after_first)
    out = tmp_path / "r.nc"
    with pytest.raises(KeyboardInterrupt) as stopped:
        bifurcation_diagram(SETTING, AXIS, out, follow=False, device="cpu")
    parts = tmp_path / "r.nc.parts"
    assert [p.name for p in parts.glob("*.npz")] == [f"{BLOCK}up-00000.npz"]
    assert "2 of 5 points kept" in " ".join(stopped.value.__notes__)
    definition = json.loads((parts / "sweep.json").read_text())
    assert PointStore(out, definition).keys() == {"up-00000", "up-00001"}

    monkeypatch.setattr(PointStore, "save_block", save_block)
    ran, seen = [], []
    ensemble_points = diagram.ensemble_points
    monkeypatch.setattr(diagram, "ensemble_points", lambda setting, systems, device: (
        ran.append(len(systems)) or ensemble_points(setting, systems, device)))
    bifurcation_diagram(SETTING, AXIS, out, follow=False, device="cpu",
                        progress=lambda d, t: seen.append((d, t)))
    assert ran == [2, 1] and seen == [(4, 5), (5, 5)]
    assert not parts.exists()
    xr.testing.assert_identical(open_result(out), open_result(both[3]))


def test_a_failed_value_is_stored_in_its_block(tmp_path, monkeypatch):
    """Duffing with a softening spring (cubic_stiffness = -1) blows up (the blow-up case of
    the catalogue); its record, without section points, is stored in one block with the two
    bounded values, and the diagram says so as the value-by-value one does."""
    blocks = []
    save_block = PointStore.save_block
    monkeypatch.setattr(PointStore, "save_block",
                        lambda self, points: blocks.append(len(points)) or save_block(self,
                                                                                      points))
    setting = Setting("duffing", None, {"damping": 0.2}, transient=20.0, samples=40, dt=0.01,
                      lyapunov=False)
    axis = Axis.linear("cubic_stiffness", -1, 1, 3)
    ds = bifurcation_diagram(setting, axis, tmp_path / "d.nc", follow=False, device="cpu")
    assert blocks == [3]
    status = list(ds.status.values[0])
    assert status[0].startswith("failed: ") and status[1:] == ["", ""]
    assert np.all(np.isnan(ds.x.values[0, 0])) and np.isfinite(ds.x.values[0, 1:]).all()
    assert np.isnan(ds.amplitude_x.values[0, 0]) and np.isfinite(ds.amplitude_x.values[0, 1:]).all()
