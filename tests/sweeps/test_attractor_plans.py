"""The attractor studies as study plans (``analysis.sweeps.attractor_blocks``): every check
once per command. ``basins`` made its study 4 times (its check, its cost, its run and the
CLI's check); a global continuation over N values about 3N + 3 times. Now a plan makes the
study once (once per value of a continuation), the cost and the run take the plan's, the
device is judged once, the cell scale computed once and a continuation's matching
threshold checked once (it was checked by the command line too). Counted through the real command
(typer's runner, the recurrence mapper on a serial executor, so the cost's timed probe runs
too) and through the API; the plans are ``StudyPlan``s and a refused plan leaves nothing."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.study import StudyPlan
from analysis.model import System
from analysis.stability.attractors import Box, Range, study
from analysis.sweeps import attractor_blocks
from analysis.sweeps.attractor_blocks import (
    continuation_to_file,
    plan_basins,
    plan_continuation,
    plan_fractions,
)
from analysis.sweeps.runner import run_study
from tests.counting import count_calls, count_judged, invoke

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3,
               speed_rpm=1.4 * 30 / np.pi)
BOX = Box.parse(["x:-3:3", "vx:-3:3"])


@pytest.fixture
def counted(monkeypatch) -> Counter:
    """How many times each check ran: the study made (``make_study``, wherever it is
    called from), the device judged (``placement.judge``), the cell scale computed, the
    matching threshold checked (``check_threshold``, wherever it is called from)."""
    from analysis.stability.attractors import continuation, studies

    counts: Counter = Counter()
    count_calls(monkeypatch, counts, "study", study.make_study,
                attractor_blocks, study, continuation, studies)
    count_judged(monkeypatch, counts)
    count_calls(monkeypatch, counts, "scale", study.AttractorStudy.settled_scale,
                study.AttractorStudy)
    count_calls(monkeypatch, counts, "threshold", continuation.check_threshold,
                attractor_blocks, continuation)
    return counts


def sets(**values: float) -> list[str]:
    return [arg for name, value in values.items() for arg in ("--set", f"{name}={value}")]


@pytest.mark.parametrize("args, studies, thresholds", [
    (["basins", "duffing", "--x", "x:-3:3:3", "--y", "vx:-3:3:3"], 1, 0),
    (["attractors", "duffing", "--samples", "6", "--box", "x:-3:3", "--box", "vx:-3:3"], 1, 0),
    (["attractors", "duffing", "--samples", "6", "--box", "x:-3:3", "--box", "vx:-3:3",
      "--param", "forcing_amplitude:0.3:0.34:3"], 3, 1),
], ids=["basins", "attractors", "global-continuation"])
def test_a_command_checks_each_thing_once(counted, args, studies, thresholds, tmp_path):
    """The study is made once (once per value), the device judged once, the scale computed
    once (the cost's probe and the run share it), though the cost is said and run; a
    continuation's matching threshold is checked once (by its plan, not the command line)."""
    out = tmp_path / "out.nc"
    done = invoke(*args, "-o", str(out), "--executor", "serial",
                  *sets(**{k: v for k, v in DUFFING.items() if k != "speed_rpm"}),
                  "--speed-rpm", str(DUFFING["speed_rpm"]))
    assert done.exit_code == 0, done.output
    assert out.exists()
    assert counted == Counter({"study": studies, "judge": 1, "scale": studies,
                               "threshold": thresholds})


@pytest.fixture(scope="module")
def system() -> System:
    return System.make("duffing", **DUFFING)


def test_the_api_checks_each_thing_once_and_plans_are_study_plans(counted, system, tmp_path):
    x, y = Range("x", -3.0, 3.0, 3), Range("vx", -3.0, 3.0, 3)
    plans = [plan_basins(system, x, y, tmp_path / "b.nc"),
             plan_fractions(system, BOX, 6, tmp_path / "f.nc"),
             plan_continuation(system, "forcing_amplitude", [0.3, 0.32], BOX, 6,
                               tmp_path / "c.nc")]
    assert all(isinstance(plan, StudyPlan) for plan in plans)
    assert counted["study"] == 4 and counted["judge"] == 3 and counted["threshold"] == 1
    for plan in plans:
        run_study(plan)
        assert plan.output.exists() and not plan.output.with_name(
            plan.output.name + ".parts").exists()
    assert counted["study"] == 4 and counted["judge"] == 3 and counted["threshold"] == 1


def test_the_api_without_a_plan_checks_the_threshold_once(counted, system):
    """``studies.global_continuation`` called directly (no plan, no store) checks the
    matching threshold once, where the values are continued."""
    from analysis.stability.attractors.studies import global_continuation

    ds = global_continuation(system, "forcing_amplitude", [0.3, 0.32], BOX, 6)
    assert ds.sizes["value"] == 2
    assert counted["threshold"] == 1


def test_the_plan_run_equals_the_api_of_before(system, tmp_path):
    """``continuation_to_file`` (the API) is its plan run by the runner: the same file."""
    args = (system, "forcing_amplitude", [0.3, 0.32], BOX, 6)
    whole = continuation_to_file(*args, tmp_path / "a.nc", block=4)
    again = run_study(plan_continuation(*args, tmp_path / "b.nc", block=4))
    xr.testing.assert_identical(whole, again)
    assert whole.attrs["param"] == "forcing_amplitude"


def test_a_refused_plan_names_its_field_and_leaves_nothing(system, tmp_path):
    with pytest.raises(InputError) as refused:
        plan_continuation(system, "no_such", [1.0], BOX, 6, tmp_path / "c.nc")
    assert refused.value.field == "param"
    with pytest.raises(InputError) as refused:
        plan_fractions(system, BOX, 0, tmp_path / "f.nc")
    assert refused.value.field == "samples"
    assert list(tmp_path.iterdir()) == []
