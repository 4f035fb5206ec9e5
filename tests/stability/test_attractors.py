"""Every attractor, not one: the recurrence mapper, basins, basin fractions and global
continuation, against independent computations.

- Duffing (c = 0.1, k1 = 1, k3 = 0.5, F = 0.3): two periodic attractors at ω = 1.40 rad/s
  and one at 1.10 and 1.70; the basin fractions at 1.40 against a brute-force count (an RK4
  of the Duffing equation written here in NumPy, every initial state of a grid run for a
  fixed time and clustered by its end state); the two-attractor range of a global
  continuation against the folds of the project's pseudo-arclength continuation started on
  the attractors found.
- balanced-rotor (50 N, N_b = 8): the period-1/period-2 family and the period-3 orbit
  coexist between the period-3 branch's folds, and only the first outside them.
"""

from __future__ import annotations

import numpy as np
import pytest

from analysis.model import System
from analysis.stability.attractors import (
    DIVERGED,
    Box,
    MapperOptions,
    Range,
    basin_fractions,
    basins,
    existence,
    global_continuation,
    study_json,
)
from analysis.stability.attractors.continuation import continue_attractors
from analysis.stability.continuation import continue_from_orbit, special_points
from analysis.stability.periodic import shoot

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1, forcing_amplitude=0.3)
RPM = 30 / np.pi  # rpm per rad/s
DUFFING_BOX = Box.parse(["x:-3:3", "vx:-3:3"])
ROTOR = dict(radial_load=50.0)
ROTOR_BOX = Box.parse(["x:-20e-6:30e-6", "y:-20e-6:20e-6"])


def duffing(omega: float) -> System:
    return System.make("duffing", speed_rpm=omega * RPM, **DUFFING)


@pytest.mark.parametrize(("omega", "count"), [(1.10, 1), (1.40, 2), (1.70, 1)])
def test_duffing_has_two_periodic_attractors_between_its_folds_and_one_outside(omega, count):
    ds = basin_fractions(duffing(omega), DUFFING_BOX, 60, seed=3)
    found = [a for a in study_json(ds)["attractors"] if a["id"] > 0]
    assert len(found) == count
    assert all(a["class"] == "periodic-1" and a["period"] == 1 for a in found)
    assert all(a["lambda1"] + a["lambda1_ci95"] < 0 for a in found)  # stable
    assert sum(a["fraction"] for a in found) == pytest.approx(1.0)
    if count == 2:  # the two coexisting orbits of the resonance: small and large
        small, large = sorted(a["amplitude"]["x"] for a in found)
        assert small < 0.5 < 1.5 < large


def brute_force_end_states(states: np.ndarray, omega: float, periods: int) -> np.ndarray:
    """x'' + c x' + k1 x + k3 x³ = F cos(ω t), RK4 in NumPy for every state at once, for
    a whole number of forcing periods (400 steps each): the end states (x, vx)."""
    c, k1, k3, f = (DUFFING[k] for k in ("damping", "linear_stiffness", "cubic_stiffness",
                                         "forcing_amplitude"))
    h = 2 * np.pi / omega / 400

    def rhs(t, x, v):
        return v, f * np.cos(omega * t) - c * v - k1 * x - k3 * x ** 3

    x, v = states[:, 0].copy(), states[:, 2].copy()
    for k in range(400 * periods):
        t = k * h
        a1, b1 = rhs(t, x, v)
        a2, b2 = rhs(t + h / 2, x + h / 2 * a1, v + h / 2 * b1)
        a3, b3 = rhs(t + h / 2, x + h / 2 * a2, v + h / 2 * b2)
        a4, b4 = rhs(t + h, x + h * a3, v + h * b3)
        x += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        v += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
    return np.column_stack([x, v])


def test_duffing_basin_fractions_agree_with_a_brute_force_count():
    system = duffing(1.40)
    x, y = Range("x", -3, 3, 24), Range("vx", -3, 3, 24)
    grid = basins(system, x, y)
    gx, gy = np.meshgrid(x.points, y.points)
    states = np.zeros((gx.size, 4))
    states[:, 0], states[:, 2] = gx.ravel(), gy.ravel()
    ends = brute_force_end_states(states, 1.40, periods=150)
    # clustered by the end state: the nearest attractor's section point (x, vx)
    ids = grid.attractor.values[grid.attractor.values > 0]
    centres = grid.representative.sel(attractor=ids, state=["x", "vx"]).values
    nearest = ids[np.argmin(np.linalg.norm(ends[:, None, :] - centres[None], axis=2), axis=1)]
    assert np.max(np.min(np.linalg.norm(ends[:, None, :] - centres[None], axis=2), axis=1)) \
        < 0.05  # every brute-force run has settled on one of the two attractors
    labels = grid.basin.values.ravel()
    assert np.mean(labels == nearest) > 0.97  # cell by cell (boundary cells may differ)
    brute = {int(i): float(np.mean(nearest == i)) for i in ids}
    random = basin_fractions(system, DUFFING_BOX, 300, seed=11)
    for i, share in brute.items():
        # the same attractor in both studies: the one whose section point is closest
        rows = random.representative.sel(state=["x", "vx"]).values
        j = int(random.attractor.values[np.argmin(np.linalg.norm(
            rows - grid.representative.sel(attractor=i, state=["x", "vx"]).values, axis=1))])
        f, se = float(random.fraction.sel(attractor=j)), float(random.fraction_stderr.sel(
            attractor=j))
        assert abs(f - share) <= 2 * se, (i, f, se, share)  # within 2 standard errors


def fold_next_to(system: System, period: str, representative: np.ndarray, stop: float,
                 dt: float | None = None) -> float:
    """The fold (LP) of the branch of the periodic orbit through ``representative``,
    continued by the project's pseudo-arclength continuation towards ``stop``."""
    orbit = shoot(system, None, period, representative, 0.0, dt=dt)
    assert orbit.converged and orbit.stability == "stable"
    branch = continue_from_orbit(orbit, param="speed_rpm", stop=stop, max_points=60, dt=dt)
    folds = [p for p in special_points(branch) if p["kind"] == "LP"]
    assert folds, "the branch turns before reaching the next grid value"
    return float(folds[0]["value"])


def coexistence_edges(steps, extra_id: int) -> tuple[int, int]:
    """Indices of the first and last values at which attractor ``extra_id`` exists."""
    where = [k for k, s in enumerate(steps) if extra_id in s.ids.values()]
    return where[0], where[-1]


def test_duffing_global_continuation_two_attractors_between_the_folds():
    omegas = np.round(np.arange(1.10, 1.701, 0.05), 2)
    steps = continue_attractors(duffing(1.1), "speed_rpm", omegas * RPM, DUFFING_BOX, 40)
    counts = [len(s.result.attractors) for s in steps]
    assert set(counts) == {1, 2}
    first_two, last_two = counts.index(2), len(counts) - 1 - counts[::-1].index(2)
    assert all(c == 2 for c in counts[first_two:last_two + 1])
    upper = steps[0].ids[steps[0].result.attractors[0].id]  # the large orbit at 1.10
    assert all(upper in s.ids.values() for s in steps[:last_two + 1])  # keeps its id
    # the folds of the two branches, continued from the attractors at the range's edges
    step = 0.05 * RPM
    low, high = steps[first_two], steps[last_two]
    lower_att = next(a for g, a in low.attractors() if g != upper)
    upper_att = next(a for g, a in high.attractors() if g == upper)
    fold_low = fold_next_to(low.study.system, "shaft", lower_att.representative,
                            low.value - step, dt=0.01)
    fold_high = fold_next_to(high.study.system, "shaft", upper_att.representative,
                             high.value + step, dt=0.01)
    assert low.value - step < fold_low < low.value  # to one grid step
    assert high.value < fold_high < high.value + step
    assert fold_low / RPM == pytest.approx(1.2616, abs=1e-3)  # docs/stability.md
    assert fold_high / RPM == pytest.approx(1.5556, abs=1e-3)


@pytest.mark.slow
def test_balanced_rotor_period3_coexists_between_its_folds():
    rpms = np.arange(7800.0, 8500.1, 50.0)
    system = System.make("balanced-rotor", n_balls=8, **ROTOR)
    ds = global_continuation(system, "speed_rpm", rpms, ROTOR_BOX, 16)
    ranges = existence(ds)
    family = next(i for i, (lo, hi) in ranges.items() if (lo, hi) == (7800.0, 8500.0))
    natures = {str(n) for n in ds.nature.sel(attractor=family).values}
    assert natures == {"periodic-1", "periodic-2"}  # the period doublings at 8142, 8342 rpm
    three = [i for i in ranges if i != family]
    assert len(three) == 1
    assert {str(n) for n in ds.nature.sel(attractor=three[0]).values if str(n)} == \
        {"periodic-3"}
    low, high = ranges[three[0]]
    assert (low, high) == (7900.0, 8400.0)
    for value, stop in ((low, low - 50.0), (high, high + 50.0)):
        here = system.replace(speed_rpm=value)
        z = ds.representative.sel(value=value, attractor=three[0]).values
        fold = fold_next_to(here, "vc:3", z, stop)
        assert min(value, stop) < fold < max(value, stop)  # to one grid step
    assert (DIVERGED not in ds.attractor.values
            or not ds.present.sel(attractor=DIVERGED).any())


def test_mapper_options_are_checked():
    with pytest.raises(ValueError, match="revisits: must be a whole number >= 1"):
        MapperOptions(revisits=0)
    with pytest.raises(ValueError, match="max_periods: must exceed revisits"):
        MapperOptions(revisits=50, max_periods=40)
