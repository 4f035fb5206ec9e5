"""Costs that hold (issue 39, item 3): the estimate probes the member kernel and variant
that will run (``probe_kernel``), counts a tangent step by its measured factor, and says
when the machine it probed was loaded."""

from __future__ import annotations

import math

import pytest

from analysis.errors import InputError
from analysis.integrate import cost
from analysis.integrate.cost import (
    COMPILED,
    KERNELS,
    CostEstimate,
    KernelProbe,
    estimate_cost,
    load_lines,
    probe_kernel,
)
from analysis.model import System

LOADED = "note: the machine was loaded"


@pytest.fixture(scope="module")
def system() -> System:
    return System.make("vakharia2015", 8, speed_rpm=5000)


def test_the_kernel_probe_times_a_step_and_its_tangent(system):
    probe = probe_kernel(system, 1e-5, tangent=True, members=8, seconds=0.01)
    assert probe is not None, "the CPU build of the member kernel is there in the tests"
    assert math.isfinite(probe.step_seconds) and 0 < probe.step_seconds < 1e-3
    assert probe.tangent_factor is not None and math.isfinite(probe.tangent_factor)
    assert probe.tangent_factor > 0, "measured, not clamped (lanes: 0.81x a state step)"
    assert 0 < probe.busy <= 1.0
    state_only = probe_kernel(system, 1e-5, members=8, steps=200)
    assert state_only is not None and state_only.tangent_factor is None


def test_the_probe_refuses_a_step_that_is_not_one(system):
    with pytest.raises(InputError, match=r"^dt: "):
        probe_kernel(system, 0.0)


def test_the_tangent_steps_are_counted_by_the_measured_factor(monkeypatch, system):
    asked = []

    def probe(sys, dt, *, tangent=False, **kwargs):
        asked.append(tangent)
        return KernelProbe(2e-7, 1.7 if tangent else None)

    monkeypatch.setattr(cost, "probe_kernel", probe)
    monkeypatch.setattr(cost, "probe_step_seconds", lambda *a, **k: math.nan)
    plain = estimate_cost(system, 10, 1000, dt=1e-5, workers=2, path=KERNELS, load=0.0)
    half = estimate_cost(system, 10, 1000, dt=1e-5, workers=2, path=KERNELS,
                         tangent_steps=500, load=0.0)
    assert asked == [False, True], "the tangent variant is probed only where it runs"
    assert plain.step_seconds == pytest.approx(2e-7)
    assert half.step_seconds == pytest.approx(2e-7 * (500 + 1.7 * 500) / 1000)
    assert half.seconds > plain.seconds
    assert "member kernel probed, tangent x1.70 on 50% of the steps" in half.lines()[0]


def test_the_compiled_path_probes_the_compiled_blocks(monkeypatch, system):
    def no_kernel(*args, **kwargs):
        raise AssertionError("the member kernel was probed for the compiled path")

    monkeypatch.setattr(cost, "probe_kernel", no_kernel)
    monkeypatch.setattr(cost, "probe_step_seconds", lambda *a, **k: 1e-6)
    est = estimate_cost(system, 10, 1000, dt=1e-5, workers=2, path=COMPILED, load=0.0)
    assert est.step_seconds == 1e-6 and "us per step, probed)" in est.lines()[0]


def test_without_a_kernel_build_the_tangent_is_n_more_states(monkeypatch, system):
    monkeypatch.setattr(cost, "probe_kernel", lambda *a, **k: None)
    monkeypatch.setattr(cost, "probe_step_seconds", lambda *a, **k: 1e-6)
    est = estimate_cost(system, 10, 1000, dt=1e-5, path=KERNELS, tangent_steps=1000,
                        load=0.0)
    assert est.step_seconds == pytest.approx(1e-6 * (1 + system.n_state))


def test_a_loaded_machine_is_said_in_one_line(monkeypatch, system):
    monkeypatch.setattr(cost, "probe_kernel", lambda *a, **k: KernelProbe(2e-7, None, 1.0))
    loaded = estimate_cost(system, 10, 1000, dt=1e-5, path=KERNELS, load=1e6)
    notes = [line for line in loaded.lines() if line.startswith(LOADED)]
    assert notes == [f"{LOADED} (load 1000000.0 on {loaded.cores} core"
                     f"{'s' if loaded.cores != 1 else ''}): the estimate assumes that load"]
    assert loaded.load == 1e6 and loaded.cores >= 1
    idle = estimate_cost(system, 10, 1000, dt=1e-5, path=KERNELS, load=0.0)
    assert not [line for line in idle.lines() if line.startswith(LOADED)]


def test_a_probe_that_got_part_of_a_core_says_so():
    assert load_lines(0.5, 2, 1.0) == []
    assert load_lines(None, 2, None) == []
    assert load_lines(1.5, 2, 0.4) == [
        f"{LOADED} (load 1.5 on 2 cores, the probe got 40% of a core): the estimate "
        "assumes that load"]
    est = CostEstimate(members=1, steps=10, workers=1, step_seconds=1.0, dt=1.0, load=3.1,
                       cores=2)
    assert est.lines()[1] == (f"{LOADED} (load 3.1 on 2 cores): the estimate assumes "
                              "that load")


@pytest.mark.parametrize(("field", "kwargs"), [("path", {"path": "gpu"}),
                                               ("tangent_steps", {"tangent_steps": 2000})])
def test_bad_arguments_name_their_parameter(system, field, kwargs):
    with pytest.raises(InputError, match=rf"^{field}: "):
        estimate_cost(system, 10, 1000, dt=1e-5, **kwargs)


def test_the_probe_runs_on_the_threads_of_the_workers(monkeypatch, system):
    """The kernel probe runs as many threads as the command has workers (the cores at most,
    the members at most): on a loaded machine they share what it gives."""
    from analysis.threads import thread_count

    asked = []

    def probe(sys, dt, *, threads=1, **kwargs):
        asked.append(threads)
        return KernelProbe(2e-7, None, 0.4, threads)

    monkeypatch.setattr(cost, "probe_kernel", probe)
    est = estimate_cost(system, 10, 1000, dt=1e-5, workers=64, path=KERNELS, load=0.0)
    one = estimate_cost(system, 1, 1000, dt=1e-5, workers=64, path=KERNELS, load=0.0)
    assert asked == [min(10, thread_count()), 1]
    assert est.probe_threads == asked[0] and one.probe_threads == 1
    line = est.load_lines()[0]
    assert line.endswith("of a core each): the estimate assumes that load") \
        if asked[0] > 1 else "the probe got 40% of a core" in line


def test_a_threaded_probe_gives_the_seconds_of_a_step_per_thread(system):
    probe = probe_kernel(system, 1e-5, members=4, steps=300, threads=2)
    assert probe is not None and probe.threads == 2
    assert math.isfinite(probe.step_seconds) and 0 < probe.step_seconds < 1e-3
    assert 0 < probe.busy <= 1.0


def test_blocks_that_do_not_deal_evenly_leave_a_worker_idle():
    """96 sets in blocks of 64 on 2 workers: one runs 64, the other 32 (4/3 of an even
    share); 128 deal evenly; one worker is never uneven."""
    assert cost.busiest_share(96, 64, 2) == pytest.approx(4 / 3)
    assert cost.busiest_share(96, 64, 4) == pytest.approx(4 / 3), "two blocks: two workers"
    assert cost.busiest_share(128, 64, 2) == 1.0
    assert cost.busiest_share(96, 64, 1) == 1.0
    # blocks of given sizes (a study's values x blocks): 64+32 x 3 on 2 workers
    assert cost.busiest_share(0, 0, 2, [64, 32] * 3) == pytest.approx(160 / 144)
    est = CostEstimate(members=96, steps=1000, workers=2, step_seconds=1e-6, dt=1e-5,
                       balance=4 / 3)
    assert est.seconds == pytest.approx(96 * 1000 * 1e-6 / 2 * 4 / 3)
    assert "on 2 (blocks uneven over them: x1.33) worker(s)" in est.lines()[0]


def test_a_calibration_on_a_pool_counts_its_blocks(monkeypatch):
    from analysis.inference import abc
    from analysis.integrate.kernels.cpu import cores

    monkeypatch.setattr(cost, "probe_kernel", lambda *a, **k: KernelProbe(2e-7, 1.5))
    monkeypatch.setattr(abc, "classify_seconds", lambda *args, **kwargs: 0.01)
    est = abc.calibrate_cost("vakharia2015", "paper-table2", ["damping:100:1000:log"],
                             samples=96, rounds=1, block=64, host_workers=2)
    assert est.kernels.balance == pytest.approx(4 / 3)
    assert est.kernels.workers == max(1, cores() // 2) * 2


def test_a_grid_counts_the_host_work_of_its_points(monkeypatch):
    """A followed sweep's whole point, timed at the longest corner, beyond its probed steps
    is each point's host work, scaled to the mean record, over the workers."""
    from analysis.sweeps import grid
    from analysis.sweeps.grid import Axis, Setting, check_grid, grid_cost

    monkeypatch.setattr(cost, "probe_step_seconds", lambda *a, **k: 1e-6)
    monkeypatch.setattr(grid, "best_seconds", lambda run: 2.0)
    setting = Setting("vakharia2015", 8, {}, 0.05, 10, lyapunov=False)
    axis = Axis.parse("speed_rpm:3000:9000:4")
    check_grid(setting, axis)
    est = grid_cost(setting, axis, workers=2, point=lambda system: None)
    longest = math.ceil(setting.seconds(setting.system_at(speed_rpm=3000.0)) / setting.step())
    host = (2.0 - longest * 1e-6) * est.steps / longest
    assert dict(est.also)["the host's work of the points (probed)"] == pytest.approx(
        host * 4 / 2)
    assert est.whole_seconds == pytest.approx(est.spent + est.seconds + host * 2
                                              + cost.FILE_SECONDS)
    plain = grid_cost(setting, axis, workers=2)
    assert "the host's work of the points (probed)" not in dict(plain.also)


def test_a_steady_probe_repeats_a_short_call():
    calls = []
    assert cost.steady_seconds(lambda: calls.append(1), seconds=0.0) >= 0.0
    assert len(calls) == 1, "one call at least"
    calls.clear()
    cost.steady_seconds(lambda: calls.append(1), seconds=1e9, most=3)
    assert len(calls) == 3, "as many as fill the time, at most 'most'"


def test_an_uncertainty_study_on_a_pool_counts_its_tasks(monkeypatch):
    """8 runs of the design in blocks of 6 (6 and 2) at one value on 2 workers: one runs 6,
    the other 2 (1.5 of an even share); the record's steps with the tangent."""
    from analysis.integrate.kernels.cpu import cores
    from analysis.uncertainty import study as uncertainty

    monkeypatch.setattr(cost, "probe_kernel", lambda *a, **k: KernelProbe(2e-7, 1.5))
    monkeypatch.setattr(uncertainty, "classify_seconds", lambda study: 0.01)
    study = uncertainty.prepare("vakharia2015", ["radial_clearance=uniform:5e-6:20e-6",
                                                 "damping=normal:200:20"], n_balls=[8],
                                samples=2, block=6)
    assert study.runs == 8 and len(study.blocks()) == 2
    est = uncertainty.study_cost(study, host_workers=2)
    assert est.kernels.balance == pytest.approx(6 * 2 / 8)
    assert est.kernels.workers == max(1, cores() // 2) * 2
    assert "tangent x1.50" in est.lines()[0]
    alone = uncertainty.study_cost(study)
    assert alone.kernels.balance == 1.0 and alone.kernels.workers == cores()
