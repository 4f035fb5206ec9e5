"""A calibration says its cost before any work (the member kernels' RK4 steps from
``analysis.integrate.cost``'s probe, the host's classification from its own probe), its
counter moves within a block of parameter sets, and an interrupted one says what it kept."""

from __future__ import annotations

import math

import pytest

import analysis.inference.abc as abc
import analysis.integrate.cost as cost
import analysis.integrate.kernels.members as members
import analysis.sweeps.executors as executors
from analysis.inference.abc import calibrate_cost, prepare, run
from analysis.inference.results import calibrate_to_file
from analysis.inference.simulate import RunSettings, evaluate_row, member_steps
from analysis.sweeps.attractor_blocks import WorkerCounts
from analysis.sweeps.store import PointStore

TINY = RunSettings(transient_revolutions=10, revolutions=40)
PRIORS = ["rotor_mass:0.3:3:log", "damping:100:1000:log"]
TINY_CLI = ("--samples", "4", "--rounds", "2", "--transient-revolutions", "10",
            "--revolutions", "40", "--block", "2")


def test_the_estimate_is_the_probes_arithmetic(monkeypatch):
    """Probes of the member kernel, 2 µs per RK4 step and a tangent step of 1.5 state
    steps, and of 30 ms per classified run: sets × rounds members of ``kernel_steps`` steps
    (the record's with the tangent at 1.5) on 4 cores, runs = sets × rounds × rows on 2
    host workers."""
    seen = []

    def probe(system, dt, **kwargs):
        seen.append(kwargs.get("tangent"))
        return cost.KernelProbe(2e-6, 1.5 if kwargs.get("tangent") else None)

    monkeypatch.setattr(cost, "probe_kernel", probe)
    monkeypatch.setattr(cost, "probe_step_seconds", lambda *args, **kwargs: math.nan)
    monkeypatch.setattr(abc, "classify_seconds", lambda *args, **kwargs: 0.03)
    est = calibrate_cost("vakharia2015", "paper-table2", PRIORS, samples=6, rounds=3,
                         settings=TINY, workers=4, host_workers=2)
    problem = prepare("vakharia2015", "paper-table2", PRIORS, samples=6, rounds=3,
                      settings=TINY)
    steps, tangent = abc.kernel_steps(problem.target, TINY, problem.model)
    assert seen == [True], "the member kernel's tangent variant is probed"
    assert 2 * tangent + (steps - tangent) == member_steps(problem.target, TINY,
                                                           problem.model)
    assert (est.kernels.members, est.kernels.steps, est.kernels.workers) == (18, steps, 4)
    assert est.kernels.seconds == pytest.approx(
        18 * ((steps - tangent) + 1.5 * tangent) * 2e-6 / 4, rel=1e-12)
    assert est.runs == 18 * 5 and est.host_total == pytest.approx(90 * 0.03 / 2, rel=1e-12)
    assert est.seconds == pytest.approx(est.kernels.seconds + est.host_total, rel=1e-12)
    head, host, *_ = est.lines()
    assert head.startswith(f"estimate: 18 parameter sets x {steps:,} RK4 steps")
    assert host.startswith("estimate: 90 runs x 0.03 s of classification and spectra")


def test_the_estimate_comes_first_on_stderr(cli, tmp_path):
    out = tmp_path / "cal.nc"
    res = cli("calibrate", "vakharia2015", "--target", "paper-table2",
              *(a for p in PRIORS for a in ("--prior", p)), *TINY_CLI, "-o", str(out))
    assert res.returncode == 0, res.stderr
    lines = res.stderr.splitlines()
    assert lines[0] == "calibrate: 4 sets × 2 rounds × 5 rows = 40 runs (serial)"
    assert lines[1].startswith("estimate: 8 parameter sets x ")
    assert lines[2].startswith("estimate: 40 runs x ") and "in all" in lines[2]
    first_work = min(i for i, line in enumerate(lines)
                     if line.startswith(("calibrate: 0/", "round 1/")))
    assert first_work > 2


def test_a_row_counts_its_sets_as_the_kernel_runs_them(monkeypatch):
    """One thread, sub-chunks of the least size (4 sets): 10 sets at a row move the counter
    at 4, 8 and 10."""
    monkeypatch.setattr(members, "PROGRESS_SECONDS", 1e-9)
    monkeypatch.setattr(members, "cores", lambda: 1)
    problem = prepare("vakharia2015", "paper-table2", PRIORS[1:], samples=10, rounds=1,
                      settings=TINY)
    thetas = abc.box(problem.priors, abc.sobol_round(1, 10, 0))
    seen: list[tuple[int, int]] = []
    evaluate_row(problem.model, problem.target.rows[0], problem.names, thetas, TINY,
                 ("x",), progress=lambda d, t: seen.append((d, t)))
    assert seen == [(4, 10), (8, 10), (10, 10)]


def test_a_calibrations_counter_moves_within_its_blocks(monkeypatch):
    """Blocks of 8 sets × 5 rows: read after each write of the block's task, the parent's
    count moves in steps of 4 runs (not 40), monotone, ending at the total."""
    monkeypatch.setattr(members, "PROGRESS_SECONDS", 1e-9)
    monkeypatch.setattr(members, "cores", lambda: 1)
    parent, seen = {}, []
    real_run, real_writer = executors.run_with_progress, WorkerCounts.writer

    def run_with_progress(executor, fn, tasks, done, total, progress, on_result):
        parent["done"] = done
        return real_run(executor, fn, tasks, done, total, progress, on_result)

    def writer(path, slot):
        write = real_writer(path, slot)

        def and_read(done: int, total: int) -> None:
            write(done, total)
            seen.append(parent["done"]())

        return and_read

    monkeypatch.setattr(executors, "run_with_progress", run_with_progress)
    monkeypatch.setattr(WorkerCounts, "writer", staticmethod(writer))
    problem = prepare("vakharia2015", "paper-table2", PRIORS[1:], samples=16, rounds=1,
                      block=8, settings=TINY)
    last: list[int] = []
    run(problem, progress=lambda d, t: last.append(d))
    assert seen == sorted(seen) and last[-1] == 80
    assert len(set(seen)) >= 16 and {s % 4 for s in seen} == {0}


def test_an_interrupted_calibration_says_what_it_kept(tmp_path, monkeypatch):
    save, saved = PointStore.save, []

    def stop(self, key, values):
        save(self, key, values)
        saved.append(key)
        raise KeyboardInterrupt

    monkeypatch.setattr(PointStore, "save", stop)
    problem = prepare("vakharia2015", "paper-table2", PRIORS[1:], samples=4, rounds=2,
                      block=2, settings=TINY)
    out = tmp_path / "cal.nc"
    with pytest.raises(KeyboardInterrupt) as caught:
        calibrate_to_file(problem, out)
    assert caught.value.__notes__ == [
        f"1 of 4 blocks of 2 parameter sets kept in {out}.parts; run the same command to "
        "resume"]


def test_an_interrupted_calibration_that_kept_nothing_says_so(tmp_path, monkeypatch):
    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(abc, "evaluate_row", stop)
    problem = prepare("vakharia2015", "paper-table2", PRIORS[1:], samples=4, rounds=2,
                      block=2, settings=TINY)
    out = tmp_path / "cal.nc"
    with pytest.raises(KeyboardInterrupt) as caught:
        calibrate_to_file(problem, out)
    assert caught.value.__notes__ == [
        "nothing was kept: none of the 4 blocks of 2 parameter sets had finished"]
    assert not out.exists() and not (tmp_path / "cal.nc.parts").exists()
