"""The CPU build's variants in blocks of lanes (``source.lanes_c``, ``BD_LANES``): bit for bit
the scalar build (the build before lanes) on members whose states, parameters, steps,
counters and schedules differ, one of them blowing up, in blocks with spare lanes, on one
and two threads; the text and so the cache key change with the lanes."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.integrate.compiled import cached_path
from analysis.integrate.kernels import Schedule, cpu
from analysis.integrate.kernels.cpu import cpu_library
from analysis.integrate.kernels.source import (
    LANE_CALLS_MAX,
    lane_calls,
    lanes_pay,
    model_source,
    state_functions,
)
from analysis.integrate.simulate import blow_up_limit
from analysis.model import System

MEMBERS = 11
"""Members per call: one full block of 8 and a block with 5 spare lanes (4: two full
blocks and one with a spare lane)."""


def _system(name: str) -> System:
    if name == "balanced-rotor":
        return System.make(name, n_balls=8, speed_rpm=8000.0, radial_load=50.0)
    return System.make(name, n_balls=8)


def _inputs(system: System) -> list[np.ndarray]:
    """z0, k0, p, h, t0, limit and the schedule of ``MEMBERS`` members: speeds ±10 %,
    states ±20 %, two step sizes, counters and start times that differ; member 3 takes a
    step 500 times the model's and blows up; the odd members' extremes run on past their
    last section."""
    m, dt = MEMBERS, float(system.model.simulation_defaults["dt"])
    speed = system.parameters.get("speed_rpm")
    factors = 0.9 + 0.2 * np.arange(m) / (m - 1)
    members = [system.replace(speed_rpm=speed * f) if speed else system for f in factors]
    z0 = np.array([system.state * (0.8 + 0.04 * i) for i in range(m)])
    h = dt * np.where(np.arange(m) % 2 == 0, 1.0, 1.1)
    h[3] = 500 * dt
    limit = np.full(m, blow_up_limit(system.model, dict(system.parameters)))
    tr, every, count = np.arange(m) * 7, np.arange(m) % 3 + 9, np.arange(m) % 4 + 3
    schedule = Schedule(tr, every, count,  # the odd members run on 5 steps
                        extremes_to=tr + every * count + 5 * (np.arange(m) % 2))
    return [np.ascontiguousarray(a) for a in (
        z0, np.arange(m) * 2.0, np.array([x.p for x in members]), h, np.arange(m) * 1e-4,
        limit)] + schedule.per_member(m)


def _run(lib: cpu.CpuLibrary, inputs: list[np.ndarray], n: int, threads: int,
         kmax: int = 6) -> list[np.ndarray]:
    m = len(inputs[0])
    outs = [np.full((m, kmax, n), np.nan), np.full((m, kmax), np.nan), np.full((m, n), np.nan),
            np.full(m, -7), np.full((m, n), np.nan), np.full((m, n), np.nan)]
    lib.run(m, threads, inputs, kmax, True, outs)
    return outs


@pytest.mark.parametrize("lanes", [4, 8])
@pytest.mark.parametrize("tangent", [False, True])
@pytest.mark.parametrize("name", ["balanced-rotor", "vakharia2015"])
def test_lanes_are_the_scalar_build_bit_for_bit(name, tangent, lanes):
    """Every output (sections, logs, final states, blow-up steps, extremes) of the blocks of
    lanes, forced and chosen, on one and two threads, equals the scalar build's."""
    system = _system(name)
    model, structure, n = system.model, system.structure, system.n_state
    inputs = _inputs(system)
    want = _run(cpu_library(model, structure, tangent, 0), inputs, n, 1)
    assert want[3][3] > 0 and np.all(np.delete(want[3], 3) == -1)  # member 3 blows up
    assert np.all(np.isfinite(want[0][:, :3, 0]) == (np.arange(MEMBERS) != 3)[:, None])
    if tangent:
        assert np.all(np.isfinite(want[1][:, :3]) == (np.arange(MEMBERS) != 3)[:, None])
    for symbol in ("_lanes", ""):
        lib = cpu_library(model, structure, tangent, lanes, symbol)
        assert lib.lanes == lanes
        for threads in (1, 2):
            got = _run(lib, inputs, n, threads)
            for a, b in zip(got, want, strict=True):
                assert np.array_equal(a, b, equal_nan=True), (symbol, threads)


def test_the_lanes_change_the_text_and_the_cache_key():
    """A build with lanes is a text of its own (so a library of its own in the cache, its
    instruction set in the command); the build without is today's text; lanes are for the
    CPU build only."""
    system = _system("vakharia2015")
    model, structure = system.model, system.structure
    scalar = model_source(model, structure, True, "cpu")
    assert model_source(model, structure, True, "cpu", 0) == scalar
    with_lanes = {lanes: model_source(model, structure, True, "cpu", lanes) for lanes in (4, 8)}
    assert "#define BD_LANES 4" in with_lanes[4] and "BD_LANES" not in scalar
    keys = {cached_path("x", text, ["gcc"]) for text in (scalar, *with_lanes.values())}
    assert len(keys) == 3
    assert cached_path("x", scalar, ["gcc"]) != cached_path("x", scalar, ["gcc", "-mavx2"])
    for tangent in (False, True):
        with pytest.raises(ValueError, match="lanes"):
            model_source(model, structure, tangent, "cuda", 4)


@pytest.mark.parametrize("tangent", [False, True])
def test_a_host_without_lanes_builds_the_scalar_text(monkeypatch, tangent):
    """Where ``host_isas`` finds neither AVX2 nor AVX-512F the default build is the scalar
    text (no instruction-set flag), and its members are those of the build with lanes."""
    system = _system("balanced-rotor")
    model, structure, n = system.model, system.structure, system.n_state
    monkeypatch.setattr(cpu, "host_isas", lambda: {})
    cpu_library.cache_clear()
    try:
        lib = cpu_library(model, structure, tangent)
        assert lib.lanes == 0
        assert lib.path == cpu_library(model, structure, tangent, 0).path
        inputs = _inputs(system)
        got = _run(lib, inputs, n, 1)
        want = _run(cpu_library(model, structure, tangent, 4, "_lanes"), inputs, n, 1)
        for a, b in zip(got, want, strict=True):
            assert np.array_equal(a, b, equal_nan=True)
    finally:
        cpu_library.cache_clear()


def test_lanes_only_where_they_pay(monkeypatch):
    """A host with lanes builds them for a model whose Functions have few libm calls lane by
    lane (balanced rotor: none in the stage, sin and cos in the step), not for one with
    many (the inner-race defect's atan2 and cos: slower on lanes)."""
    monkeypatch.setattr(cpu, "host_isas", lambda: {4: ()})
    cpu_library.cache_clear()
    try:
        rotor, defect = _system("balanced-rotor"), System.make("6205-inner-defect")
        assert lanes_pay(rotor.model, rotor.structure, True)
        assert not lanes_pay(defect.model, defect.structure, False)
        assert lane_calls(state_functions(defect.model, defect.structure)[0]) > LANE_CALLS_MAX
        assert cpu_library(rotor.model, rotor.structure, True).lanes == 4
        assert cpu_library(defect.model, defect.structure, False).lanes == 0
    finally:
        cpu_library.cache_clear()
