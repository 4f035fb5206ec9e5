"""Ensembles (``analysis.integrate.ensemble``) against ``simulate``, member by member, bit for
bit: the stroboscopic map's section points and ``ensemble``'s records, whatever members
share a call of the member kernel (``analysis.integrate.kernels``), at different step
counters, through a blow-up beside them, and the same without a kernel (the scalar blocks)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from analysis import simulate
from analysis.errors import InputError, SimulationError
from analysis.integrate.ensemble import StroboscopicMap, ensemble
from analysis.integrate.kernels import members, source
from analysis.integrate.kernels.cpu import cpu_library
from analysis.integrate.kernels.source import Unsupported, scalar_c, state_functions
from analysis.integrate.simulate import check_bounded
from analysis.model import System
from tests.integrate.fake_cupy import FakeCupy, fake_gpu

CASES = {
    "balanced-rotor": (dict(n_balls=8, speed_rpm=8000.0, radial_load=50.0), "vc"),
    "duffing": (dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1,
                     forcing_amplitude=0.3, speed_rpm=1.4 * 30 / math.pi), "shaft"),
    "rotor-housing": ({}, "vc"),
}
PERIODS = 4


def _map(name: str) -> StroboscopicMap:
    values, period = CASES[name]
    return StroboscopicMap.make(System.make(name, **values), period)


def _starts(smap: StroboscopicMap, count: int) -> np.ndarray:
    """``count`` different initial states near the system's."""
    z = smap.system.state
    scale = np.abs(z).max() or 1.0
    rng = np.random.default_rng(7)
    return z + 0.3 * scale * rng.standard_normal((count, len(z)))


def _states(system: System, z0: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """``simulate``'s states after every step 0 … steps (steps + 1 × n)."""
    run = simulate(system, initial_state=z0, duration=steps * dt, transient=0.0, dt=dt)
    assert len(run.t) == steps + 1
    return np.stack([run[v].values for v in system.state_names], axis=1)


def _rows(z: np.ndarray, k: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.column_stack([z, k]), dtype=float)


@pytest.mark.parametrize("name", list(CASES))
def test_each_member_is_simulate_at_the_section_times(name):
    """Five members (an odd count), two of them at later step counters: each member's
    section points are ``simulate``'s states every N steps, bit for bit; the rows come back
    at their counters plus PERIODS·N."""
    smap = _map(name)
    assert cpu_library(smap.system.model, smap.system.structure, False) is not None
    n, big_n = smap.system.n_state, smap.steps
    starts = _starts(smap, 5)
    offsets = [0, 0, 3 * big_n + 17, 0, 5]
    runs = [_states(smap.system, z, smap.dt, k0 + PERIODS * big_n)
            for z, k0 in zip(starts, offsets, strict=True)]
    s = _rows([run[k0] for run, k0 in zip(runs, offsets, strict=True)], np.array(offsets))
    points = smap.advance(s, PERIODS)
    assert points.shape == (5, PERIODS, n)
    for i, (run, k0) in enumerate(zip(runs, offsets, strict=True)):
        want = run[k0 + big_n::big_n][:PERIODS]
        assert np.array_equal(points[i], want), (name, i)
        assert np.array_equal(s[i, :n], run[-1]) and s[i, n] == k0 + PERIODS * big_n
    assert not smap.diverged(points).any()


def test_save_every_n_matches_simulate_with_save_every():
    """The brief's reference: ``simulate(dt=h, save_every=N)`` from z0 gives the section
    points as its samples 1 … PERIODS."""
    smap = _map("balanced-rotor")
    z0 = _starts(smap, 1)[0]
    run = simulate(smap.system, initial_state=z0, duration=PERIODS * smap.steps * smap.dt,
                   transient=0.0, dt=smap.dt, save_every=smap.steps)
    want = np.stack([run[v].values for v in smap.system.state_names], axis=1)[1:]
    points = smap.advance(_rows(z0[None, :], np.zeros(1)), PERIODS)
    assert np.array_equal(points[0], want)


def test_a_member_does_not_depend_on_its_neighbours():
    """The same member beside other members, at another index: the same bits."""
    smap = _map("duffing")
    starts = _starts(smap, 4)
    first = smap.advance(_rows(starts[:3], np.zeros(3)), PERIODS)
    again = smap.advance(_rows(starts[[1, 3, 0, 2]], np.zeros(4)), PERIODS)
    assert np.array_equal(first[0], again[2]) and np.array_equal(first[1], again[0])
    assert np.array_equal(first[2], again[3])


def test_a_member_that_blows_up_leaves_its_neighbours_exact():
    """A huge initial velocity on the hardening Duffing overflows to inf/NaN, and a
    NaN row stays NaN: both are flagged, their neighbours are the lone runs'."""
    smap = _map("duffing")
    good = _starts(smap, 2)
    wild = [[0.0, 0.0, 1e200, 0.0], [np.nan, 0.0, 0.0, 0.0]]
    rows = _rows(np.array([good[0], wild[0], good[1], wild[1]]), np.zeros(4))
    points = smap.advance(rows, PERIODS)
    assert list(smap.diverged(points)) == [False, True, False, True]
    alone = smap.advance(_rows(good, np.zeros(2)), PERIODS)
    assert np.array_equal(points[0], alone[0]) and np.array_equal(points[2], alone[1])
    assert np.all(np.isnan(points[3][:, 0]))  # x is NaN; y, decoupled, stays 0


def test_diverged_is_check_bounded_rule():
    """A point beyond the blow-up limit but finite is flagged as ``check_bounded`` does."""
    smap = _map("balanced-rotor")
    pairs = smap.system.model.centre_indices()
    for x in (0.5 * smap.limit, 0.8 * smap.limit, 2 * smap.limit):
        point = np.array([x, 0.75 * x, 0.0, 0.0])
        try:
            check_bounded(point[:, None], np.zeros(1), smap.limit, pairs)
            raised = False
        except SimulationError:
            raised = True
        assert bool(smap.diverged(point[None, None, :])[0]) is raised


def test_a_step_too_coarse_is_refused():
    """The map's step is checked as a flow map's (``RunPlan.step``)."""
    values, _ = CASES["balanced-rotor"]
    with pytest.raises(InputError, match="dt"):
        StroboscopicMap.make(System.make("balanced-rotor", **values), "vc", dt=1e-3)


def test_ensemble_members_are_simulate_with_their_parameters():
    """Three members of other speeds and states, saved every 3rd step: each is ``simulate``
    of its System bit for bit, its parameters and initial state recorded."""
    values, _ = CASES["balanced-rotor"]
    system = System.make("balanced-rotor", **values)
    starts = _starts(StroboscopicMap.make(system, "vc"), 3)
    speeds = [{"speed_rpm": 7000.0}, {"speed_rpm": 8000.0}, {"speed_rpm": 9100.0}]
    ds = ensemble(system, starts, 0.004, parameters=speeds, save_every=3)
    assert ds.sizes["member"] == 3 and np.all(np.isnan(ds["diverged_at"]))
    for i, member in enumerate(speeds):
        run = simulate(system.replace(state=starts[i], **member), duration=0.004,
                       transient=0.0, save_every=3)
        assert np.array_equal(run.t.values, ds.t.values)
        for v in system.state_names:
            assert np.array_equal(run[v].values, ds[v].values[i]), (i, v)
            assert ds[v].attrs == run[v].attrs
        assert ds["speed_rpm"].values[i] == member["speed_rpm"]
        assert np.array_equal([ds[f"{v}0"].values[i] for v in system.state_names], starts[i])
    assert ds.attrs["members"] == 3 and ds.attrs["save_every"] == 3


def test_ensemble_records_a_blow_up_without_raising():
    """A Duffing member that escapes has ``diverged_at`` the time ``simulate`` reports
    (to its message's digits) and NaN after it; its neighbour is ``simulate``'s."""
    values, _ = CASES["duffing"]
    system = System.make("duffing", **{**values, "cubic_stiffness": -1.0,
                                       "forcing_amplitude": 0.3})
    members = [{"forcing_amplitude": 0.3}, {"forcing_amplitude": 2.0}]
    ds = ensemble(system, None, 60.0, parameters=members)
    with pytest.raises(SimulationError) as error:
        simulate(system.replace(**members[1]), duration=60.0, transient=0.0)
    when = float(ds["diverged_at"].values[1])
    assert f"t = {when:.6g} s" in str(error.value)
    assert np.all(np.isnan(ds["x"].values[1][ds.t.values > when]))
    good = simulate(system.replace(**members[0]), duration=60.0, transient=0.0)
    assert np.isnan(ds["diverged_at"].values[0])
    assert np.array_equal(good["x"].values, ds["x"].values[0])


def test_without_a_kernel_the_members_run_one_by_one_with_the_same_bits(monkeypatch):
    """An operation the writer does not know (sqrt taken away) means no member kernel; the
    map and ``ensemble`` then run member by member in the scalar blocks: the same bits."""
    smap = _map("balanced-rotor")
    model, structure = smap.system.model, smap.system.structure
    starts = _starts(smap, 3)
    rows = _rows(starts, np.array([0.0, 11.0, 0.0]))
    with_kernel = smap.advance(rows.copy(), PERIODS)
    speeds = [{"speed_rpm": 7000.0}, {"speed_rpm": 9000.0}, {"speed_rpm": 8000.0}]
    ds_kernel = ensemble(smap.system, starts, 0.002, parameters=speeds)
    monkeypatch.delitem(source.UNARY, "SQRT")
    cpu_library.cache_clear()
    members._self_test.cache_clear()
    try:
        with pytest.raises(Unsupported, match="SQRT"):
            scalar_c(state_functions(model, structure)[0], "step")
        with pytest.raises(Unsupported, match="SQRT"):
            cpu_library(model, structure, False)
        assert np.array_equal(smap.advance(rows.copy(), PERIODS), with_kernel)
        ds_scalar = ensemble(smap.system, starts, 0.002, parameters=speeds)
        for v in smap.system.state_names:
            assert np.array_equal(ds_scalar[v].values, ds_kernel[v].values)
    finally:
        cpu_library.cache_clear()
        members._self_test.cache_clear()


def _speeds_ensemble(system: System, **kwargs):
    starts = _starts(StroboscopicMap.make(system, "vc"), 3)
    speeds = [{"speed_rpm": 7000.0}, {"speed_rpm": 8000.0}, {"speed_rpm": 9100.0}]
    return ensemble(system, starts, 0.002, parameters=speeds, save_every=2, **kwargs)


def test_device_cpu_is_the_default_bit_for_bit():
    """``device="cpu"``: the same bits as the default call (and so ``simulate``'s), for
    ``ensemble`` and the stroboscopic map."""
    system = _map("balanced-rotor").system
    default, cpu = _speeds_ensemble(system), _speeds_ensemble(system, device="cpu")
    for v in system.state_names:
        assert np.array_equal(default[v].values, cpu[v].values)
    starts = _rows(_starts(_map("balanced-rotor"), 3), np.zeros(3))
    smap = StroboscopicMap.make(system, "vc", device="cpu")
    assert smap.device == "cpu"
    assert np.array_equal(smap.advance(starts.copy(), 2), _map("balanced-rotor").advance(
        starts.copy(), 2))


def test_unknown_device_and_gpu_without_cupy_are_one_line(monkeypatch):
    """``device="tpu"`` is refused naming the allowed values; ``device="gpu"`` with CuPy
    not importable in one line naming cupy and the extra to install."""
    system = _map("balanced-rotor").system
    for call in (lambda d: _speeds_ensemble(system, device=d),
                 lambda d: StroboscopicMap.make(system, "vc", device=d)):
        with pytest.raises(InputError, match=r"device: one of cpu, gpu, auto, got 'tpu'") as bad:
            call("tpu")
        assert "\n" not in str(bad.value)
        monkeypatch.setitem(sys.modules, "cupy", None)  # `import cupy` raises ImportError
        with pytest.raises(InputError, match=r"cupy is not installed.*bearingdyn\[gpu\]") \
                as missing:
            call("gpu")
        assert "\n" not in str(missing.value)
        monkeypatch.delitem(sys.modules, "cupy")


def test_device_gpu_with_a_cpu_twin_equals_the_cpu_build(monkeypatch):
    """With CuPy's stand-in (``tests/integrate/fake_cupy.py``: the GPU path, its launches
    run by the CPU build) ``device="gpu"`` takes the GPU path and gives the CPU build's
    results to round-off; ``auto`` stays on the CPU for so few members; ``gpu`` with
    ``compiled=False`` is refused."""
    smap = _map("balanced-rotor")
    system = smap.system
    cpu = _speeds_ensemble(system, device="cpu")
    starts = _rows(_starts(smap, 3), np.array([0.0, 5.0, 0.0]))
    points_cpu = smap.advance(starts.copy(), 2)
    seen: list = []
    with fake_gpu(monkeypatch, FakeCupy(system, seen)):
        assert _speeds_ensemble(system, device="auto").attrs == cpu.attrs and not seen
        gpu = _speeds_ensemble(system, device="gpu")
        assert seen == [False]
        for v in system.state_names:
            want = cpu[v].values
            assert np.all(np.abs(gpu[v].values - want) <= 1e-12 * np.abs(want).max()), v
        gmap = StroboscopicMap.make(system, "vc", device="gpu")
        rows = starts.copy()
        points = gmap.advance(rows, 2)
        assert np.all(np.abs(points - points_cpu) <= 1e-12 * np.abs(points_cpu).max())
        assert np.array_equal(rows[:, -1], starts[:, -1] + 2 * smap.steps)
        with pytest.raises(InputError, match="compiled=False"):
            _speeds_ensemble(system, device="gpu", compiled=False)
