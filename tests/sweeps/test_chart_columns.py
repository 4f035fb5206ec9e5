"""The chart's rows as columns end to end (issue 39): ``points.chart_grid_points(…,
columns=True)`` gives the arrays ``PointStore.save_block`` would stack from its rows, a
group whose members start their record at different sections equals its points classified
alone, ``PointStore.save_columns`` / ``columns`` store and read the entries of
``save_block`` / ``points``, ``classes._phases`` is ``np.mod``'s bits, and the chart's
frozen heap is given back however the chart ends."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from analysis.errors import SimulationError
from analysis.sweeps import chart, classes
from analysis.sweeps import points as chart_points
from analysis.sweeps.grid import Setting
from analysis.sweeps.store import BLOCK, PointStore, stacked

CHART = Setting("vakharia2015", None, {}, transient=0.3, samples=40, lyapunov=True)
DUFFING = Setting("duffing", None, {"linear_stiffness": 1.0, "damping": 0.2},
                  transient=5.0, samples=30, lyapunov=True, dt=0.01)
"""Softening Duffing escapes its well at the larger forcing (a failed point)."""
SPEEDS = ("speed_rpm", "n_balls")


def _same_columns(a: dict, b: dict) -> bool:
    return list(a) == list(b) and all(
        a[f].dtype == b[f].dtype and a[f].shape == b[f].shape
        and np.array_equal(a[f], b[f], equal_nan=a[f].dtype.kind == "f") for f in a)


def test_columns_are_the_rows_stacked():
    """Speeds whose records start at different sections (several skips and counts in one
    group): every column is the stack of the rows (dtype, shape and bits), and each point
    classified alone (a group of one: no copy by skip) gives the same row."""
    values = [(v, 8.0) for v in np.linspace(1000.0, 10000.0, 40).tolist()]
    batch = chart_points._grid_batch(CHART, SPEEDS, values)
    assert len(np.unique(batch.skip)) > 1 and len(np.unique(batch.count)) > 1
    columns, failed = chart_points.chart_grid_points(CHART, SPEEDS, values, columns=True)
    rows = chart_points.chart_grid_points(CHART, SPEEDS, values)
    assert not failed and _same_columns(columns, stacked(rows))
    for k in (0, 7, 23, 39):
        alone = chart_points.chart_grid_points(CHART, SPEEDS, [values[k]])[0]
        assert alone.keys() == rows[k].keys()
        assert all(alone[f] == rows[k][f] or (alone[f] != alone[f] and rows[k][f] != rows[k][f])
                   for f in alone), k


def test_a_failed_point_in_columns_is_the_rows_block():
    """A point that blows up: ``chart_grid_points`` names it by index, and the chart's
    group task stores the block the rows (``_failed_point`` for it) would have made."""
    names, values = ("cubic_stiffness", "forcing_amplitude"), [(1.0, 0.3), (-1.0, 2.0),
                                                              (0.5, 0.3)]
    columns, failed = chart_points.chart_grid_points(DUFFING, names, values, columns=True)
    assert list(failed) == [1] and isinstance(failed[1], SimulationError)
    rows = chart_points.chart_grid_points(DUFFING, names, values)
    for j in (0, 2):  # the points that ran: their rows
        np.testing.assert_equal({f: c[j] for f, c in columns.items()}, rows[j])  # NaN = NaN
    want = stacked([chart._failed_point(DUFFING, row) if isinstance(row, SimulationError)
                    else row for row in rows])
    group = [(DUFFING, names[0], a, names[1], b, f"0000-{k:04d}", None)
             for k, (a, b) in enumerate(values)]
    keys, got = chart._chart_group_task(group)
    assert keys == ["0000-0000", "0000-0001", "0000-0002"] and _same_columns(got, want)
    assert str(got["nature"][1]).startswith("failed")


def test_save_columns_writes_save_blocks_entry_and_columns_reads_points(tmp_path):
    """The same entry either way; ``columns`` gives every stored point (entries of one
    point and blocks, a key stored twice its last row) as ``points`` does."""
    rows = [{"nature": "periodic-1", "period": 1, "lyapunov": -3.5,
             "codes": np.array([1, -1])},
            {"nature": "failed: blew up", "period": 0, "lyapunov": np.nan,
             "codes": np.array([-1, -1])}]
    one = PointStore(tmp_path / "a.nc", {"kind": "test"}, lock=True)
    two = PointStore(tmp_path / "b.nc", {"kind": "test"}, lock=True)
    one.save_block([("0000-0000", rows[0]), ("0000-0001", rows[1])])
    two.save_columns(["0000-0000", "0000-0001"], stacked(rows))
    a, b = (s.load(BLOCK + "0000-0000") for s in (one, two))
    assert _same_columns(a, b)
    with pytest.raises(ValueError, match="one value per key"):
        two.save_columns(["0000-0002"], stacked(rows))
    two.save("0000-0001", {"nature": "chaotic", "period": 0, "lyapunov": 12.0,
                           "codes": np.array([3, 3])})  # sorted before the block: replaced
    two.save("0001-0000", {"nature": "chaotic", "period": 0, "lyapunov": 11.0,
                           "codes": np.array([2, 2])})
    keys, columns = two.columns()
    points = two.points()
    at = dict(zip(keys.tolist(), range(len(keys)), strict=True))
    assert sorted(at) == sorted(points) == ["0000-0000", "0000-0001", "0001-0000"]
    for key, values in points.items():
        for name, value in values.items():
            np.testing.assert_array_equal(columns[name][at[key]], value)
    assert str(columns["nature"][at["0000-0001"]]) == "failed: blew up"
    empty = PointStore(tmp_path / "c.nc", {"kind": "test"}, lock=True)
    assert len(empty.columns()[0]) == 0 and empty.columns()[1] == {}
    for store in (one, two, empty):
        store.remove()


def test_phases_are_np_mods_bits():
    """t·f − ⌊t·f⌋ against ``np.mod(t·f, 1)``: scales 1e-20-1e7, negatives, whole numbers,
    −0, values past 2**53 and the non-finite ones, bit for bit (the sign of zero too)."""
    rng = np.random.default_rng(3)
    times = np.concatenate([
        rng.random((40, 64)) * 10.0 ** rng.integers(-20, 8, (40, 1)),
        -rng.random((20, 64)) * 10.0 ** rng.integers(-20, 8, (20, 1)),
        np.round(rng.normal(size=(4, 64)) * 100), np.full((1, 64), -0.0),
        rng.normal(size=(2, 64)) * 1e17])
    times[0, :3] = [np.inf, -np.inf, np.nan]
    hz = np.concatenate([rng.uniform(0.0, 300.0, len(times) - 3), [1.0, 1.0, 0.0]])
    with np.errstate(invalid="ignore"):
        got, want = classes._phases(times, hz), np.mod(times * hz[:, None], 1.0)
    assert np.array_equal(np.isnan(got), np.isnan(want))
    finite = ~np.isnan(want)
    assert np.array_equal(got.view(np.int64)[finite], want.view(np.int64)[finite])


def test_the_frozen_heap_is_given_back():
    """``_young_heap`` freezes only a heap nobody froze, with the collector on, and
    unfreezes it on leaving, by an exception too."""
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    with chart._young_heap():
        assert gc.get_freeze_count() > 0
    assert gc.get_freeze_count() == 0
    with pytest.raises(KeyError), chart._young_heap():
        raise KeyError("stop")
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    gc.disable()
    try:
        with chart._young_heap():
            assert gc.get_freeze_count() == 0
    finally:
        gc.enable()


@pytest.mark.parametrize("n", [4, 8])
def test_repeat_periods_equal_classify(n):
    """Members repeating with periods 1-17, with noise below, near and above the limit, a
    NaN, constant rows, and records of 4-201 sections: ``repeat_periods`` (its probes by
    plane for n < 8, by point otherwise) gives ``classify.repeat_period``'s period."""
    from analysis.stability.classify import repeat_period

    rng = np.random.default_rng(n)
    m, count = 1020, 201
    points = rng.normal(size=(m, count, n))
    for period in range(1, 18):
        rows = slice((period - 1) * 60, period * 60)
        base = np.tile(rng.normal(size=(60, period, n)), (1, count // period + 1, 1))[:, :count]
        noise = rng.choice([0.0, 1e-4, 5e-4, 2e-3], size=(60, 1, 1))
        points[rows] = base + rng.normal(size=(60, count, n)) * noise
    points[5, 30, 1] = np.nan
    points[1000:] = points[1000:, :1]
    size = np.nan_to_num(np.ptp(points[:, :, 0], axis=1), nan=1.0) + 0.5
    for sections in (4, 9, 12, 20, 40, count):
        part = points[:, :sections]
        want = [repeat_period(part[i], size[i], 1e-3, 16) or 0 for i in range(m)]
        assert classes.repeat_periods(part, size).tolist() == want, sections
    assert len(set(want)) > 12  # periods found, and members that do not repeat
