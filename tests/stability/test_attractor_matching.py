"""Global continuation says how sure its matches are: the matching threshold is the user's
(API keyword ``match_distance``, ``--match-threshold``), a match beyond it, a match across
periods and a vanished attractor beside a new one are each noted; the transition
(tipping-probability) matrix between consecutive values; the fraction figure draws an
attractor only where it exists, with standard errors; a study whose states do not settle
says so, why where it can be known, and what to raise."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError
from analysis.model import System
from analysis.stability.attractors import Box, global_continuation
from analysis.stability.attractors.continuation import (
    check_threshold,
    continue_attractors,
    match,
    transitions,
)
from analysis.stability.attractors.dataset import unsettled
from analysis.stability.attractors.label import Attractor
from analysis.stability.attractors.mapper import Scale

SCALE = Scale(np.ones(2))


def attractor(i: int, centre: float, period: int | None = 1) -> Attractor:
    points = np.array([[centre, 0.0]]) if period == 1 else \
        np.array([[centre, 0.0], [centre + 0.01, 0.0]])
    nature = f"periodic-{period}" if period else "chaotic"
    return Attractor(i, nature, period, -1.0, 0.1, {}, points[0], points, "")


def test_a_seed_match_beyond_the_threshold_is_noted_and_the_threshold_is_the_users():
    previous = [(1, attractor(1, 0.0))]
    found = [attractor(1, 0.6)]
    notes: list[str] = []
    ids, _ = match(previous, {1: 1}, found, SCALE, 2, 0.25, notes)
    assert ids == {1: 1}  # followed by its seed: same id …
    assert len(notes) == 1 and "more than the matching threshold 0.25" in notes[0]
    notes = []
    match(previous, {1: 1}, found, SCALE, 2, 1.0, notes)  # … a larger threshold trusts it
    assert notes == []


def test_a_match_across_periods_is_said_never_silent():
    notes: list[str] = []
    ids, _ = match([(3, attractor(1, 0.0, 1))], {3: 1}, [attractor(1, 0.05, 2)], SCALE, 4,
                   0.25, notes)
    assert ids == {1: 3}
    assert any("changed from periodic-1 to periodic-2" in n for n in notes)


def test_a_seed_landing_on_an_unrelated_period_does_not_merge_the_two():
    previous = [(1, attractor(1, 0.0, 1))]
    period3 = Attractor(1, "periodic-3", 3, -1.0, 0.1, {}, np.zeros(2),
                        np.array([[0.0, 0.0], [0.05, 0.0], [0.1, 0.0]]), "")
    notes: list[str] = []
    ids, _ = match(previous, {1: 1}, [period3, attractor(2, 0.1, 1)], SCALE, 2, 0.25, notes)
    assert ids == {1: 2, 2: 1}  # the period-1 orbit keeps its id, by distance
    assert any("landed on a periodic-3 attractor: not taken as the same" in n for n in notes)
    notes = []
    ids, _ = match(previous, {1: 1}, [period3], SCALE, 2, 0.25, notes)
    assert ids == {1: 2}  # within the threshold, but of another period: a new id


def test_a_vanished_attractor_beside_a_new_one_is_noted_and_a_threshold_joins_them():
    previous = [(1, attractor(1, 0.0))]
    notes: list[str] = []
    ids, next_id = match(previous, {1: -2}, [attractor(1, 0.5)], SCALE, 2, 0.25, notes)
    assert ids == {1: 2} and next_id == 3  # a new id …
    assert any("attractor 1 vanished and attractor 2 appeared 0.5" in n for n in notes)
    notes = []
    ids, _ = match(previous, {1: -2}, [attractor(1, 0.5)], SCALE, 2, 0.6, notes)
    assert ids == {1: 1} and notes == []  # … or the same one, within the user's threshold


def test_transitions_count_where_each_basins_states_go():
    before = np.array([1, 1, 1, 1, 2, 2, -2])
    after = np.array([1, 1, 3, 3, 2, 1, 2])
    t = transitions(before, after)
    assert t == {1: {1: 0.5, 3: 0.5}, 2: {1: 0.5, 2: 0.5}, -2: {2: 1.0}}
    with pytest.raises(ValueError, match="same states"):
        transitions(before, after[:-1])


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), True])
def test_the_threshold_is_checked(bad):
    with pytest.raises(InputError, match="match_distance: must be a number > 0") as refused:
        check_threshold(bad)
    assert refused.value.field == "match_distance"


DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1,
               forcing_amplitude=0.3)
BOX = Box.parse(["x:-3:3", "vx:-3:3"], "--box")


@pytest.fixture(scope="module")
def duffing_continuation() -> xr.Dataset:
    system = System.make("duffing", **DUFFING, speed_rpm=12.5)
    return global_continuation(system, "speed_rpm", [12.5, 14.0, 15.5, 17.0], BOX, 24,
                               seed=2)


def test_the_transition_matrix_is_the_random_states_labels_followed(duffing_continuation):
    ds = duffing_continuation
    assert np.isnan(ds.transition.isel(value=-1)).all()  # no next value
    for k in range(ds.sizes["value"] - 1):
        rows = ds.transition.isel(value=k)
        present = ds.present.isel(value=k)
        has_states = ds.fraction.isel(value=k) > 0
        for a in ds.attractor.values[(present & has_states).values]:
            assert float(rows.sel(attractor=a).sum()) == pytest.approx(1.0)
            # a row's states reach only attractors present at the next value
            reached = ds.to.values[rows.sel(attractor=a).values > 0]
            assert ds.present.isel(value=k + 1).sel(attractor=reached).all()
        # the matrix carries the basin fractions on: Σ_a f_a(k) T[a, b] = f_b(k + 1)
        f = ds.fraction.isel(value=k).fillna(0).values
        carried = np.nansum(f[:, None] * rows.values, axis=0)
        assert carried == pytest.approx(ds.fraction.isel(value=k + 1).fillna(0).values)


def test_fractions_are_drawn_only_where_present_with_standard_errors(duffing_continuation):
    from analysis.reports.attractor_plots import continuation_figure

    ds = duffing_continuation
    absent = [int(i) for i in ds.attractor.values if not ds.present.sel(attractor=i).all()]
    assert absent, "the range should hold an attractor that vanishes"
    fig = continuation_figure(ds)
    bottom = fig.axes[1]
    lines = {line.get_color(): line for line in bottom.lines if line.get_linestyle() == "-"}
    from analysis.reports.attractor_plots import attractor_color

    for i in absent:
        y = lines[attractor_color(i)].get_ydata()
        here = ds.present.sel(attractor=i).values
        assert np.isnan(np.asarray(y, dtype=float)[~here]).all()  # a gap, not a line to 0
    bars = [c for c in bottom.containers if c.has_yerr]
    assert len(bars) == sum(int(ds.present.sel(attractor=i).any())
                            for i in ds.attractor.values)


def test_a_tiny_threshold_warns_at_every_followed_value():
    system = System.make("duffing", **DUFFING, speed_rpm=13.0)
    said: list[str] = []
    steps = continue_attractors(system, "speed_rpm", [13.0, 14.0], BOX, 8, seed=1,
                                match_distance=1e-9, progress=said.append)
    assert steps[1].notes and all("matching threshold 1e-09" in n for n in steps[1].notes)
    assert any(line.startswith("  warning: attractor") for line in said)


def table(share: float, one_forcing: int, found: int = 0, mapper: str = "recurrence"):
    ids = [*range(1, found + 1), -2]
    fractions = [(1 - share) / max(found, 1)] * found + [share]
    return xr.Dataset({"fraction": ("attractor", fractions)},
                      coords={"attractor": ids},
                      attrs={"one_forcing": one_forcing, "mapper": mapper,
                             "mapper_max_periods": 3000, "mapper_resolution": 40,
                             "mapper_revisits": 30, "section": "shaft"})


def test_nothing_settled_says_why_and_what_to_raise():
    lines = unsettled(table(1.0, one_forcing=0))
    assert lines[0].startswith("nothing settled: 100.0 % of the initial states")
    assert "is not a map" in lines[1] and "more than one forcing frequency" in lines[1]
    assert "--mapper features" in lines[2] and "--max-periods (now 3000)" in lines[2]
    lines = unsettled(table(0.7, one_forcing=1, found=1))
    assert lines[0].startswith("most initial states did not settle: 70.0 %")
    assert "raise --max-periods (now 3000)" in lines[1]
    assert "--transient-periods" in unsettled(table(0.9, 1, mapper="features"))[1]
    assert unsettled(table(0.2, 1, found=2)) == []


def test_basins_that_do_not_settle_say_so(cli, tmp_path):
    res = cli("basins", "duffing", *[f"--set={k}={v}" for k, v in DUFFING.items()],
              "--speed-rpm", "13.369", "--x", "x:-3:3:4", "--y", "vx:-3:3:4",
              "--max-periods", "31", "--revisits", "30", "-o", "b.nc", "--plot", "b.png",
              "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "wrote b.nc: 0 attractor(s)" in res.stdout
    assert "nothing settled: 100.0 %" in res.stdout
    assert "raise --max-periods (now 31)" in res.stdout
    assert "boundary: none on this grid" in res.stdout
    from analysis.io import open_result
    from analysis.reports.attractor_plots import basins_figure

    fig = basins_figure(open_result(tmp_path / "b.nc"))  # not a blank figure: the advice
    assert any("nothing settled" in t.get_text() for t in fig.axes[0].texts)
