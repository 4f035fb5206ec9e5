"""A chart's groups stored as blocks (``PointStore.save_block``): one entry per group, read
back point by point with the values stored, resumable with the same chart as an
uninterrupted run."""

from __future__ import annotations

import re

import numpy as np
import pytest

from analysis.sweeps import chart
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.store import BLOCK, PointStore

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
X, Y = Axis.parse("speed_rpm:2000:6100:3"), Axis.parse("n_balls:7:8")


def test_a_block_reads_back_as_its_points(tmp_path):
    store = PointStore(tmp_path / "s.nc", {"kind": "test"}, lock=True)
    points = [("0000-0000", {"nature": "periodic-1", "period": 1, "lyapunov": -3.5,
                             "codes": np.array([1, -1])}),
              ("0000-0001", {"nature": "failed: blew up", "period": 0, "lyapunov": np.nan,
                             "codes": np.array([-1, -1])})]
    store.save_block(points)
    store.save("0001-0000", {"nature": "chaotic", "period": 0, "lyapunov": 12.0,
                             "codes": np.array([3, 3])})
    assert store.done() == {BLOCK + "0000-0000", "0001-0000"}
    assert store.point_count() == 3
    got = store.points()
    assert sorted(got) == ["0000-0000", "0000-0001", "0001-0000"]
    for key, values in points:
        for name, value in values.items():
            np.testing.assert_array_equal(got[key][name], value)
    assert str(got["0000-0001"]["nature"]) == "failed: blew up"
    with pytest.raises(ValueError, match="same fields"):
        store.save_block([points[0], ("0002-0000", {"nature": "chaotic"})])
    store.remove()


def test_an_interrupted_chart_of_blocks_resumes_to_the_uninterrupted_chart(tmp_path,
                                                                            monkeypatch):
    monkeypatch.setitem(chart.GROUP_POINTS, "cpu", 2)
    reference = chart.stability_chart(CHART, X, Y, tmp_path / "ref.nc")

    class Stop(Exception):
        pass

    def stop_after_two(done: int, total: int) -> None:
        if done >= 2:
            raise Stop

    with pytest.raises(Stop) as info:
        chart.stability_chart(CHART, X, Y, tmp_path / "c.nc", progress=stop_after_two)
    note = re.match(r"(\d+) of 6 points kept", info.value.__notes__[0])
    assert note and int(note.group(1)) >= 2, info.value.__notes__
    parts = sorted((tmp_path / "c.nc.parts").glob("*.npz"))  # the thread may have gone on
    assert parts and all(p.stem.startswith(BLOCK) for p in parts)
    sizes = [len(np.load(p)["keys"]) for p in parts]
    assert max(sizes) == 2 and sum(sizes) >= int(note.group(1))  # blocks of two points
    resumed = chart.stability_chart(CHART, X, Y, tmp_path / "c.nc")
    for name in reference.data_vars:
        np.testing.assert_array_equal(resumed[name].values, reference[name].values, name)
    assert not (tmp_path / "c.nc.parts").exists()
