"""The frequency-domain methods are study plans (issue 39): ``plan_branch`` checks a
request once (the method's ``check``), the one runner (``sweeps.runner.run_study``) says
its cost once and writes its file; ``bearingdyn hb`` and ``bearingdyn torus`` check, cost
and build each thing exactly once, the error estimate's re-solves check only their size
(``Method.resize``), and a refusal of an API field carries that field, which the command
line shows as its option without reading the message."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import pytest

import analysis.model
from analysis.errors import InputError
from analysis.frequency import methods
from analysis.frequency.methods import PERIODIC, TORUS, BranchPlan, Request
from analysis.integrate.study import StudyPlan
from analysis.io import open_result
from analysis.sweeps.runner import run_study
from tests.counting import count_calls, counting, invoke

DUFFING = ["duffing", "--period", "shaft", "--set", "linear_stiffness=1", "--set",
           "cubic_stiffness=0.5", "--set", "damping=0.1", "--set", "forcing_amplitude=0.3",
           "--set", "speed_rpm=12"]
DUFFING_API = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1,
                   forcing_amplitude=0.3, speed_rpm=12.0)
ROTOR = ["vakharia2015", "--n-balls", "10", "--set", "speed_rpm=5000"]


@pytest.fixture
def counted(monkeypatch) -> Counter:
    """Calls of every method's ``check``, ``estimate`` (its cost) and ``resize`` (a
    re-solve's size checks), keyed ``check``, ``cost``, ``resize``; of ``plan_branch``
    (``plan``) and of the System's build (``analysis.model.as_system``: ``system``)."""
    calls: Counter = Counter()
    for table in (PERIODIC, TORUS):
        for key, method in list(table.items()):
            monkeypatch.setitem(table, key, replace(
                method, check=counting(calls, "check", method.check),
                estimate=counting(calls, "cost", method.estimate),
                resize=method.resize and counting(calls, "resize", method.resize)))
    count_calls(monkeypatch, calls, "plan", methods.plan_branch, methods)
    count_calls(monkeypatch, calls, "system", analysis.model.as_system, analysis.model)
    return calls


ONCE = {"plan": 1, "check": 1, "cost": 1, "system": 1}
"""What a command does once: its plan, the method's checks, its cost, its System."""


@pytest.mark.parametrize("args, resolves", [
    (["hb", *DUFFING, "--harmonics", "5"], 2),
    (["torus", *ROTOR, "--harmonics", "4,2", "--lyapunov-duration", "0"], 2),
    (["torus", *ROTOR, "--method", "shooting", "--points", "17", "--lyapunov-duration", "0"], 0),
], ids=["hb", "torus-hb", "torus-shooting"])
def test_a_command_checks_costs_and_builds_each_thing_once(counted, tmp_path, args, resolves):
    """The re-solves of the HB error estimate (2H, twice the samples) check their size
    only (``resize``), not the whole request again."""
    out = tmp_path / "out.nc"
    done = invoke(*args, "-o", str(out))
    assert done.exit_code == 0, done.output
    assert counted == Counter({**ONCE, "resize": resolves}), counted
    assert done.stderr.startswith("estimate: ")  # the cost, said before the work
    assert done.stdout.startswith(f"wrote {out}: ") and open_result(out).sizes["point"] == 1


def test_a_quiet_command_pays_no_cost_probe(counted, tmp_path):
    done = invoke("hb", *DUFFING, "--harmonics", "5", "-o", str(tmp_path / "q.nc"), "--quiet")
    assert done.exit_code == 0, done.output
    assert counted == Counter({**ONCE, "cost": 0, "resize": 2}) and done.stderr == ""


def test_the_api_checks_once_and_the_plan_is_a_study_plan(counted, tmp_path):
    system = analysis.model.System.make("duffing", **DUFFING_API)
    out = tmp_path / "api.nc"
    plan = methods.plan_branch(PERIODIC["hb"], system, Request(period="shaft"), output=out)
    assert isinstance(plan, StudyPlan) and isinstance(plan, BranchPlan)
    assert (plan.kind, plan.unit, plan.total) == ("hb", "responses", 1)
    assert plan.definition is None and plan.placement is None
    assert plan.request.resolution == PERIODIC["hb"].default  # the default, checked
    assert counted == Counter({"plan": 1, "check": 1})
    lines: list[str] = []
    data = run_study(plan, say=lines.append)
    assert counted == Counter({"plan": 1, "check": 1, "cost": 1, "resize": 2}), \
        "the run checks nothing of the request again"
    assert lines and all(line.startswith(("estimate: ", "note: ")) for line in lines)
    written = open_result(out)
    assert (written.coefficients.values == data.coefficients.values).all()
    assert written.attrs["error_harmonics_at"] == "20"  # the error estimate, in the file


def test_method_run_is_the_same_plan_in_memory(counted):
    system = analysis.model.System.make("duffing", **DUFFING_API)
    seen = []
    data = PERIODIC["hb"].run(system, Request(5, period="shaft"), cost=seen.append)
    assert counted == Counter({"plan": 1, "check": 1, "cost": 1}) and len(seen) == 1
    assert "error_harmonics" not in data.attrs  # ``measured`` adds it


def test_a_branch_plan_counts_its_points():
    system = analysis.model.System.make("duffing", **DUFFING_API)
    end = system.replace(speed_rpm=14.0)
    plan = methods.plan_branch(PERIODIC["hb"], system, Request(
        5, period="shaft", param="speed_rpm", start=12.0, stop=14.0, max_points=7), end)
    assert plan.total == 7 and plan.output is None


@pytest.mark.parametrize("args, field, line", [
    (["hb", *DUFFING, "--harmonics", "0"], "harmonics",
     "--harmonics: must be a whole number >= 1, got 0"),
    (["hb", *DUFFING, "--harmonics", "5", "--samples", "3"], "samples",
     "--samples: must be a whole number >= 2H + 1 = 11, got 3"),
    (["torus", *ROTOR, "--harmonics", "0,2"], "harmonics",
     "--harmonics: each of H1,H2 must be a whole number >= 1, got '0,2'"),
    (["torus", *ROTOR, "--frequencies", "shaft,shaft", "--harmonics", "4,2"], "frequencies",
     "--frequencies: shaft and shaft are the same frequency; a torus needs two "
     "incommensurate ones"),
    (["torus", *ROTOR, "--stability-every", "0"], "stability_every",
     "--stability-every: must be a whole number >= 1, got 0"),
    (["torus", *ROTOR, "--lyapunov-duration", "-1"], "lyapunov_duration",
     "--lyapunov-duration: must be a finite number >= 0 s, got -1.0"),
    (["torus", *ROTOR, "--method", "fourier"], "method",
     "--method: must be hb or shooting, got 'fourier'"),
])
def test_a_refused_field_is_named_as_its_option(tmp_path, monkeypatch, args, field, line):
    """The library's error carries its field; the command line's edge shows the option."""
    import analysis.cli.common as common

    raised = []

    def keep(exc):
        raised.append(exc)
        return as_option(exc)

    as_option = common.as_option
    monkeypatch.setattr(common, "as_option", keep)
    out = tmp_path / "t.nc"
    done = invoke(*args, "-o", str(out))
    assert done.exit_code == 2, done.output
    assert done.stderr == f"error: {line}\n"
    assert isinstance(raised[0], InputError) and raised[0].field == field
    assert str(raised[0]).startswith(f"{field}: ")  # the library names the parameter
    assert not out.exists()


def test_a_refused_default_resolution_names_its_option(monkeypatch, tmp_path):
    """A torus resolution left at its default is the command's value of that option, so a
    refusal of it (field ``points``) names ``--points`` as one of a value given."""
    def refuse(system, end, request):
        raise InputError(f"points: {request.resolution} refused here", field="points")

    monkeypatch.setitem(TORUS, "shooting", replace(TORUS["shooting"], check=refuse))
    done = invoke("torus", *ROTOR, "-o", str(tmp_path / "t.nc"))
    assert done.exit_code == 2, done.output
    assert done.stderr == f"error: --points: {TORUS['shooting'].default} refused here\n"
