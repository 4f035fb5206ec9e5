"""Features computed on the device (issue 39, item 4): a featurizing run on a GPU reduces
its sections there (``members.section_features``) and copies back 2n features per member,
not its K × n section points; the few members whose points are needed run again alone.

On CuPy's stand-in (``tests/integrate/fake_cupy.py``: the GPU path, its launches run by
the CPU build):

- a study on the "GPU" with the device's features gives the labels, attractors and table
  of the same study with every section point copied back (``DEVICE_FEATURES`` off);
- the device's features are ``features(sections, scale)``, NaN after a blow-up included;
- the bytes ``asnumpy`` copies back per member: 2n × 8 for the sections' part instead of
  K × n × 8 (the final state, the flags and the extremes as before);
- the members run again: the first of each cluster and up to ``PERIOD_SAMPLE`` per
  cluster, none on the sections path;
- on the CPU the features are those of the reduction written before (bit for bit).
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.kernels import Schedule, place, run_members
from analysis.integrate.simulate import blow_up_limit
from analysis.model import System
from analysis.stability.attractors import Box, basin_fractions, featurizing, study_json
from analysis.stability.attractors.featurizing import (
    PERIOD_SAMPLE,
    FeatureOptions,
    FeaturizingMapper,
    features,
    scaled,
)
from analysis.stability.attractors.sampling import Range
from analysis.stability.attractors.studies import basins
from analysis.stability.attractors.study import make_study
from tests.integrate.fake_cupy import FakeCupy, fake_gpu

RPM = 30 / np.pi  # rpm per rad/s
DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
SHORT = FeatureOptions(transient=100, sections=24)


@pytest.fixture(scope="module")
def rotor() -> System:
    return System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)


@pytest.fixture(scope="module")
def duffing() -> System:
    return System.make("duffing", speed_rpm=1.40 * RPM, **DUFFING)


def on_the_stand_in(monkeypatch, system, run, device_features: bool):
    """``run()`` on CuPy's stand-in with ``DEVICE_FEATURES`` set; (its value, the mappers'
    ``rerun`` counts)."""
    reruns: list[int] = []
    real = FeaturizingMapper.points_of

    def counted(self, *args):
        out = real(self, *args)
        reruns.append(self.rerun)
        return out

    with monkeypatch.context() as patch:
        patch.setattr(featurizing, "DEVICE_FEATURES", device_features)
        patch.setattr(FeaturizingMapper, "points_of", counted)
        with fake_gpu(patch, FakeCupy(system, [])):
            return run(), reruns


def assert_same_study(a, b) -> None:
    np.testing.assert_array_equal(a.basin.values if "basin" in a else a.label.values,
                                  b.basin.values if "basin" in b else b.label.values)
    assert study_json(a) == study_json(b)
    assert a.sizes["attractor"] == b.sizes["attractor"]


def test_a_gpu_basin_with_device_features_is_the_basin_of_every_section_point(
        duffing, monkeypatch):
    """A 10 × 10 basin in blocks of 40 (clusters merged across blocks): the same labels,
    attractors and table whether the sections or only their features come back."""
    x, y = Range("x", -3.0, 3.0, 10), Range("vx", -3.0, 3.0, 10)

    def run():
        return basins(duffing, x, y, block=40, mapper="features", device="gpu",
                      feature_options=SHORT)

    reduced, reruns = on_the_stand_in(monkeypatch, duffing, run, True)
    whole, none = on_the_stand_in(monkeypatch, duffing, run, False)
    assert reduced.attrs["device"] == "gpu" and reduced.sizes["attractor"] == 2
    assert_same_study(reduced, whole)
    assert none == [0, 0, 0]  # the sections came back: nobody ran again
    assert len(reruns) == 3 and all(0 < r <= 2 * PERIOD_SAMPLE for r in reruns)


def test_gpu_fractions_with_device_features_are_those_of_every_section_point(
        rotor, monkeypatch):
    """The balanced rotor's period-1 and period-3 orbits from 70 random states: the same
    labels and table; 2 clusters, so at most 2 × ``PERIOD_SAMPLE`` members ran again."""
    box = Box.parse(["x:-20e-6:30e-6", "y:-20e-6:20e-6"])

    def run():
        return basin_fractions(rotor, box, 70, seed=1, mapper="features", device="gpu",
                               feature_options=FeatureOptions(transient=150, sections=24))

    reduced, reruns = on_the_stand_in(monkeypatch, rotor, run, True)
    whole, _ = on_the_stand_in(monkeypatch, rotor, run, False)
    assert_same_study(reduced, whole)
    ids = [int(a) for a in reduced.attractor.values if a > 0]
    assert len(ids) >= 2 and len(reruns) == 1 and reruns[0] <= PERIOD_SAMPLE * len(ids)
    labels = reduced.label.values
    assert reruns[0] == sum(min(np.count_nonzero(labels == a), PERIOD_SAMPLE) for a in ids)


def diverging_states(system: System, count: int) -> np.ndarray:
    states = system.state + np.linspace(-1, 1, count)[:, None] * 5e-6 * (
        np.arange(system.n_state) < 2)
    states[3, 0] = 3 * blow_up_limit(system.model, dict(system.parameters))  # blows up
    return states


def test_device_features_are_the_hosts_to_1e_12(rotor, monkeypatch):
    """``run_members(…, features=True)`` on the "GPU" against ``features`` of the CPU
    build's sections: equal to 1e-12 relative (they are the same operations), NaN where a
    member blew up; on the CPU the sections are kept and reduced as well."""
    study = make_study(rotor, 1, mapper="features", device="cpu", feature_options=SHORT)
    smap, scale = study.map, study.scale
    schedule = featurizing.schedule_of(smap, SHORT)
    states = diverging_states(rotor, 40)
    cpu = run_members(rotor, states, None, smap.dt, schedule, device="cpu", features=True)
    want = features(cpu.sections, scale)
    assert np.isnan(want[3]).all() and np.isfinite(np.delete(want, 3, axis=0)).all()
    np.testing.assert_array_equal(scaled(cpu.features, scale), want)
    with fake_gpu(monkeypatch, FakeCupy(rotor, [])):
        gpu = run_members(rotor, states, None, smap.dt, schedule, device="gpu",
                          features=True)
    assert gpu.sections is None and gpu.device == "gpu"
    np.testing.assert_allclose(scaled(gpu.features, scale), want, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(gpu.diverged_at, cpu.diverged_at)
    with pytest.raises(InputError, match=r"^features: "):
        run_members(rotor, states, None, smap.dt, Schedule(10, 5, 4, keep_sections=False),
                    features=True)


def copies(monkeypatch, system, states, schedule, h, reduce: bool) -> list[tuple]:
    """(shape, bytes) of every array ``asnumpy`` copies back in a "GPU" run (placed and
    run once first: the kernel's self-tests copy their own)."""
    seen: list[tuple] = []
    fake = FakeCupy(system, [])

    def asnumpy(a):
        seen.append((a.shape, a.nbytes))
        return np.asarray(a)

    with fake_gpu(monkeypatch, fake):
        placed = place("gpu", len(states))
        run_members(system, states[:1], None, h, schedule, device=placed, features=reduce)
        fake.asnumpy = asnumpy
        run_members(system, states, None, h, schedule, device=placed, features=reduce)
    return seen


def test_a_member_copies_back_2n_features_not_k_n_section_points(rotor, monkeypatch):
    """Counted in the stand-in's ``asnumpy``: per member 2n × 8 bytes for its sections'
    part (K × n × 8 before); its final state, blow-up step and extremes as before."""
    smap = make_study(rotor, 1, mapper="features", device="cpu", feature_options=SHORT).map
    options = FeatureOptions(transient=2, sections=24)
    schedule = featurizing.schedule_of(smap, options)
    states = diverging_states(rotor, 40)
    m, n, k = len(states), rotor.n_state, options.sections
    reduced = copies(monkeypatch, rotor, states, schedule, smap.dt, True)
    whole = copies(monkeypatch, rotor, states, schedule, smap.dt, False)
    launches = len(reduced) // 6  # sections, logs, final, diverged, low, high per launch
    assert launches >= 2 and len(reduced) == 6 * launches  # the stand-in's small GPU
    first = reduced[0::6]
    assert all(shape[1:] == (2 * n,) for shape, _ in first)  # no (count, K, n) copy
    assert sum(b for _, b in first) == m * 2 * n * 8
    rest = sum(b for _, b in reduced) - sum(b for _, b in first)
    assert rest == m * 8 * (n + 1 + 2 * n) + launches * 8  # final, flag, extremes; no logs
    assert sum(b for _, b in whole) - sum(b for _, b in reduced) == m * (k * n - 2 * n) * 8
    per_member = sum(b for _, b in reduced) / m
    assert per_member < 0.2 * sum(b for _, b in whole) / m


def test_cpu_features_are_the_reduction_written_before_bit_for_bit():
    """``features`` (now ``members.section_features`` divided by the scale) against the
    reduction of the commit before it, written out here, on more than one
    ``FEATURE_CHUNK`` of members with NaN rows: bit for bit."""
    rng = np.random.default_rng(3)
    m = featurizing.FEATURE_CHUNK + 1000
    sections = rng.normal(size=(m, 7, 3)) * np.array([1e-5, 3e-6, 0.2])
    sections[5, 4:] = np.nan
    scale = type("S", (), {"size": np.array([2e-5, 4e-6, 0.3])})()

    def before(s):
        first = s[:, 0]
        low, high, total = first.copy(), first.copy(), first.copy()
        for k in range(1, s.shape[1]):
            point = s[:, k]
            np.minimum(low, point, out=low)
            np.maximum(high, point, out=high)
            total += point
        return np.concatenate([total / s.shape[1] / scale.size, (high - low) / scale.size],
                              axis=1)

    now = features(sections, scale)
    assert np.isnan(now[5]).all()
    assert now.tobytes() == before(sections).tobytes()


def test_the_memory_check_counts_a_gpu_blocks_features_not_its_sections():
    """45·10⁶ states of a 4-state rotor in blocks of 2²⁰: refused when a block's 48
    sections come back (their 1.9 GB and 8 (n + 3) B per state pass the 4 GiB budget),
    allowed when only its features do (0.34 GB)."""
    from analysis.stability.attractors.mapper import MapperOptions
    from analysis.stability.attractors.study import check_memory

    args = (45_000_000, 4, MapperOptions(), FeatureOptions(), 1 << 20)
    with pytest.raises(InputError, match=r"^samples: .* or a smaller --block$"):
        check_memory(*args)
    check_memory(*args, device_features=True)
