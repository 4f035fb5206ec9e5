"""Verdicts where the user looks (issue 25, item 7): the words of ``classify`` follow the
interval of the largest Lyapunov exponent, a stable response to incommensurate forcings is
"quasi-periodic (forced by X, VC, …)", `bearingdyn run`'s table gives each N_b's class
beside the paper's, and the slow part (the exponent) reports its progress."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.integrate.simulate import simulate
from analysis.io import save_dataset
from analysis.provenance import load_dataset, state_at, system_of_attrs
from analysis.reports.paper import PAPER_TABLE2
from analysis.reports.progress import ProgressReporter
from analysis.reports.report import peak_table_markdown, run_paper_case
from analysis.signal.poincare import poincare_section
from analysis.stability.classify import (
    classify,
    classify_section,
    commensurate_groups,
    forcing_frequencies,
)
from analysis.stability.lyapunov import lyapunov
from tests.conftest import run_cli

TWO_BEARINGS = {"left": 7, "right": 11}


@pytest.fixture(scope="module")
def chaotic_points():
    """Cage-section points of a chaotic run (N_b = 7): they never repeat, so the exponent
    given to ``classify_section`` decides."""
    ds = simulate("vakharia2015", 7, duration=0.9, transient=0.3)
    pts = poincare_section(ds, "cage")
    return pts, {v: float(np.ptp(ds[v].values)) for v in ("x", "y", "vx", "vy")}


@pytest.mark.parametrize("lam, ci", [(-9.6, 6.4), (-1.0, 0.99), (3.0, 2.0), (0.5, 0.4),
                                     (-2.0, 3.0), (2.0, 3.0), (0.0, 1.0), (140.0, 13.0)])
def test_approx_zero_is_said_only_of_an_interval_that_holds_zero(chaotic_points, lam, ci):
    pts, ptp = chaotic_points
    c = classify_section(pts, ptp, lambda: (lam, ci))
    floor = 0.01 * 2 * math.pi / pts.attrs["section_period_s"]
    assert ("≈ 0" in c.detail) == (lam - ci <= 0 <= lam + ci), c.detail
    assert c.nature == ("chaotic" if lam - ci > 0 and lam > floor else "quasi-periodic")
    if lam + ci < 0:
        assert "< 0" in c.detail and "stable" in c.detail
    if lam - ci > 0 and lam <= floor:
        assert "below the chaos floor" in c.detail and f"{floor:.3g}" in c.detail
    assert f"{lam:.4g} ± {ci:.2g}" in c.detail and c.largest_exponent == lam


def test_forcing_frequencies_in_groups_of_rational_ratio():
    assert commensurate_groups({"X": 50.0, "VC": 150.0}) == [["X", "VC"]]
    assert commensurate_groups({"X": 1.0, "VC": math.sqrt(2)}) == [["X"], ["VC"]]
    cage = 250 / 6 * (1 - 7.94 / 39.04)  # Hz: the 6205's cage at 5000 rpm
    assert commensurate_groups({"X": 250 / 3, "VC[l]": 7 * cage, "VC[r]": 11 * cage}) == [
        ["X"], ["VC[l]", "VC[r]"]]
    # the balanced rotor: VC alone; the paper's rotor: X and VC (the shaft and cage speeds)
    attrs = {"shaft_hz": 80.0, "vc_hz": 300.0, "unbalance_force": 0.0, "n_balls": 8}
    assert forcing_frequencies(attrs) == {"VC": 300.0}
    assert forcing_frequencies({**attrs, "unbalance_force": 0.6}) == {"X": 80.0, "VC": 300.0}


def test_a_stable_response_to_incommensurate_forcings_is_forced_quasi_periodic(tmp_path):
    """Two bearings of 7 and 11 balls on one cage speed (VC ratio 7:11) and unbalance at X:
    a loaded rotor whose largest exponent is negative beyond its interval. Independently of
    the exponent, two runs from states 1e-7 m apart come together (the response is stable),
    and the shaft section does not repeat (the forcing is not periodic)."""
    ds = simulate("two-bearing-rotor", TWO_BEARINGS, duration=1.0, transient=0.5,
                  radial_load=50.0)
    c = classify(ds)
    assert c.label == "quasi-periodic (forced by X, VC[left], VC[right])"
    assert c.nature == "quasi-periodic" and c.forced_by == ("X", "VC[left]", "VC[right]")
    assert c.largest_exponent + c.ci95 < 0 and "≈ 0" not in c.detail
    assert "X; VC[left], VC[right]" in c.detail  # the two incommensurate groups
    vc = forcing_frequencies(ds.attrs)
    assert vc["VC[left]"] / vc["VC[right]"] == pytest.approx(7 / 11, rel=1e-12)

    start = state_at(ds, 0)
    kick = np.zeros_like(start)
    kick[0] = 1e-7  # m, on the first position
    a = simulate(system_of_attrs(ds.attrs, start), duration=0.3, transient=0.0)
    b = simulate(system_of_attrs(ds.attrs, start + kick), duration=0.3, transient=0.0)
    gap = np.abs(a.x.values - b.x.values)
    assert gap[-1000:].max() < 1e-3 * gap[:10].max()

    save_dataset(ds, tmp_path / "two.nc")
    res = run_cli("classify", str(tmp_path / "two.nc"), "--quiet")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("quasi-periodic (forced by X, VC[left], VC[right]): "
                                 "largest Lyapunov exponent")


def test_progress_of_the_exponent_is_reported():
    ds = simulate("vakharia2015", 6, duration=0.7, transient=0.2)
    calls = []
    c = classify(ds, progress=lambda done, total: calls.append((done, total)))
    assert c.largest_exponent is not None  # the exponent was needed
    total = calls[0][1]
    assert calls[0] == (0, total) and calls[-1] == (total, total) and total > 1
    assert [d for d, _ in calls] == sorted(d for d, _ in calls)


def test_the_progress_renderer_waits_before_it_shows(capsys):
    silent = ProgressReporter("classify", after=1e6, unit="blocks")
    for k in range(11):
        silent(k, 10)
    shown = ProgressReporter("classify", after=0.0, unit="blocks", every=5)
    for k in range(11):
        shown(k, 10)
    err = capsys.readouterr().err
    assert err.count("classify: ") == 3 and "10/10 blocks" in err and "blocks/s" in err


def test_the_run_table_has_each_classes_beside_the_papers(tmp_path):
    """`run`'s table: the paper's Table 2 class and ours with λ1 ± its interval, for N_b = 6
    and 9. Ours is checked against classify with a Lyapunov exponent computed here from the
    model, N_b and the record's first state (not from the run's attrs)."""
    results = run_paper_case(tmp_path, n_balls=(6, 9), duration=1.0, transient=0.4)
    table = peak_table_markdown(results).splitlines()
    assert table[0].endswith("| class (paper) | class (this model) | λ1 (1/s, 95 %) |")
    for r, row in zip(results, table[2:], strict=True):
        ds = load_dataset(r.netcdf)
        exps = lyapunov("vakharia2015", r.n_balls, duration=0.6, transient=0.0,
                        n_exponents=1, initial_state=tuple(state_at(ds, 0)))
        ours = classify(ds, exponents=exps)
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[0] == str(r.n_balls) and cells[6] == PAPER_TABLE2[r.n_balls].nature
        assert cells[7] == ours.label
        lam, ci = float(exps.exponents[0]), float(exps.ci95[0])
        assert cells[8] == f"{lam:.3g} ± {ci:.2g}"
    assert results[0].verdict.nature == "chaotic"  # N_b = 6, as the paper


def test_a_record_too_short_for_a_verdict_is_said_in_the_table(tmp_path):
    (r,) = run_paper_case(tmp_path, n_balls=(6,), duration=0.5, transient=0.2)
    assert r.verdict is None and "simulate longer" in r.unclassified
    row = peak_table_markdown([r]).splitlines()[2]
    assert row.endswith("| chaotic | - | - |")
