"""The chart and the brute-force diagram as study plans (``analysis.integrate.study``):
``plan_chart`` and ``plan_diagram`` run every check once (the grid, the initial states' box,
the device judged once), through the command line and the API alike; a plan refused leaves
no file and no stored parts; a plan interrupted and run again through the one runner
(``run_study``) writes the uninterrupted result; a refusal names its parameter, and the
command line its option."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from analysis.errors import InputError, ParameterError
from analysis.integrate.study import StudyPlan
from analysis.sweeps import chart, diagram, grid
from analysis.sweeps.chart import plan_chart, stability_chart
from analysis.sweeps.diagram import bifurcation_diagram, plan_diagram
from analysis.sweeps.grid import Axis, Setting
from analysis.sweeps.multistability import Ics, parse_ics
from analysis.sweeps.runner import run_study
from tests.counting import by_device, count_calls, count_judged, invoke

SETTING = Setting("vakharia2015", None, {}, transient=0.05, samples=10)
X, Y = Axis.parse("speed_rpm:4000:5000:2"), Axis.parse("n_balls:8:8")
SWEPT = replace(SETTING, n_balls=8)
SMALL = ["--transient", "0.05", "--executor", "serial"]
CHART_ARGS = ["chart", "vakharia2015", "--x", "speed_rpm:4000:5000:2", "--y", "n_balls:8:8",
              "--revolutions", "10", *SMALL]
SWEEP_ARGS = ["sweep", "vakharia2015", "--param", "speed_rpm", "--from", "4000", "--to",
              "5000", "--num", "2", "--n-balls", "8", "--samples", "10", *SMALL]


@pytest.fixture
def checks(monkeypatch) -> Counter:
    """How many times each check of a chart or a diagram ran: the grid (``check_grid``, by
    the name each module calls), the device (``placement.judge``, by the device named), the
    initial states' box (``Ics.check``) and the cost (``grid_cost``)."""
    seen: Counter = Counter()
    count_calls(monkeypatch, seen, "check_grid", grid.check_grid, chart, diagram, grid)
    count_calls(monkeypatch, seen, "cost", grid.grid_cost, chart, diagram)
    count_calls(monkeypatch, seen, "ics", Ics.check, Ics)
    count_judged(monkeypatch, seen, by_device)
    return seen


def test_a_chart_command_checks_each_thing_once(checks, tmp_path):
    done = invoke(*CHART_ARGS, "-o", str(tmp_path / "c.nc"), "--device", "cpu", "--ics", "2")
    assert done.exit_code == 0, done.output
    assert checks == Counter({"check_grid": 1, "judge cpu": 1, "ics": 1, "cost": 1})
    assert "estimate:" in done.output and "wrote" in done.output


def test_a_chart_through_the_api_checks_each_thing_once(checks, tmp_path):
    ds = stability_chart(SETTING, X, Y, tmp_path / "c.nc", ics=Ics(2), device="auto")
    assert ds.n_attractors.shape == (1, 2)
    assert checks == Counter({"check_grid": 1, "judge auto": 1, "ics": 1})  # no cost said


@pytest.mark.parametrize("extra, judged", [
    ([], None),  # followed: no member kernel, no device judged
    (["--no-follow"], None),  # value by value
    (["--no-follow", "--device", "cpu"], "cpu"),  # the member kernels
], ids=["followed", "value-by-value", "kernels"])
def test_a_sweep_command_checks_each_thing_once(checks, extra, judged, tmp_path):
    done = invoke(*SWEEP_ARGS, "-o", str(tmp_path / "d.nc"), "--direction", "both", *extra)
    assert done.exit_code == 0, done.output
    expected = Counter({"check_grid": 1, "cost": 1})
    if judged is not None:
        expected[f"judge {judged}"] = 1
    assert checks == expected
    assert "2 values × 2 direction(s)" in done.output


@pytest.mark.parametrize("follow, device", [(True, None), (False, None), (False, "cpu")])
def test_a_diagram_through_the_api_checks_each_thing_once(checks, follow, device, tmp_path):
    ds = bifurcation_diagram(SWEPT, X, tmp_path / "d.nc", follow=follow, device=device)
    assert len(ds.speed_rpm) == 2
    expected = Counter({"check_grid": 1})
    if device is not None:
        expected[f"judge {device}"] = 1
    assert checks == expected


def test_the_plans_are_study_plans_that_hold_what_they_checked(checks, tmp_path):
    charted = plan_chart(SETTING, X, Y, tmp_path / "c.nc", ics=Ics(2), device="cpu")
    swept = plan_diagram(SWEPT, X, tmp_path / "d.nc", direction="both", follow=False,
                         device="cpu")
    followed = plan_diagram(SWEPT, X, tmp_path / "f.nc")
    for plan in (charted, swept, followed):
        assert isinstance(plan, StudyPlan)
        assert plan.unit == "points"
    assert (charted.kind, charted.total, charted.placement) == ("chart", 2, "cpu")
    assert charted.definition["ics"]["count"] == 2
    assert (swept.kind, swept.total, swept.placement) == ("diagram", 4, "cpu")
    assert swept.definition["directions"] == ["up", "down"]
    assert followed.placement is None and followed.definition["restart"]
    assert checks == Counter({"check_grid": 3, "judge cpu": 2, "ics": 1})  # one per plan
    assert list(tmp_path.iterdir()) == []  # planned: nothing written


@pytest.mark.parametrize("args", [
    [*CHART_ARGS, "--dt", "0.002"],  # a step too coarse for the grid's fastest corner
    [*CHART_ARGS, "--ics-box", "x:-1e-5:1e-5"],  # a box without --ics
    [*SWEEP_ARGS, "--device", "cpu"],  # the member kernels of a followed sweep
    [*SWEEP_ARGS, "--direction", "left"],
], ids=["chart-step", "chart-box", "sweep-device", "sweep-direction"])
def test_a_command_refused_by_its_plan_leaves_nothing_and_runs_nothing(checks, args, tmp_path):
    done = invoke(*args, "-o", str(tmp_path / "out.nc"))
    assert done.exit_code == 2, done.output
    assert done.output.startswith("error: ") and done.output.count("\n") == 1, done.output
    assert list(tmp_path.iterdir()) == []  # no file, no .parts folder
    assert checks["cost"] == 0 and checks["check_grid"] <= 1


def test_a_refusal_names_the_parameter_and_the_command_line_its_option(tmp_path):
    with pytest.raises(InputError) as refused:
        plan_diagram(SWEPT, X, tmp_path / "d.nc", device="cpu")
    assert refused.value.field == "device"
    assert str(refused.value) == ("device: the member kernels run the values of a diagram "
                                  "with follow=False (a followed diagram is one trajectory); "
                                  "set follow=False")
    done = invoke(*SWEEP_ARGS, "-o", str(tmp_path / "d.nc"), "--device", "cpu")
    assert done.output == ("error: --device: the member kernels run the values of a "
                           "--no-follow sweep (a followed sweep is one trajectory); add "
                           "--no-follow\n")
    with pytest.raises(InputError) as refused:
        plan_chart(replace(SETTING, values={"speed_rpm": 3000.0}), X, Y, tmp_path / "c.nc")
    assert refused.value.field == "sets"
    assert str(refused.value) == ("sets speed_rpm: also an axis; drop speed_rpm from sets "
                                  "(the axis gives its values)")
    assert str(refused.value.renamed("--set")) == ("--set speed_rpm: also an axis; drop the "
                                                   "--set (the axis gives its values)")
    with pytest.raises(InputError) as refused:
        plan_diagram(SWEPT, Axis.linear("n_balls", 7, 9, 3), tmp_path / "d.nc")
    assert (refused.value.field, str(refused.value)) == (
        "n_balls", "n_balls: also an axis (n_balls); drop n_balls")
    with pytest.raises(InputError) as refused:
        parse_ics(None, ["x:-1e-5:1e-5"], 0)
    assert (refused.value.field, str(refused.value)) == (
        "ics_box", "ics_box: draws the initial states of ics; give ics K")
    assert list(tmp_path.iterdir()) == []


def test_a_parameter_error_crosses_processes_whole():
    import pickle

    err = ParameterError("n_balls", "{field} left: also an axis; drop it from {field}")
    back = pickle.loads(pickle.dumps(err))
    assert (type(back), str(back), back.field) == (ParameterError, str(err), "n_balls")
    assert str(back.renamed("--n-balls")) == "--n-balls left: also an axis; drop it from " \
                                             "--n-balls"


class Stop(Exception):
    pass


def _stop_after(count: int):
    def progress(done: int, total: int) -> None:
        if done >= count:
            raise Stop
    return progress


@pytest.mark.parametrize("kind", ["chart", "diagram"])
def test_a_plan_resumed_through_the_runner_writes_the_uninterrupted_result(kind, tmp_path,
                                                                          monkeypatch):
    monkeypatch.setitem(chart.GROUP_POINTS, "cpu", 1)  # a chart stores point by point
    monkeypatch.setitem(diagram.ENSEMBLE_BLOCK, "cpu", 1)

    def plan(name):
        if kind == "chart":
            return plan_chart(SETTING, Axis.parse("speed_rpm:4000:5000:3"), Y,
                              tmp_path / name, device="cpu")
        return plan_diagram(SWEPT, Axis.linear("speed_rpm", 4000, 5000, 3), tmp_path / name,
                            follow=False, device="cpu")

    reference = run_study(plan("ref.nc"))
    interrupted = plan("out.nc")
    with pytest.raises(Stop) as stopped:
        run_study(interrupted, progress=_stop_after(1))
    assert "of 3 points kept" in stopped.value.__notes__[0]
    assert (tmp_path / "out.nc.parts").is_dir() and not (tmp_path / "out.nc").exists()
    resumed = run_study(interrupted)
    for name in reference.variables:
        np.testing.assert_array_equal(resumed[name].values, reference[name].values, name)
    assert not (tmp_path / "out.nc.parts").exists()
