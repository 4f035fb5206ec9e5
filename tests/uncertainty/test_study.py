"""``analysis.uncertainty.study`` against the stability chart's points
(``analysis.sweeps.points.chart_points``, an independent path through the kernels and the
classifier): the study's probabilities agree with a plain Monte Carlo of chart points at
the same draws, and with zero spread it reduces to the deterministic chart point; blocks are
resumed from the point store."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.inference.simulate import RunSettings
from analysis.model import as_system
from analysis.sweeps.grid import Setting
from analysis.sweeps.points import chart_points
from analysis.sweeps.store import PointStore
from analysis.uncertainty.probabilities import regime
from analysis.uncertainty.study import prepare, run, to_json, uncertainty

SETTINGS = RunSettings(transient_revolutions=20, revolutions=40)
CLEARANCE = "radial_clearance=uniform:5e-6:20e-6"


def chart_classes(n_balls: int, values: list[dict[str, float]]) -> list[dict]:
    """Chart points of vakharia2015 at ``values``, with the study's record: the same RK4
    step, transient and revolutions."""
    base = as_system("vakharia2015", n_balls)
    h, _ = SETTINGS.steps(base)
    period = 1.0 / base.frequencies().shaft_hz
    setting = Setting("vakharia2015", n_balls, {}, transient=20 * period, samples=40, dt=h)
    return chart_points(setting, [base.replace(**v) for v in values])


@pytest.fixture(scope="module")
def clearance_study():
    return uncertainty("vakharia2015", [CLEARANCE], n_balls=[8], samples=8, seed=0,
                       settings=SETTINGS)


def test_probabilities_agree_with_chart_points_at_the_same_draws(clearance_study):
    ds = clearance_study
    independent = ds["independent"].values
    assert independent.sum() == 16
    draws = ds["draws"].values[independent, 0]
    assert draws.min() >= 5e-6 and draws.max() <= 20e-6
    points = chart_classes(8, [{"radial_clearance": float(v)} for v in draws])
    chart = [regime(p["nature"]) for p in points]
    study = list(ds["regime"].values[ds["regime_index"].values[0][independent]])
    lam, ci = ds["lambda1"].values[0][independent], ds["ci95"].values[0][independent]
    for mine, theirs, lo, hi in zip(study, chart, lam - ci, lam + ci, strict=True):
        # a member whose lambda1 interval reaches zero may go either way in either path
        assert mine == theirs or lo <= 0 <= hi, (mine, theirs)
    for k, name in enumerate(ds["regime"].values):
        share = np.mean([c == name for c in chart])
        low, high = ds["probability_ci95"].values[0, k]
        assert low <= share <= high, (name, share, low, high)
    # both regimes appear here: the clearance decides (quasi-periodic at the small end)
    assert 0 < ds["probability"].sel(regime="chaotic").item() < 1


def test_json_shape(clearance_study):
    got = json.loads(json.dumps(to_json(clearance_study, "x.nc"), allow_nan=False))
    (entry,) = got["values"]
    assert entry["n_balls"] == 8
    assert sum(entry["probability"].values()) == pytest.approx(1.0)
    lo, hi = entry["ci95"]["chaotic"]
    assert lo <= entry["probability"]["chaotic"] <= hi
    assert set(entry["amplitude"]) == {"x", "y"}
    amp = entry["amplitude"]["y"]
    assert amp["p05"] <= amp["p50"] <= amp["p95"]
    assert "radial_clearance" in got["sobol"]["chaotic"][0]
    assert got["provenance"]["samples"] == 8 and got["provenance"]["output"] == "x.nc"


def test_zero_spread_reduces_to_the_chart_point():
    ds = uncertainty("vakharia2015", ["radial_clearance=uniform:10e-6:10e-6"],
                     param=("speed_rpm", [5000.0, 6000.0]), samples=2, settings=SETTINGS)
    for i, speed in enumerate((5000.0, 6000.0)):
        (point,) = _chart_at_speed(speed)
        probability = dict(zip(ds["regime"].values, ds["probability"].values[i],
                               strict=True))
        assert probability[regime(point["nature"])] == 1.0, (speed, point["nature"])
        # every member ran the same system: one class, one lambda1
        assert len(set(ds["regime_index"].values[i])) == 1
        assert np.ptp(ds["lambda1"].values[i]) == pytest.approx(0.0, abs=1e-9)


def _chart_at_speed(speed: float) -> list[dict]:
    base = as_system("vakharia2015", None, speed_rpm=speed)
    h, _ = SETTINGS.steps(base)
    period = 1.0 / base.frequencies().shaft_hz
    setting = Setting("vakharia2015", None, {"speed_rpm": speed}, transient=20 * period,
                      samples=40, dt=h)
    return chart_points(setting, [base])


def test_blocks_resume_from_the_store(tmp_path):
    study = prepare("vakharia2015", [CLEARANCE, "damping=normal:200:20"], n_balls=[8],
                    samples=2, settings=SETTINGS, block=4)
    assert study.design.runs == 8 and len(study.blocks()) == 2
    output = tmp_path / "unc.nc"
    store = PointStore(output, study.definition(), lock=True)
    first = run(study, store=store)
    assert store.done() == {"v0-r0", "v0-r4"}
    # a stored block is read back, not computed again: mark it and find the mark
    block = store.load("v0-r4")
    block["lambda1"] = np.full(4, 12345.0)
    store.save("v0-r4", block)
    again = run(study, store=store)
    store.remove()
    assert np.all(again["lambda1"].values[0, 4:] == 12345.0)
    assert np.array_equal(again["lambda1"].values[0, :4], first["lambda1"].values[0, :4])
