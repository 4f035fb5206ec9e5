"""``run_members`` with a progress callback on the CPU: the members run in sub-chunks (the
counter moves more often than once per call) and the results are one call's, bit for
bit."""

from __future__ import annotations

import numpy as np

import analysis.integrate.kernels.members as members
from analysis.integrate.kernels import Schedule, run_members
from analysis.model import System


def test_sub_chunks_equal_one_call_and_move_the_counter(monkeypatch):
    """Sub-chunks sized for 1 µs of work (so each holds the least, CHUNK_PER_THREAD members
    per thread): the counter moves once per sub-chunk, monotone, ending at the total; every
    output equals one call's bit for bit."""
    system = System.make("balanced-rotor", n_balls=8, speed_rpm=8000.0, radial_load=50.0)
    z0 = system.state * (1 + 0.01 * np.arange(11))[:, None]
    schedule = Schedule(3, 5, 4, tangent=True)
    whole = run_members(system, z0, None, 1e-5, schedule, threads=1)
    monkeypatch.setattr(members, "PROGRESS_SECONDS", 1e-6)
    seen: list[tuple[int, int]] = []
    parts = run_members(system, z0, None, 1e-5, schedule, threads=1,
                        progress=lambda done, total: seen.append((done, total)))
    for name in ("sections", "logs", "lambda1", "diverged_at", "final", "low", "high"):
        assert np.array_equal(getattr(parts, name), getattr(whole, name), equal_nan=True), name
    step = members.CHUNK_PER_THREAD
    assert seen == [(min(k, 11), 11) for k in range(step, 11 + step, step)]


def test_sub_chunks_grow_to_the_work_of_half_a_second():
    """The sizing rule: a rate of 100 members/s gives chunks of 50 members (a multiple of
    CHUNK_PER_THREAD x threads), never above the block, never below the least."""
    chunks = members._Chunks(1000, 2)
    least = 2 * members.CHUNK_PER_THREAD
    assert chunks.size == least
    chunks.took(least, least / 100.0)
    assert chunks.size % least == 0 and chunks.size == least * int(50 // least)
    chunks.took(10, 1e-9)
    assert chunks.size == least * (1000 // least)
    chunks.took(10, 100.0)
    assert chunks.size == least
    fixed = members._Chunks(7, None)
    fixed.took(7, 1.0)
    assert fixed.size == 7
