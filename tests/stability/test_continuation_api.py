"""Continuation as a public problem: ``ContinuationOptions`` refuses each bad field with its
message, ``switch_and_continue`` gives the branch of ``continue --switch-pd``, and a
``ShootingProblem`` built by hand continues like ``continue_orbits``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.flow import steps_per_period
from analysis.io import open_result
from analysis.model import as_system
from analysis.stability.continuation import (
    ContinuationOptions,
    ShootingProblem,
    StepGuards,
    continue_orbits,
    continue_problem,
    options_with,
    orbit_scale,
    switch_and_continue,
)
from analysis.stability.curves import continue_curve
from analysis.stability.periodic import as_period, shoot

DOUBLING = dict(linear_stiffness=1.0, cubic_stiffness=1.0, damping=0.2, forcing_amplitude=20.0)
PD_RUN = dict(param="speed_rpm", start=11.46, stop=14.32, period="shaft", dt=0.01,
              settle=200.0)
"""The Duffing period-doubling example of docs/stability.md (``continue … --switch-pd``)."""

BAD_OPTIONS = [
    (dict(ds_max=0.0), "ds_max: must be a finite number > 0, got 0.0"),
    (dict(ds_max=-1.0), "ds_max: must be a finite number > 0, got -1.0"),
    (dict(ds_max=math.nan), "ds_max: must be a finite number > 0, got nan"),
    (dict(ds_min=0), "ds_min: must be a finite number > 0, got 0"),
    (dict(ds_min=math.inf), "ds_min: must be a finite number > 0, got inf"),
    (dict(tol=0.0), "tol: must be a finite number > 0, got 0.0"),
    (dict(tol=2.0), "tol: must be in (0, 1), got 2.0"),
    (dict(ds_min=0.1, ds_max=0.05), "ds_min: must be <= ds_max = 0.05, got 0.1"),
    (dict(ds=0.0), "ds: must be a finite number > 0 (kept within [ds_min, ds_max]), got 0.0"),
    (dict(ds="0.1"), "ds: must be a finite number > 0 (kept within [ds_min, ds_max]), "
                     "got '0.1'"),
    (dict(max_points=0), "max_points: must be a whole number in [2, 100000], got 0"),
    (dict(max_points=1), "max_points: must be a whole number in [2, 100000], got 1"),
    (dict(max_points=100_001), "max_points: must be a whole number in [2, 100000], "
                               "got 100001"),
    (dict(max_points=2.5), "max_points: must be a whole number in [2, 100000], got 2.5"),
    (dict(max_points=True), "max_points: must be a whole number in [2, 100000], got True"),
    (dict(guards="strict"), "guards: must be a StepGuards, got 'strict'"),
]


@pytest.mark.parametrize(("fields", "message"), BAD_OPTIONS,
                         ids=[m.split(":")[0] + "-" + str(i) for i, (_, m) in
                              enumerate(BAD_OPTIONS)])
def test_options_refuse_each_bad_field(fields, message):
    with pytest.raises(InputError) as err:
        ContinuationOptions(**fields)
    assert str(err.value) == message


@pytest.mark.parametrize("name", ["max_contraction", "max_correction", "max_angle"])
def test_step_guards_refuse_a_bad_threshold(name):
    with pytest.raises(InputError, match=rf"^guards\.{name}: must be a finite number > 0, "
                                         "got 0$"):
        StepGuards(**{name: 0})


def test_keywords_build_the_options_and_replace_their_fields():
    base = ContinuationOptions(ds_max=0.2, max_points=50)
    assert options_with(None) == ContinuationOptions()
    assert options_with(base) is base
    assert options_with(base, ds_max=None, tol=1e-8) == ContinuationOptions(
        ds_max=0.2, max_points=50, tol=1e-8)
    assert options_with(None, ContinuationOptions(max_points=300)).max_points == 300
    assert ContinuationOptions().first_ds == 0.01
    with pytest.raises(InputError, match=r"^ds_max: must be a finite number > 0, got 0$"):
        options_with(base, ds_max=0)


def test_continue_functions_check_their_keywords_before_any_orbit():
    with pytest.raises(InputError, match=r"^ds_max: must be a finite number > 0, got 0.0$"):
        continue_orbits("duffing", **PD_RUN, ds_max=0.0, **DOUBLING)
    with pytest.raises(InputError, match=r"^max_points: must be a whole number in "
                                         r"\[2, 100000\], got 0$"):
        continue_orbits("duffing", **PD_RUN, options=ContinuationOptions(), max_points=0,
                        **DOUBLING)
    with pytest.raises(InputError, match=r"^max_points: must be a whole number in "
                                         r"\[2, 100000\], got 1$"):
        continue_curve("no-such-branch.nc", "PD", param="damping", stop=0.3, max_points=1)


def _same(a, b) -> None:
    """Two branches equal to the last bit: every variable and every attr of ``a``."""
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        x, y = a[name].values, b[name].values
        if x.dtype.kind in "fc":
            assert np.array_equal(x, y, equal_nan=True), name
        else:
            assert np.array_equal(x, y), name
    for key, value in a.attrs.items():
        assert np.array_equal(np.asarray(value), np.asarray(b.attrs[key])), key


@pytest.fixture(scope="module")
def pd_cli(tmp_path_factory):
    """``bearingdyn continue duffing … --switch-pd``: the branch and the period-2 branch."""
    from tests.conftest import run_cli

    out = tmp_path_factory.mktemp("pd") / "pd.nc"
    res = run_cli("continue", "duffing", "--param", "speed_rpm", "--from", "11.46", "--to",
                  "14.32", "--period", "shaft", "--dt", "0.01", "--settle", "200",
                  *(f"--set={k}={v:g}" for k, v in DOUBLING.items()), "--switch-pd",
                  "--quiet", "-o", str(out))
    assert res.returncode == 0, res.stderr
    return open_result(out), open_result(out.with_name("pd-period2.nc"))


def test_switch_and_continue_gives_the_branch_of_switch_pd(pd_cli):
    branch, period2 = pd_cli
    switched = switch_and_continue(branch, "PD", stop=14.32, dt=0.01)
    assert switched.ok and switched.message == ""
    assert switched.point == int(np.nonzero(branch.special.values == "PD")[0][0])
    assert switched.branch.attrs["switched_at"] == "PD"
    _same(switched.branch, period2)
    again = switch_and_continue(branch, "PD", stop=14.32, dt=0.01, point=switched.point,
                                options=ContinuationOptions(max_points=5))
    assert again.branch.sizes["point"] == 5
    np.testing.assert_array_equal(again.branch.z0.values, period2.z0.values[:5])


def test_switch_and_continue_says_when_there_is_nothing_to_switch_to(pd_cli):
    branch, _ = pd_cli
    none = switch_and_continue(branch, "BP", stop=14.32)
    assert not none.ok and none.branch is None and none.point is None
    assert none.message == "no BP point on the branch: nothing to switch to"
    with pytest.raises(InputError, match=r"^point: 0 is not a period-doubling point"):
        switch_and_continue(branch, "PD", stop=14.32, point=0)
    with pytest.raises(InputError, match=r"^point: must be in \[-26, 25\]"):
        switch_and_continue(branch, "PD", stop=14.32, point=26)
    with pytest.raises(InputError, match=r"^kind: must be PD or BP, got 'LP'"):
        switch_and_continue(branch, "LP", stop=14.32)


def test_a_problem_built_by_hand_continues_like_continue_orbits():
    start, stop, dt = 11.46, 12.2, 0.01
    run = dict(PD_RUN, stop=stop)
    expected = continue_orbits("duffing", **run, max_points=12, **DOUBLING)

    system = as_system("duffing", None, **DOUBLING).replace(speed_rpm=start)
    orbit = shoot(system, None, "shaft", dt=dt, settle=200.0)
    model = system.model
    period = as_period(model, orbit.period)
    n_steps = max(steps_per_period(model, orbit.structure, period,
                                   {**orbit.values, "speed_rpm": end}, dt)
                  for end in (start, stop))
    prob = ShootingProblem(model, orbit.structure, period,
                           model.parameter_names.index("speed_rpm"), dict(orbit.values),
                           orbit.t0, n_steps, np.ones(model.n_state), abs(stop - start))
    prob.s_z = orbit_scale(prob, orbit.z0)
    branch = continue_problem(prob, orbit.z0, stop, ContinuationOptions(max_points=12))
    _same(expected, branch)
    assert branch.sizes["point"] == 12
