"""The member kernels (``analysis.integrate.kernels``) on the CPU build: the state variant
against ``simulate`` bit for bit, the tangent variant's λ1 against the chart's tangent
blocks (``tangent.tangent_block``), blow-ups member by member, the schedule's bookkeeping
and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import simulate
from analysis.errors import InputError
from analysis.integrate.kernels import MemberResult, Schedule, devices, resolve_device, run_members
from analysis.integrate.kernels.source import Unsupported, scalar_c
from analysis.integrate.simulate import bad_states, blow_up_limit
from analysis.integrate.tangent import tangent_block
from analysis.model import System, available_models
from tests.integrate.fake_cupy import FakeCupy, fake_gpu

BALANCED = dict(n_balls=8, speed_rpm=8000.0, radial_load=50.0)


def _system(name: str = "balanced-rotor") -> System:
    return System.make(name, **(BALANCED if name == "balanced-rotor" else {}))


def _simulated(system: System, z0: np.ndarray, dt: float, steps: int) -> np.ndarray:
    run = simulate(system, initial_state=z0, duration=steps * dt, transient=0.0, dt=dt)
    return np.stack([run[v].values for v in system.state_names], axis=1)


@pytest.mark.parametrize("name", ["balanced-rotor", "vakharia2015", "rotor-housing"])
def test_state_variant_is_simulate_bit_for_bit(name):
    """Three members at different speeds: every section is ``simulate``'s state at that
    step, bit for bit, and the final state the last one."""
    system = _system(name)
    dt = float(system.model.simulation_defaults["dt"])
    speeds = [system.parameters["speed_rpm"] * f for f in (1.0, 0.9, 1.1)]
    members = [system.replace(speed_rpm=s) for s in speeds]
    z0 = np.array([system.state * (1 + 0.2 * i) for i in range(3)])
    schedule = Schedule(transient_steps=7, steps_per_section=13, n_sections=5)
    out = run_members(system, z0, np.array([m.p for m in members]), dt, schedule)
    assert isinstance(out, MemberResult) and out.device == "cpu"
    assert np.all(out.diverged_at == -1)
    for i, member in enumerate(members):
        want = _simulated(member, z0[i], dt, schedule.total_steps)
        steps = 7 + 13 * np.arange(1, 6)
        assert np.array_equal(out.sections[i], want[steps])
        assert np.array_equal(out.final[i], want[-1])
        record = want[7:]
        assert np.array_equal(out.low[i], record.min(axis=0))
        assert np.array_equal(out.high[i], record.max(axis=0))


def test_tangent_lambda1_is_the_tangent_blocks_to_round_off():
    """A periodic point of the balanced rotor: λ1 of the tangent variant (renormalised
    every 100 steps) equals the mean log of ``tangent_block`` over the same steps to
    round-off, and its states the state variant's."""
    system = _system()
    model, dt = system.model, 1e-5
    n, renorms, every = model.n_state, 30, 100
    out = run_members(system, system.state[None, :], None, dt,
                      Schedule(0, every, renorms, tangent=True))
    block = tangent_block(model, system.structure, 1, every, renorms)
    s = np.concatenate([system.state, [0.0], np.eye(n)[:, 0]])
    s_end, logs = (np.asarray(x) for x in block(s, system.p, dt, 0.0))
    assert np.allclose(out.logs[0], logs.ravel(), rtol=1e-9, atol=1e-11)
    lam_blocks = logs.mean() / (every * dt)
    assert abs(out.lambda1[0] - lam_blocks) <= 1e-9 * max(abs(lam_blocks), 1.0)
    states = run_members(system, system.state[None, :], None, dt, Schedule(0, every, renorms))
    scale = np.abs(states.sections).max(axis=1)
    assert np.all(np.abs(out.sections - states.sections) <= 1e-12 * scale[:, None, :] * 10)
    assert np.allclose(s_end.ravel()[:n], out.final[0], rtol=1e-10, atol=1e-18)


SHIPPED_TRANSIENT, SHIPPED_EVERY, SHIPPED_SECTIONS = 1000, 40, 6
"""The every-model comparison: 1000 steps of transient (every shipped model's members are
then in contact, their tangent logs not 0), then 6 sections of 40 steps: kept short for CI,
as each model compiles three libraries (two member variants, the RK4 blocks of
``simulate``) and the CasADi virtual machine runs the tangent path's 240 steps."""


@pytest.mark.parametrize("name", available_models())
def test_every_shipped_model_both_variants_match_the_compiled_path(name):
    """Every shipped model with its own balls and parameters, two members (the spec's state
    and one 10 % larger, the second 3 % faster where there is a speed): the state variant's
    sections are ``simulate``'s states (today's compiled path) bit for bit; the tangent
    variant's sections and growth factors (exp of the logs) are those of the scalar CasADi
    tangent path (``tangent_block``: forward AD through the RK4 step, from e1 after the
    transient, renormalised at the same steps) to 1e-12 relative."""
    system = System.make(name)
    model, n, dt = system.model, system.n_state, float(system.model.simulation_defaults["dt"])
    speed = system.parameters.get("speed_rpm")
    members = [system, system.replace(speed_rpm=1.03 * speed) if speed else system]
    z0 = np.array([system.state, system.state * 1.1])
    p = np.array([m.p for m in members])
    tr, every, count = SHIPPED_TRANSIENT, SHIPPED_EVERY, SHIPPED_SECTIONS
    states = run_members(system, z0, p, dt, Schedule(tr, every, count))
    tangent = run_members(system, z0, p, dt, Schedule(tr, every, count, tangent=True))
    assert np.all(states.diverged_at == -1) and np.all(tangent.diverged_at == -1)
    block = tangent_block(model, system.structure, 1, every, count, with_states=True)
    for i, member in enumerate(members):
        want = _simulated(member, z0[i], dt, tr + every * count)
        assert np.array_equal(states.sections[i], want[tr + every::every]), (name, i)
        s = np.concatenate([want[tr], [tr], np.eye(n)[:, 0]])
        _, logs, path = (np.asarray(x) for x in block(s, member.p, dt, 0.0))
        scale = np.abs(want).max(axis=0) + 1e-300
        cas = path[:n, every - 1::every].T  # [z; k] after every step: the section states
        assert np.all(np.abs(tangent.sections[i] - cas) <= 1e-12 * scale), (name, i)
        assert np.all(logs != 0.0), (name, i)  # the tangent moves: a test of the Jacobian
        assert np.all(np.abs(tangent.logs[i] - logs.ravel()) <= 1e-12), (name, i)


def test_a_blow_up_stops_one_member_only():
    """A member with a huge step leaves the bound: its diverged_at is the first step where
    ``simulate.bad_states`` holds, its later sections NaN; the other member is unchanged."""
    system = _system()
    z0 = np.array([system.state, system.state])
    schedule = Schedule(0, 10, 20, tangent=True)
    alone = run_members(system, z0[:1], None, 1e-5, schedule)
    out = run_members(system, z0, None, np.array([1e-5, 5e-3]), schedule)
    assert out.diverged_at[0] == -1 and out.diverged_at[1] > 0
    assert np.array_equal(out.sections[0], alone.sections[0])
    assert np.isnan(out.lambda1[1]) and np.isfinite(out.lambda1[0])
    k = int(out.diverged_at[1])
    limit = blow_up_limit(system.model, dict(system.parameters))
    assert bad_states(out.final[1], limit, system.model.centre_indices())
    assert np.all(np.isnan(out.sections[1, k // 10:]))
    if k > 10:
        assert not np.any(bad_states(out.sections[1, :k // 10 - 1], limit,
                                     system.model.centre_indices()))


def test_chained_calls_equal_one_call():
    """Two calls chained through ``final`` and ``k0`` equal one call bit for bit."""
    system = _system("vakharia2015")
    dt = 1e-5
    z0 = system.state[None, :]
    one = run_members(system, z0, None, dt, Schedule(0, 20, 6))
    first = run_members(system, z0, None, dt, Schedule(0, 20, 3))
    second = run_members(system, first.final, None, dt, Schedule(0, 20, 3), k0=60)
    assert np.array_equal(one.sections[0], np.concatenate([first.sections[0],
                                                           second.sections[0]]))


def test_blocks_do_not_change_results():
    system = _system()
    z0 = system.state * (1 + 0.01 * np.arange(5))[:, None]
    seen = []
    a = run_members(system, z0, None, 1e-5, Schedule(3, 5, 4), block=2,
                    progress=lambda done, total: seen.append((done, total)))
    b = run_members(system, z0, None, 1e-5, Schedule(3, 5, 4))
    assert np.array_equal(a.sections, b.sections) and seen == [(2, 5), (4, 5), (5, 5)]


@pytest.mark.parametrize("kwargs, field", [
    (dict(transient_steps=-1, steps_per_section=1, n_sections=1), "transient_steps"),
    (dict(transient_steps=0, steps_per_section=0, n_sections=1), "steps_per_section"),
    (dict(transient_steps=0, steps_per_section=1, n_sections=0), "n_sections"),
    (dict(transient_steps=0, steps_per_section=1, n_sections=2, lyapunov_skip=2),
     "lyapunov_skip"),
])
def test_bad_schedules_name_their_field(kwargs, field):
    with pytest.raises(InputError, match=field):
        Schedule(**kwargs)


def test_bad_inputs_and_devices():
    system = _system()
    with pytest.raises(InputError, match="states"):
        run_members(system, np.zeros((2, 3)), None, 1e-5, Schedule(0, 1, 1))
    with pytest.raises(InputError, match="h"):
        run_members(system, system.state[None, :], None, -1.0, Schedule(0, 1, 1))
    with pytest.raises(InputError, match="parameters"):
        run_members(system, system.state[None, :], np.zeros((1, 2)), 1e-5, Schedule(0, 1, 1))
    with pytest.raises(InputError, match=r"^device: one of cpu, gpu, auto"):
        resolve_device("tpu", 10, 10)
    assert resolve_device("cpu", 10, 10) == "cpu"
    assert resolve_device("auto", 10, 10) == "cpu"


def test_auto_takes_a_visible_gpu_from_both_thresholds_on(monkeypatch):
    """With a GPU visible (CuPy's stand-in), ``auto`` is ``gpu`` at and above
    ``AUTO_MIN_MEMBERS`` members and ``AUTO_MIN_STEPS`` member-steps, ``cpu`` just below
    either; ``cpu`` stays ``cpu``."""
    members, total = devices.AUTO_MIN_MEMBERS, devices.AUTO_MIN_STEPS
    steps, wide = -(-total // members), -(-total // (10 * members))  # fewest steps that reach
    assert members * (steps - 1) < total <= members * steps         # the member-steps bound
    with fake_gpu(monkeypatch, FakeCupy(_system(), [])):
        assert devices.gpu_problem() is None
        for m, k, want in ((members, steps, "gpu"), (members + 1, steps, "gpu"),
                           (10 * members, wide, "gpu"), (members - 1, 10 * steps, "cpu"),
                           (members, steps - 1, "cpu"), (10 * members, wide - 1, "cpu")):
            assert resolve_device("auto", m, k) == want, (m, k)
        assert resolve_device("cpu", 10 * members, 10 * steps) == "cpu"
        assert resolve_device("gpu", 1, 1) == "gpu"


def test_the_writer_refuses_what_it_cannot_write():
    import casadi as ca

    x = ca.MX.sym("x")
    with pytest.raises(Unsupported, match="not an SX"):
        scalar_c(ca.Function("f", [x], [x]), "f")


def test_per_member_schedules_are_each_members_own_call():
    """Members of different schedules in one call: each equals its call alone; sections
    past a member's own K are NaN; λ1 averages its own logs."""
    system = _system()
    z0 = system.state * (1 + 0.05 * np.arange(3))[:, None]
    hs = np.array([1e-5, 1.1e-5, 0.9e-5])
    together = run_members(system, z0, None, hs,
                           Schedule([5, 0, 9], [10, 7, 12], [4, 6, 3], tangent=True,
                                    lyapunov_skip=[1, 0, 2]))
    for i, (tr, ev, k, skip) in enumerate([(5, 10, 4, 1), (0, 7, 6, 0), (9, 12, 3, 2)]):
        alone = run_members(system, z0[i:i + 1], None, hs[i],
                            Schedule(tr, ev, k, tangent=True, lyapunov_skip=skip))
        assert np.array_equal(together.sections[i, :k], alone.sections[0])
        assert np.all(np.isnan(together.sections[i, k:]))
        assert together.lambda1[i] == alone.lambda1[0]
        assert np.isclose(alone.lambda1[0], alone.logs[0, skip:].mean() / (ev * hs[i]),
                          rtol=1e-14)
    with pytest.raises(InputError, match="n_sections"):
        run_members(system, z0, None, 1e-5, Schedule(0, 1, [1, 2]))
