"""Lyapunov exponents come out largest first (issue 32, section 4): the finite-time QR frame
can swap two close exponents, so the result reorders its rows by their averaged means."""

from __future__ import annotations

import numpy as np

from analysis.stability.lyapunov import in_order, lyapunov


def test_rows_are_reordered_by_their_averaged_means_not_their_transient():
    rng = np.random.default_rng(3)
    means = np.array([0.2, 0.5, -0.1, -3.0])  # QR order with the first two swapped
    logs = means[:, None] + 0.01 * rng.standard_normal((4, 50))
    logs[:, :10] = -means[:, None]  # a discarded transient that would order them the other way
    out = in_order(logs, discarded=10)
    averaged = out[:, 10:].mean(axis=1)
    assert np.all(np.diff(averaged) <= 0)
    assert np.allclose(sorted(averaged, reverse=True), averaged)
    np.testing.assert_array_equal(out[0], logs[1])  # whole rows move, transient included
    np.testing.assert_array_equal(in_order(out, 10), out)  # already in order: unchanged


def test_a_short_run_prints_its_exponents_in_order():
    res = lyapunov("vakharia2015", 6, duration=0.3, transient=0.1)
    lam = res.exponents.values
    assert np.all(np.diff(lam) <= 0), lam
    assert res.attrs["largest"] == lam[0]
    np.testing.assert_allclose(res.running.isel(t=-1).values, lam)
