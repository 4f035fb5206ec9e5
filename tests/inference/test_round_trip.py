"""A synthetic round trip of `calibrate`, CI-sized.

The target comes from an independent integrator written here: a plain NumPy RK4 of the
equations of `vakharia2015` (its MODEL.md) at a known (rotor_mass, damping) = (1 kg,
300 N·s/m), λ1 from a shadow trajectory (Benettin's two-trajectory method), classified
with the tool's class vocabulary (``classify_section``) and its lines named by
``find_peaks``. The calibration then runs on the member kernels with log priors a factor
of ten wide around the truth (truth/√10 to truth·√10). It must: put the truth inside the
90 % credible box; exclude a point far from the truth; narrow as rows are added.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.inference.abc import calibrate, discrepancy, row_marks
from analysis.inference.simulate import RunSettings, evaluate_row
from analysis.inference.targets import parse_target
from analysis.model import as_system, load_model
from analysis.provenance import completed_attrs, to_dataset
from analysis.signal.poincare import poincare_section
from analysis.signal.spectrum import find_peaks
from analysis.stability.classify import classify_section

pytestmark = pytest.mark.xdist_group(__name__)
"""This module's tests on one xdist worker (``--dist loadgroup``: tests/conftest.py), so its
module fixtures run once, not once per worker."""
TRUTH = {"rotor_mass": 1.0, "damping": 300.0}
N_BALLS = (6, 7, 8, 9, 10)
SETTINGS = RunSettings(transient_revolutions=30, revolutions=40)
PRIORS = [f"{name}:{value / math.sqrt(10):.6g}:{value * math.sqrt(10):.6g}:log"
          for name, value in TRUTH.items()]
FAR = {"rotor_mass": 0.33, "damping": 900.0}
"""A corner of the prior box: light and strongly damped."""


def numpy_records(values: dict, n_balls, transient_revs: int, revs: int, per_rev: int = 40):
    """Fixed-step RK4 of Vakharia's equations (MODEL.md of vakharia2015), every N_b and a
    shadow of each at once (balls padded and masked). Returns the sample times (s), the
    records (rows × samples × 4), λ1 and its 95 % half-width (1/s) per row."""
    v = values
    w = v["speed_rpm"] * np.pi / 30
    di, do = v["inner_race_diameter"], v["outer_race_diameter"]
    wc = np.pi * di * v["speed_rpm"] / (30 * (di + do))
    period = 2 * np.pi / w
    every = math.ceil(period / (per_rev * 1e-5) - 1e-9)
    h = period / (per_rev * every)
    nb = np.array(n_balls)
    rows, top = len(nb), nb.max()
    i = np.arange(top)
    phase = np.tile(2 * np.pi * i[None, :] / nb[:, None], (2, 1))
    mask = np.tile((i[None, :] < nb[:, None]).astype(float), (2, 1))
    mass, c, k, gap = v["rotor_mass"], v["damping"], v["contact_stiffness"], \
        v["radial_clearance"]

    def f(t, z):
        x, y, vx, vy = z.T
        th = phase + wc * t
        ct, st = np.cos(th), np.sin(th)
        q = k * np.maximum(x[:, None] * ct + y[:, None] * st - gap, 0.0) ** 1.5 * mask
        # Eq. 9's centrifugal force is subtracted from every ball: it cancels (S4)
        fx = -c * vx + v["radial_load"] + v["unbalance_force"] * np.cos(w * t) \
            - (q * ct).sum(1)
        fy = -c * vy + v["unbalance_force"] * np.sin(w * t) - (q * st).sum(1)
        return np.column_stack([vx, vy, fx / mass, fy / mass])

    def advance(z, step, count):
        for _ in range(count):
            t = step * h
            k1 = f(t, z)
            k2 = f(t + h / 2, z + h / 2 * k1)
            k3 = f(t + h / 2, z + h / 2 * k2)
            k4 = f(t + h, z + h * k3)
            z, step = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), step + 1
        return z, step

    z, step = advance(np.tile([1e-6, 1e-6, 0.0, 0.0], (2 * rows, 1)), 0,
                      transient_revs * per_rev * every)
    d0 = 1e-11
    z[rows:] = z[:rows]
    z[rows:, 0] += d0
    record = np.empty((rows, revs * per_rev, 4))
    logs = np.empty((rows, revs))
    times = np.empty(revs * per_rev)
    scale = np.array([1.0, 1.0, 1 / w, 1 / w])
    for r in range(revs):
        for j in range(per_rev):
            z, step = advance(z, step, every)
            record[:, r * per_rev + j] = z[:rows]
            times[r * per_rev + j] = step * h
        d = np.linalg.norm((z[rows:] - z[:rows]) * scale, axis=1)
        logs[:, r] = np.log(d / d0)
        z[rows:] = z[:rows] + (z[rows:] - z[:rows]) * (d0 / d)[:, None]
    lam = logs.sum(1) / (revs * period)
    batches = logs.reshape(rows, 10, -1).sum(2) / (period * revs / 10)
    ci = 2.262 * batches.std(1, ddof=1) / np.sqrt(10)
    return times, record, lam, ci, h, every


@pytest.fixture(scope="module")
def truth_rows():
    """The target rows of the truth: the class and the major y line at every N_b (x's
    major line is left out: at these points it changes with round-off)."""
    model = load_model("vakharia2015")
    values = model.parameters(TRUTH)
    times, record, lam, ci, h, every = numpy_records(values, N_BALLS,
                                                     SETTINGS.transient_revolutions,
                                                     SETTINGS.revolutions)
    rows = []
    for r, nb in enumerate(N_BALLS):
        system = as_system(model, nb, **TRUTH)
        attrs = completed_attrs(system, method="rk4", dt=h, save_every=every,
                                duration=float(times[-1]), transient=float(times[0]))
        run = to_dataset(times, record[r].T, attrs, model)
        ptp = {n: float(np.ptp(record[r][:, i])) for i, n in enumerate(model.state_names)}
        verdict = classify_section(poincare_section(run, "shaft"), ptp,
                                   lambda r=r: (lam[r], ci[r]))
        rows.append({"n_balls": nb, "class": verdict.nature,
                     "major": {"y": find_peaks(run, "y")[0].name}})
    return model, rows


def _target(model, rows):
    return parse_target({"name": "synthetic", "conditions": {"speed_rpm": 5000.0},
                         "rows": rows}, model)


@pytest.fixture(scope="module")
def calibrations(truth_rows):
    model, rows = truth_rows
    out = {}
    # "few": N_b = 8 alone, whose class is firm (λ1 49 ± 31 1/s); the truth's own classes
    # at N_b = 9 and 10 are doubtful (λ1 −15 ± 21, −15 ± 18: the interval reaches zero,
    # issue 41), so a row of them alone cannot be matched firmly and narrows nothing
    for label, chosen in (("few", rows[2:3]), ("all", rows)):
        out[label] = calibrate(model, _target(model, chosen), PRIORS, samples=32, rounds=2,
                               seed=1, quantile=0.3, settings=SETTINGS)
    return out


def test_truth_inside_the_90_percent_credible_box(calibrations):
    box = calibrations["all"].credible_interval(0.9)
    for name, value in TRUTH.items():
        lo, hi = box[name]
        assert lo <= value <= hi, (name, value, box[name])


def test_a_far_point_is_excluded(truth_rows, calibrations):
    model, _ = truth_rows
    cal = calibrations["all"]
    target = cal.target
    names = list(FAR)
    results = [evaluate_row(model, row, names, np.array([list(FAR.values())]), SETTINGS,
                            ("x", "y"))[0] for row in target.rows]
    marks = [row_marks(row, res) for row, res in zip(target.rows, results, strict=True)]
    n = len(target.rows)
    d = discrepancy(n - sum(k for k, _ in marks), n - sum(ln for _, ln in marks), n)
    assert d > cal.posterior.epsilon
    box = cal.credible_interval(0.9)
    assert any(not box[k][0] <= v <= box[k][1] for k, v in FAR.items())


def test_posterior_narrows_and_says_it_is_too_small(calibrations):
    """The five rows narrow the prior (damping's 90 % interval 0.70 of the prior's log
    width, measured). Whether they narrow it more than one row does is within the noise of
    32 sets × 2 rounds once doubtful rows no longer count (issue 41; log areas 3.29 and
    3.17, measured), and the calibration says so itself: its effective sample size (16-20)
    is too small to conclude."""
    for cal in calibrations.values():
        assert min(cal.narrowing().values()) < 0.8
        assert "effective sample size" in cal.verdict()
        assert cal.effective_sample_size() < 32
