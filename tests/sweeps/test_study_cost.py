"""The recurrence mapper's cost said up front (issue 32, section 3): its states stop when
they settle, so the bound of ``max_periods`` each overstates a study by one to two orders of
magnitude; a probe that maps a few states in the study's own box gives the expectation."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from analysis.integrate.cost import CostEstimate
from analysis.model import System
from analysis.stability.attractors import Box, Range
from analysis.sweeps import attractor_blocks
from analysis.sweeps.attractor_blocks import (
    PROBE_BLOCKS,
    PROBE_WIDE_PERIODS,
    recurrence_probe,
    study_cost,
)


class Clock:
    """A clock that a fake study advances: its mapper's host walk costs ``start + k · each``
    s for a block of k states, and runs the member kernel for 30 member-periods (its
    attractor's finder) and 10 per state; the kernel costs ``narrow`` s per member-period
    below 32 members at once and ``wide`` from 32 on (the CPU build's lanes)."""

    def __init__(self, start: float, each: float, narrow: float, wide: float):
        self.now, self.start, self.each = 0.0, start, each
        self.narrow, self.wide, self.sizes, self.widths = narrow, wide, [], []

    def perf_counter(self) -> float:
        return self.now

    def advance(self, s, n_periods):
        self.widths.append(len(s))
        self.now += len(s) * n_periods * (self.narrow if len(s) < 32 else self.wide)
        return np.zeros((len(s), n_periods, s.shape[1] - 1))

    def mapper(self, advance):
        clock = self

        class Mapper:
            def map(self, states):
                clock.sizes.append(len(states))
                clock.now += clock.start + len(states) * clock.each
                advance(np.zeros((1, 3)), 30)
                advance(np.zeros((len(states), 3)), 10)

        return Mapper()

    def map_block(self, states, progress=None):
        self.sizes.append(len(states))


def test_the_probe_separates_a_blocks_start_from_its_states(monkeypatch):
    clock = Clock(start=0.3, each=0.01, narrow=0.004, wide=0.001)
    monkeypatch.setattr(attractor_blocks.time, "perf_counter", clock.perf_counter)
    study = SimpleNamespace(map_block=clock.map_block, mapper=clock.mapper,
                            map=SimpleNamespace(advance=clock.advance),
                            system=System.make("duffing"))
    box = Box((Range("x", -1.0, 1.0), Range("vx", -1.0, 1.0)))
    seconds, note = recurrence_probe(study, box, members=1000, block=256, workers=2)
    assert clock.sizes == [1, *PROBE_BLOCKS], "one untimed state, then the timed blocks"
    assert clock.widths[-1] == 256, "the kernel priced at the study's block width"
    blocks = 4  # 1000 states in blocks of 256
    kernel = (blocks * 30 + 1000 * 10) * 0.001  # member-periods at the wide price
    host = (blocks * 0.3 + 1000 * 0.01) / 2  # the walk, over the workers
    assert seconds == pytest.approx(kernel + host)
    walks = (0.3 + 2 * 0.01) + (0.3 + 8 * 0.01)
    narrow = (30 + 2 * 10 + 30 + 8 * 10) * 0.004  # the probe blocks' own kernel time
    probed = walks + narrow + 256 * PROBE_WIDE_PERIODS * 0.001
    assert note == (f"a probe mapped {sum(PROBE_BLOCKS)} states and ran 256 for "
                    f"{PROBE_WIDE_PERIODS} periods in {probed:.2g} s")


def test_an_expectation_below_the_bound_is_said_beside_it():
    est = CostEstimate(members=3600, steps=708_000, workers=2, step_seconds=4e-7, dt=1e-5,
                       what="initial states", bound=True, expected_seconds=17.0,
                       probe_note="a probe mapped 10 states in 0.34 s")
    assert est.bound_seconds == pytest.approx(3600 * 708_000 * 4e-7 / 2)
    assert est.seconds == 17.0
    assert ("expected about 17 s on 2 worker(s) (a probe mapped 10 states in 0.34 s); the "
            "steps alone at most about 8.5 min (0.4 us per step, probed)") in est.lines()[0]
    assert est.advice() == [], "the advice follows the expectation, not the bound"
    above = CostEstimate(10, 100, 1, 1e-3, 1e-5, bound=True, expected_seconds=50.0)
    assert above.seconds == 50.0, ("the probe ran whole members, the host's work between "
                                   "the steps too: the steps' bound does not cap it")


def test_a_basin_study_probes_its_own_grid(monkeypatch):
    system = System.make("duffing", linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1,
                         forcing_amplitude=0.3, speed_rpm=1.4 * 60 / (2 * 3.141592653589793))
    sides = (Range("x", -2.0, 2.0, 30), Range("vx", -2.0, 2.0, 30))
    monkeypatch.setattr(attractor_blocks, "process_seconds", lambda: 42.0)
    est = study_cost(system, 900, workers=1, sides=sides)
    assert est.bound and est.expected_seconds is not None
    assert est.spent == 42.0, "the probe's seconds are in the 'so far' of the whole command"
    assert 0 < est.seconds < est.bound_seconds
    assert "a probe mapped 10 states and ran" in est.lines()[0]
    without = study_cost(system, 900, workers=1)
    assert without.expected_seconds is None and without.seconds == without.bound_seconds
