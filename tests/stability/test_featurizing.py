"""The featurizing mapper (fixed-time runs on the member kernel, features clustered on the
host) against the recurrence mapper on the same initial states, and its pieces.

- balanced-rotor (50 N, N_b = 8, 8000 rpm): the period-1 orbit and the period-3 orbit,
  both found, their basin shares within two standard errors of the recurrence mapper's;
- Duffing (c = 0.1, k1 = 1, k3 = 0.5, F = 0.3) at ω = 1.40 rad/s: two periodic-1
  attractors (small and large), both mappers agree state by state;
- blocks merged across (a block size that cuts the ensemble gives the labels of one
  block), diverged states labelled and kept, the clustering of touching cells, the
  choice of mapper, a block's arrays read back exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.integrate.kernels.devices import gpu_problem
from analysis.integrate.simulate import blow_up_limit
from analysis.model import System
from analysis.stability.attractors import DIVERGED, Box, basin_fractions, study_json
from analysis.stability.attractors.featurizing import (
    FEATURES_FROM,
    FeatureOptions,
    FeaturizingMapper,
    choose,
    merge_groups,
    periods,
    touching_groups,
)
from analysis.stability.attractors.sampling import Range
from analysis.stability.attractors.study import Block, Blocks, make_study
from analysis.sweeps.attractor_blocks import basins_to_file
from analysis.sweeps.executors import make_executor
from analysis.sweeps.store import PointStore

RPM = 30 / np.pi  # rpm per rad/s
DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
ROTOR_BOX = Box.parse(["x:-20e-6:30e-6", "y:-20e-6:20e-6"])
DUFFING_BOX = Box.parse(["x:-3:3", "vx:-3:3"])


@pytest.fixture(scope="module")
def rotor() -> System:
    return System.make("balanced-rotor", n_balls=8, radial_load=50.0, speed_rpm=8000.0)


def both(system: System, box: Box, samples: int, seed: int, **features):
    """The same initial states mapped by each mapper (on the CPU)."""
    return [basin_fractions(system, box, samples, seed=seed, mapper=m, device="cpu",
                            **features) for m in ("recurrence", "features")]


def by_class(ds) -> dict[str, tuple[float, float]]:
    return {a["class"]: (a["fraction"], a["fraction_stderr"])
            for a in study_json(ds)["attractors"] if a["id"] > 0}


def test_balanced_rotor_period1_and_period3_shares_agree_with_the_recurrence_mapper(rotor):
    recurrence, features = both(rotor, ROTOR_BOX, 200, seed=1)
    assert features.attrs["mapper"] == "features" and features.attrs["device"] == "cpu"
    ours, theirs = by_class(features), by_class(recurrence)
    assert set(ours) == set(theirs) == {"periodic-1", "periodic-3"}
    for name, (f, se) in ours.items():
        g, se_g = theirs[name]
        assert 0.1 < f < 0.9  # both basins are wide here
        assert abs(f - g) <= 2 * np.hypot(se, se_g), (name, f, g)
    # the same states: the same partition (labels may be numbered differently)
    pairs = set(zip(recurrence.label.values.tolist(), features.label.values.tolist(),
                    strict=True))
    assert len(pairs) == 2


def test_duffing_two_attractors_both_mappers_agree():
    system = System.make("duffing", speed_rpm=1.40 * RPM, **DUFFING)
    recurrence, features = both(system, DUFFING_BOX, 120, seed=11)
    found = [a for a in study_json(features)["attractors"] if a["id"] > 0]
    assert len(found) == 2 and all(a["class"] == "periodic-1" for a in found)
    small, large = sorted(a["amplitude"]["x"] for a in found)
    assert small < 0.5 < 1.5 < large  # the two orbits of the resonance
    a, b = recurrence.label.values, features.label.values
    same = max(np.mean(a == b), np.mean(a == 3 - b))  # ids 1, 2 in either order
    assert same >= 0.98


def test_blocks_are_merged_as_one(rotor):
    states = ROTOR_BOX.sample(rotor, 90, np.random.default_rng(5))
    whole = make_study(rotor, 90, mapper="features", device="cpu")
    cut = make_study(rotor, 90, mapper="features", device="cpu", block=25,
                     scale=whole.scale)
    one = whole.find(states)
    four = cut.find(states, blocks=Blocks(25))
    assert len(one.attractors) == len(four.attractors) == 2
    np.testing.assert_array_equal(one.labels, four.labels)


def test_a_diverged_state_is_labelled_and_kept(rotor):
    limit = blow_up_limit(rotor.model, dict(rotor.parameters))
    states = np.tile(rotor.state, (3, 1))
    states[1, 0] = 3 * limit  # beyond the blow-up bound
    study = make_study(rotor, 3, mapper="features", device="cpu")
    mapper = FeaturizingMapper(study.map, study.scale, FeatureOptions(transient=20,
                                                                       sections=24))
    labels = mapper.map(states)
    assert labels[1] == DIVERGED
    assert labels[0] == labels[2] == 1


def test_touching_cells_are_one_cluster_far_ones_are_not():
    rng = np.random.default_rng(0)
    a = rng.integers(0, 3, size=(200, 4))  # a blob of touching cells
    b = rng.integers(0, 3, size=(200, 4)) + np.array([10, 0, 0, 0])  # another, far
    chain = np.array([[3, 1, 1, 1], [4, 1, 1, 1]])  # joined to a, not to b
    groups = touching_groups(np.concatenate([b, a, chain]))
    assert groups[0] == 0  # numbered in the order of first appearance
    assert set(groups[:200]) == {0} and set(groups[200:]) == {1}
    # clusters of different blocks: merged when their cells touch
    assert merge_groups([a[:5], b[:5], a[5:9] + np.array([1, 0, 0, 0]), b[:3] + 5]).tolist() == \
        [0, 1, 0, 2]


def test_periods_of_section_points():
    k = np.arange(48)
    one = np.zeros((48, 2))
    three = np.stack([np.cos(2 * np.pi * k / 3), np.sin(2 * np.pi * k / 3)], axis=1)
    drift = np.stack([np.cos(0.3 * k), np.sin(0.3 * k)], axis=1)  # not periodic
    scale = type("S", (), {"size": np.ones(2)})()
    assert periods(np.stack([one, three, drift]), scale, FeatureOptions()).tolist() == \
        [1, 3, 0]


def test_the_mapper_is_chosen_by_size_and_device():
    assert choose("auto", "cpu", FEATURES_FROM - 1) == "recurrence"
    assert choose("auto", "cpu", FEATURES_FROM) == "features"
    assert choose("auto", "gpu", 10) == "features"
    assert choose("recurrence", "cpu", 10**7) == "recurrence"
    with pytest.raises(InputError, match=r"^mapper: the recurrence mapper runs on the CPU"):
        choose("recurrence", "gpu", 10)
    with pytest.raises(InputError, match=r"^mapper: must be one of"):
        choose("kmeans", "cpu", 10)
    with pytest.raises(InputError, match=r"^sections: "):
        FeatureOptions(sections=10, max_period=12)


def test_a_feature_block_reads_back_exactly(rotor):
    study = make_study(rotor, 30, mapper="features", device="cpu")
    states = ROTOR_BOX.sample(rotor, 30, np.random.default_rng(2))
    block = study.map_block(states)
    again = Block.from_arrays(block.arrays())
    assert again.cell_width == 2 * rotor.n_state
    np.testing.assert_array_equal(again.labels, block.labels)
    assert [f.cells for f in again.found] == [f.cells for f in block.found]
    np.testing.assert_array_equal(np.array(again.found[0].points),
                                  np.array(block.found[0].points))


def test_a_kernel_that_cannot_be_built_is_refused_on_the_gpu_and_replaced_on_the_cpu(
        rotor, monkeypatch):
    import analysis.integrate.kernels as kernels
    from analysis.stability.attractors import featurizing

    def unbuildable(*args, **kwargs):
        raise kernels.Unsupported("operation 'erf' has no C form")

    monkeypatch.setattr(kernels, "run_members", unbuildable)
    monkeypatch.setattr(kernels, "check_fits", lambda *args, **kwargs: None)
    monkeypatch.setattr(kernels.devices, "gpu_problem", lambda: None)  # a GPU is there
    study = make_study(rotor, 10, mapper="recurrence", device="cpu")
    with pytest.raises(InputError, match=r"^device gpu: the member kernel of model "
                                         r"'balanced-rotor' with N_b [\d, ]+ cannot be "
                                         r"built: operation"):
        featurizing.recorder(study.map, "gpu", 10, FeatureOptions())
    assert featurizing.recorder(study.map, "cpu", 10, FeatureOptions()) is \
        featurizing.map_record


class Interrupted(Exception):
    pass


def test_feature_blocks_stream_into_the_store_and_resume(monkeypatch, tmp_path):
    """Blocks go to the store one by one (the executor's workers are not used: the kernel
    takes the cores); a run stopped after the first block resumes to the same file."""
    import xarray as xr

    system = System.make("duffing", speed_rpm=1.40 * RPM, **DUFFING)
    x, y = Range("x", -3.0, 3.0, 8), Range("vx", -3.0, 3.0, 8)
    how = dict(block=20, mapper="features", device="cpu",
               feature_options=FeatureOptions(transient=100, sections=24))
    reference = basins_to_file(system, x, y, tmp_path / "r.nc", **how)
    assert reference.attrs["mapper"] == "features" and reference.sizes["attractor"] == 2
    save, saved = PointStore.save, []

    def stop(self, key, values):
        save(self, key, values)
        saved.append(key)
        raise Interrupted(key)

    with monkeypatch.context() as patch:
        patch.setattr(PointStore, "save", stop)
        with pytest.raises(Interrupted):
            basins_to_file(system, x, y, tmp_path / "b.nc", **how,
                           executor=make_executor("processes", 2))
    assert len(list((tmp_path / "b.nc.parts").glob("*.npz"))) == 1
    mapped = []
    real = FeaturizingMapper.map

    def count(self, states, *args, **kwargs):
        mapped.append(len(states))
        return real(self, states, *args, **kwargs)

    monkeypatch.setattr(FeaturizingMapper, "map", count)
    again = basins_to_file(system, x, y, tmp_path / "b.nc", **how)
    assert mapped == [20, 20, 4]  # the stored block was not mapped again
    xr.testing.assert_identical(again.drop_attrs(), reference.drop_attrs())
    np.testing.assert_array_equal(again.basin.values, reference.basin.values)


GPU_PROBLEM = gpu_problem()


@pytest.mark.skipif(GPU_PROBLEM is not None, reason=f"no GPU: {GPU_PROBLEM}")
def test_the_gpu_labels_states_as_the_cores_do(rotor):
    states = ROTOR_BOX.sample(rotor, 400, np.random.default_rng(7))
    cpu = make_study(rotor, 400, mapper="features", device="cpu")
    gpu = make_study(rotor, 400, mapper="features", device="gpu", scale=cpu.scale)
    a, b = cpu.find(states), gpu.find(states)
    assert [x.nature for x in a.attractors] == [x.nature for x in b.attractors]
    np.testing.assert_array_equal(a.labels, b.labels)


def test_distinct_rows_are_numpys_by_a_key_or_row_wise_past_2_to_the_62():
    from analysis.stability.attractors.featurizing import distinct_rows

    rng = np.random.default_rng(4)
    small = rng.integers(-5, 5, size=(500, 8))
    wide = np.array([[0] * 8, [2**40, 5, 2**30, 0, 0, 0, 0, 1], [0] * 8])
    for cells in (small, wide):
        unique, inverse = distinct_rows(cells)
        expect, expect_inverse = np.unique(cells, axis=0, return_inverse=True)
        np.testing.assert_array_equal(unique, expect)
        np.testing.assert_array_equal(inverse, expect_inverse.ravel())


def test_continuation_matches_across_values_alike_with_either_mapper():
    """Matching across parameter values is the same with the featurizing mapper (issue 33,
    item 5): the Duffing resonance at ω = 1.3, 1.4, 1.5 rad/s continued with each mapper
    from the same random states; the same attractor ids present at each value, of the same
    class, with fractions within two standard errors of each other."""
    from analysis.stability.attractors import global_continuation

    system = System.make("duffing", speed_rpm=1.3 * RPM, **DUFFING)
    values = [1.3 * RPM, 1.4 * RPM, 1.5 * RPM]
    found = {m: global_continuation(system, "speed_rpm", values, DUFFING_BOX, 60, seed=3,
                                    mapper=m, device="cpu")
             for m in ("recurrence", "features")}
    rec, feat = found["recurrence"], found["features"]
    assert feat.attrs["mapper"] == "features"
    assert rec.attractor.values.tolist() == feat.attractor.values.tolist()
    np.testing.assert_array_equal(rec.present.values, feat.present.values)
    assert rec.present.sum() >= 4, "both orbits of the resonance are followed"
    assert (rec.nature.values == feat.nature.values).all(), "of the same class"
    for a in rec.attractor.values:
        for k in range(len(values)):
            if not bool(rec.present.sel(attractor=a).isel(value=k)):
                continue
            f, g = (float(d.fraction.sel(attractor=a).isel(value=k)) for d in (rec, feat))
            se = np.hypot(*(float(d.fraction_stderr.sel(attractor=a).isel(value=k))
                            for d in (rec, feat)))
            assert abs(f - g) <= 2 * se + 1e-12, (int(a), k, f, g)
