"""A calibration is a study plan (issue 39): ``plan_calibration`` checks every input once
(the priors, the RK4 steps at their corners, the row kernels, the device judged once) and
the one runner (``sweeps.runner.run_study``) opens its store and writes its file; the
command line and the API each check every thing exactly once, and a refusal leaves no
file. The uncertainty study (``uncertainty.study.plan_uncertainty``) is a plan the same
way."""

from __future__ import annotations

from collections import Counter

import pytest

import analysis.inference.abc as abc
from analysis.errors import InputError
from analysis.integrate.study import StudyPlan
from analysis.io import open_result
from analysis.sweeps.runner import run_study
from tests.counting import by_device, count_calls, count_judged, invoke

PRIORS = ["rotor_mass:0.3:3:log", "damping:100:1000:log"]
TINY = {"samples": 4, "rounds": 1, "block": 2,
        "settings": abc.RunSettings(transient_revolutions=10, revolutions=40)}
TINY_CLI = ("--samples", "4", "--rounds", "1", "--transient-revolutions", "10",
            "--revolutions", "40", "--block", "2", "--executor", "serial")
CHECKS = ("check_priors", "check_fixed", "check_steps", "check_row_kernels")
"""The calibration's checks, by their name in ``analysis.inference.abc``."""


@pytest.fixture
def counted(monkeypatch) -> Counter:
    """Calls of each of ``CHECKS`` and of ``placement.judge`` (``judge``). The cost's advice
    tries coarser steps than the calibration's own (``abc.accepted_dt``: ``check_steps``
    with a ``dt`` given): those are counted apart, as ``check_steps of a coarser dt``."""
    calls: Counter = Counter()

    def steps(*args, **kwargs) -> str:
        return "check_steps of a coarser dt" if args[3].dt is not None else "check_steps"

    for name in CHECKS:
        count_calls(monkeypatch, calls, steps if name == "check_steps" else name,
                    getattr(abc, name), abc)
    return count_judged(monkeypatch, calls)


ONCE = Counter({name: 1 for name in (*CHECKS, "judge")})


def test_the_command_checks_each_thing_once(counted, tmp_path):
    out = tmp_path / "cal.nc"
    done = invoke("calibrate", "vakharia2015", "--target", "paper-table2",
                  *(a for p in PRIORS for a in ("--prior", p)), *TINY_CLI, "-o", str(out))
    assert done.exit_code == 0, done.output
    counted.pop("check_steps of a coarser dt", None)  # the advice's, not a check
    assert counted == ONCE
    assert out.exists() and not (tmp_path / "cal.nc.parts").exists()


def test_the_api_checks_each_thing_once_and_the_plan_is_a_study_plan(counted, tmp_path):
    from analysis.inference.results import CalibrationPlan, plan_calibration, to_dataset

    out = tmp_path / "cal.nc"
    plan = plan_calibration("vakharia2015", "paper-table2", PRIORS, out, **TINY)
    assert isinstance(plan, StudyPlan) and isinstance(plan, CalibrationPlan)
    assert counted == ONCE, "every check made by the plan"
    assert plan.placement == "cpu" and plan.placement.variants == ("tangent",)
    assert (plan.kind, plan.unit, plan.total) == ("calibrate", "runs", 4 * 1 * 5)
    assert plan.definition == plan.problem.definition()
    lines: list[str] = []
    ds = run_study(plan, progress=None, say=lines.append, cost=False)
    assert counted == ONCE, "the run checks nothing again, the device included"
    assert lines[0].startswith("round 1/1: ") and lines[-1].startswith("step halved at")
    written = open_result(out)
    assert written.sizes == ds.sizes and written.sizes["member"] == 4
    assert float(written.matched.sum()) == float(to_dataset(plan.calibration).matched.sum())
    assert not (tmp_path / "cal.nc.parts").exists()


def test_calibrate_to_file_checks_nothing_again(counted, tmp_path):
    from analysis.inference.results import calibrate_to_file

    problem = abc.prepare("vakharia2015", "paper-table2", PRIORS, **TINY)
    cal = calibrate_to_file(problem, tmp_path / "cal.nc")
    assert counted == ONCE
    assert len(cal.rounds) == 1 and (tmp_path / "cal.nc").exists()


def test_the_head_names_the_runs_and_the_executor(tmp_path):
    from analysis.inference.results import plan_calibration
    from analysis.sweeps.executors import SerialExecutor

    plan = plan_calibration("vakharia2015", "paper-table2", PRIORS, tmp_path / "c.nc", **TINY)
    assert plan.head(SerialExecutor()) == \
        "calibrate: 4 sets × 1 rounds × 5 rows = 20 runs (serial)"


@pytest.mark.parametrize("options, field", [
    ({"device": "tpu"}, "device"),
    ({"samples": 200_000, "rounds": 30}, "samples"),
    ({"settings": abc.RunSettings(dt=1.0)}, "prior"),  # RK4 unstable at a prior's corner
])
def test_a_refusal_names_its_field_and_leaves_no_file(options, field, tmp_path):
    from analysis.inference.results import plan_calibration

    out = tmp_path / "cal.nc"
    with pytest.raises(InputError) as refused:
        plan_calibration("vakharia2015", "paper-table2", PRIORS, out, **{**TINY, **options})
    assert refused.value.field == field and str(refused.value).startswith(f"{field}: ")
    assert list(tmp_path.iterdir()) == []


def test_the_command_line_names_the_option_and_leaves_no_file(tmp_path):
    out = tmp_path / "cal.nc"
    done = invoke("calibrate", "vakharia2015", "--target", "paper-table2",
                  *(a for p in PRIORS for a in ("--prior", p)), *TINY_CLI, "--device", "tpu",
                  "-o", str(out))
    assert done.exit_code == 2
    assert "error: --device: must be cpu, gpu or auto, got 'tpu'" in done.output
    assert list(tmp_path.iterdir()) == []


# --- the uncertainty study, the same way ---------------------------------------------------

UNC_CLI = ("uncertainty", "vakharia2015", "--dist", "radial_clearance=uniform:5e-6:20e-6",
           "--n-balls", "8,9", "--samples", "4", "--transient-revolutions", "10",
           "--revolutions", "40", "--executor", "serial")


@pytest.fixture
def unc_counted(monkeypatch) -> Counter:
    """Calls of the study's checks (``check_dists``, ``check_size``, ``check_kernels``) and
    of ``placement.judge``."""
    import analysis.uncertainty.study as study

    calls: Counter = Counter()
    for name in ("check_dists", "check_size", "check_kernels"):
        count_calls(monkeypatch, calls, name, getattr(study, name), study)
    return count_judged(monkeypatch, calls)


UNC_ONCE = Counter({"check_dists": 1, "check_size": 1, "check_kernels": 1, "judge": 1})


@pytest.mark.parametrize("written", [True, False], ids=["to-a-file", "printed-only"])
def test_the_uncertainty_command_checks_each_thing_once(unc_counted, tmp_path, written):
    out = tmp_path / "u.nc"
    done = invoke(*UNC_CLI, *(("-o", str(out)) if written else ()))
    assert done.exit_code == 0, done.output
    assert unc_counted == UNC_ONCE
    assert out.exists() == written and not (tmp_path / "u.nc.parts").exists()


def test_the_uncertainty_plan_is_a_study_plan_and_checks_nothing_again(unc_counted,
                                                                      tmp_path):
    from analysis.uncertainty.study import UncertaintyPlan, plan_uncertainty

    settings = abc.RunSettings(transient_revolutions=10, revolutions=40)
    plan = plan_uncertainty("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6"],
                            tmp_path / "u.nc", n_balls=[8], samples=4, settings=settings)
    assert isinstance(plan, StudyPlan) and isinstance(plan, UncertaintyPlan)
    assert plan.placement == "cpu" and plan.total == plan.study.runs
    ds = run_study(plan)
    assert unc_counted == UNC_ONCE
    assert open_result(tmp_path / "u.nc").sizes == ds.sizes


def test_an_uncertainty_refusal_names_its_field_and_leaves_no_file(tmp_path):
    from analysis.uncertainty.study import plan_uncertainty

    with pytest.raises(InputError) as refused:
        plan_uncertainty("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6"],
                         tmp_path / "u.nc", n_balls=[8], samples=4, device="tpu")
    assert refused.value.field == "device"
    assert list(tmp_path.iterdir()) == []


ONE_ROW = """name = "one-row"
[conditions]
speed_rpm = 5000.0
[[rows]]
n_balls = 8
class = "quasi-periodic"
"""


def test_a_calibration_on_the_gpu_judges_it_once_and_runs_there(monkeypatch, tmp_path):
    """On a stand-in GPU (``fake_cupy``: the GPU path run by the CPU build): the device is
    judged once, every ensemble call (the rounds' and the halved step's) goes the GPU
    path, and the sets' classes and λ1 are those of the cores."""
    from analysis.inference.results import calibrate_to_file
    from analysis.model import as_system
    from tests.integrate.fake_cupy import FakeCupy, fake_gpu

    target = tmp_path / "one.toml"
    target.write_text(ONE_ROW)
    options = {**TINY, "samples": 8, "block": 4,  # a record that fits the stand-in's 64 KiB
               "settings": abc.RunSettings(transient_revolutions=5, revolutions=40,
                                           samples_per_revolution=8)}
    cpu = calibrate_to_file(abc.prepare("vakharia2015", str(target), PRIORS, **options),
                            tmp_path / "cpu.nc")
    judged = count_judged(monkeypatch, Counter(), by_device)
    system = as_system("vakharia2015", 8, speed_rpm=5000.0)
    with fake_gpu(monkeypatch, FakeCupy(system, seen := [])):
        problem = abc.prepare("vakharia2015", str(target), PRIORS, device="gpu", **options)
        gpu = calibrate_to_file(problem, tmp_path / "gpu.nc")
    assert judged == Counter({"judge gpu": 1}) and problem.placement.gpu and seen and all(seen)
    assert [[m[0].nature for m in r.rows] for r in gpu.rounds] == \
        [[m[0].nature for m in r.rows] for r in cpu.rounds]
    assert [[m[0].lambda1 for m in r.rows] for r in gpu.rounds] == \
        [[m[0].lambda1 for m in r.rows] for r in cpu.rounds]
    assert open_result(tmp_path / "gpu.nc").attrs["device"] == "gpu"


def test_the_cost_of_a_calibration_not_on_the_cpu_ends_with_the_gpus_note(tmp_path):
    """``auto``: judged once for an ensemble call of a round's sets (here the cores: no GPU
    is visible, or too few sets); the cost, from the CPU's probe, says so last."""
    from analysis.inference.results import GPU_NOTE, plan_calibration

    plan = plan_calibration("vakharia2015", "paper-table2", PRIORS, tmp_path / "c.nc",
                            **{**TINY, "device": "auto", "block": None})
    assert plan.placement.asked == "auto" and plan.placement.members == 4
    assert plan.cost(1).lines()[-1] == GPU_NOTE
    assert GPU_NOTE not in plan_calibration("vakharia2015", "paper-table2", PRIORS,
                                            tmp_path / "c.nc", **TINY).cost(1).lines()


def test_a_prior_the_target_fixes_is_refused_naming_the_prior(tmp_path):
    from analysis.inference.results import plan_calibration

    with pytest.raises(InputError) as refused:
        plan_calibration("vakharia2015", "paper-table2", ["speed_rpm:3000:6000"],
                         tmp_path / "c.nc", **TINY)
    assert refused.value.field == "prior"
    assert str(refused.value).startswith("prior speed_rpm: the target fixes speed_rpm")
    assert list(tmp_path.iterdir()) == []
