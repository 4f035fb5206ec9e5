"""Figures that were crowded (issue 41): a run-up's orbit under hundreds of marks, the
stiffness of two bearings sampled 3 times per ball pitch, the waterfall's labels of close
lines printed over each other."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.reports.orbit_plots import MAX_RUN_UP_MARKS, mark_step
from analysis.reports.waterfall_plots import label_shifts
from analysis.stability.statics import ball_pitches, cage_pitch, coefficients


def test_a_run_ups_marks_are_thinned_and_a_constant_speeds_are_not():
    assert mark_step(367, run_up=True) == 10
    assert math.ceil(367 / mark_step(367, run_up=True)) <= MAX_RUN_UP_MARKS
    assert mark_step(367, run_up=False) == 1
    assert mark_step(MAX_RUN_UP_MARKS, run_up=True) == 1


@pytest.mark.parametrize("positions", [[100.0, 103.0, 104.0, 300.0], [0.0, 1.0, 2.0],
                                       [395.0, 398.0, 400.0], [10.0, 50.0]])
def test_waterfall_labels_are_moved_apart_as_little_as_needed(positions):
    gap, width = 9.0, 400.0
    shifts = label_shifts(positions, gap, width)
    placed = np.add(positions, shifts)
    assert np.all(np.diff(placed) >= gap - 1e-9)
    assert placed[-1] <= width + 1e-9
    if np.all(np.diff(positions) >= gap):
        assert shifts == [0.0] * len(positions)  # far enough apart: left where they are
    assert max(abs(s) for s in shifts) <= gap * len(positions)


def test_two_bearings_are_sampled_per_pitch_of_the_one_with_more_balls():
    """7 and 11 balls: the cage pitch 2π holds 11 pitches of the right bearing; each gets
    the 36 angles (396 in all); one bearing keeps its 36 over its pitch."""
    assert ball_pitches((7, 11)) == 11 and ball_pitches((8, 8)) == 1 and ball_pitches((9,)) == 1
    ds = coefficients("two-bearing-rotor", {"left": 7, "right": 11}, n_angles=4)
    assert ds.cage_angle.size == 44
    assert ds.attrs["cage_pitch"] == pytest.approx(cage_pitch((7, 11)))
    one = coefficients("vakharia2015", 8, n_angles=6)
    np.testing.assert_array_equal(one.cage_angle.values,
                                  cage_pitch((8,)) * np.arange(6) / 6)
