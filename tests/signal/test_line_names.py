"""Lines a specialist asks about first are named (issue 32, section 4): the slow beat
kX − n·VC of two nearly equal lines, and the half-order lines of a period-2 response."""

from __future__ import annotations

import pytest

from analysis.signal.spectrum import BEAT_BELOW, HALF_ORDERS, fault_names, frequency_names

X = 83.3333
VC = 332.23  # N_b = 10 on the paper's model: 4X − VC = 1.10 Hz
FAULTS = {"": {"FTF": 33.223, "BPFO": VC, "BPFI": 500.0, "BSF": 150.0}}


def test_the_beat_of_4x_and_vc_is_named():
    names = frequency_names(4 * X - VC, X, VC, tol_hz=0.3)
    assert names[0][:3] == ("4X-VC", 4, -1)


def test_only_a_slow_difference_is_a_beat():
    assert 3 * 82.0 - 196.3 > BEAT_BELOW * 82.0  # a difference, but not a slow one
    assert frequency_names(50.0, 82.0, 196.3, tol_hz=0.75) == []  # 3X − VC = 49.7 Hz: no beat
    assert frequency_names(0.2, X, VC, tol_hz=0.05) == []  # nothing near 0.2 Hz


@pytest.mark.parametrize(("n", "label"), [(1, "VC/2"), (3, "3VC/2"), (5, "5VC/2")])
def test_half_order_envelope_lines_are_named_without_a_defect(n, label):
    assert n in HALF_ORDERS
    assert fault_names(n * VC / 2, X, FAULTS, tol_hz=0.4, defects=())[0][0] == label


@pytest.mark.parametrize(("n", "label"), [(1, "BPFO/2"), (3, "3BPFO/2"), (5, "5BPFO/2")])
def test_half_order_lines_of_an_outer_race_defect(n, label):
    assert fault_names(n * VC / 2, X, FAULTS, tol_hz=0.4, defects=("outer",))[0][0] == label


def test_whole_orders_keep_their_names():
    assert fault_names(VC, X, FAULTS, tol_hz=0.4, defects=("outer",))[0][0] == "BPFO"
    assert fault_names(2 * VC, X, FAULTS, tol_hz=0.4, defects=("outer",))[0][0] == "2BPFO"
    assert fault_names(VC + X, X, FAULTS, tol_hz=0.4, defects=("outer",))[0][0] == "BPFO+X"
