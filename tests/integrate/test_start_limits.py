"""Initial states within the model's bounds (issue 32, §5: ±1e300 was accepted): one rule,
``integrate.checks.StartLimits``, judged by every path that takes an initial state
(``simulate``, the sides of boxes and grids, ``chart --ics-box``; the commands' rows are in
the bad-input catalogue)."""

from __future__ import annotations

import math

import pytest

from analysis.errors import InputError
from analysis.integrate.checks import (
    STATE_CAP,
    VELOCITY_MARGIN,
    blow_up_limit,
    check_start,
    check_start_range,
    fastest_forcing,
    stable_step,
    start_limits,
)
from analysis.integrate.simulate import simulate
from analysis.model import System


@pytest.fixture(scope="module")
def paper() -> System:
    return System.make("vakharia2015", n_balls=6)


def test_the_velocity_bound_is_the_stated_rule(paper):
    limits = start_limits(paper)
    displacement = blow_up_limit(paper.model, dict(paper.parameters))
    rate = max(stable_step(paper)[1], 2 * math.pi * fastest_forcing(paper)[1])
    assert limits.displacement == displacement == pytest.approx(1.1905e-3)
    assert limits.velocity == pytest.approx(VELOCITY_MARGIN * displacement * rate)
    assert 50 < limits.velocity < 200, "about 100 m/s for the paper's bearing"


@pytest.mark.parametrize("name", ["vx", "vy"])
def test_a_velocity_beyond_the_bound_is_refused_naming_it(paper, name):
    bound = start_limits(paper).velocity
    index = paper.state_names.index(name)
    state = [1e-6, 0.0, 0.0, 0.0]
    for value in (1e300, -1e300, -1.01 * bound):
        state[index] = value
        with pytest.raises(InputError, match=rf"^initial_state: {name} = .* m/s reaches beyond "
                                             r"the velocity bound of .*give a value within"):
            check_start(paper, state)
    state[index] = 0.99 * bound
    check_start(paper, state)  # within the bound: judged nothing


def test_simulate_refuses_before_any_step_and_runs_within(paper):
    with pytest.raises(InputError, match="initial_state: vx = 1e\\+300 m/s"):
        simulate(paper, duration=0.01, transient=0.0, initial_state=[1e-6, 0, 1e300, 0])
    with pytest.raises(InputError, match=r"centre displacement hypot\(x, y\) = 1e\+300 m"):
        simulate(paper, duration=0.01, transient=0.0, initial_state=[1e300, 0, 0, 0])
    run = simulate(paper, duration=0.002, transient=0.0, initial_state=[1e-6, 0, 0.01, 0])
    assert math.isfinite(float(run.x[-1]))


def test_a_box_side_of_velocities_is_judged_as_a_state(paper):
    with pytest.raises(InputError, match=r"^--box: vx from -1e\+300 to 1e\+300 m/s reaches "
                                         r"beyond the velocity bound"):
        check_start_range(paper, "vx", -1e300, 1e300, "--box")
    check_start_range(paper, "vx", -1.0, 1.0, "--box")


def test_a_model_without_a_blow_up_limit_is_capped():
    duffing = System.make("duffing")
    assert math.isinf(start_limits(duffing).displacement)
    with pytest.raises(InputError, match="beyond the largest initial value of 1e\\+100"):
        check_start(duffing, [0.0, 0.0, 1e300, 0.0])
    check_start(duffing, [0.0, 0.0, STATE_CAP, 0.0])


def test_an_ensemble_member_beyond_the_bounds_is_refused_naming_it(paper):
    from analysis.integrate.ensemble import ensemble

    states = [[1e-6, 0.0, 0.0, 0.0], [1e-6, 0.0, 0.0, -1e300]]
    with pytest.raises(InputError, match=r"^states\[1\]: vy = -1e\+300 m/s reaches beyond"):
        ensemble(paper, states, duration=0.001)
