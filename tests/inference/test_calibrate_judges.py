"""Issue 41: a calibration judges its own answer. A row whose class is decided by a λ1
interval that reaches zero is reported as doubtful and not counted as matched (as
``classify_section`` itself says such a motion is "≈ 0 (the interval contains 0)"); the
share of the prior says how many matches are doubtful; the posterior says how far it
narrowed each prior and how many sets it is worth (Kish's effective sample size); a run
too small to conclude says so, in the text and in the JSON, and ``--json`` keeps the
progress counter on stderr."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from analysis.inference.abc import Calibration, Options, Round, doubtful_match, row_marks
from analysis.inference.priors import parse_prior
from analysis.inference.simulate import MemberRow
from analysis.inference.targets import load_target
from analysis.model import load_model
from tests.inference.test_calibrate_cli import TINY

MODEL = load_model("vakharia2015")
TARGET = load_target("paper-table2", MODEL)
N_B7 = next(row for row in TARGET.rows if row.balls == 7)  # the paper: quasi-periodic


def member(nature: str, lam: float, ci: float) -> MemberRow:
    return MemberRow(nature, lam, ci, {}, {}, math.nan)


@pytest.mark.parametrize(("nature", "lam", "ci", "matched", "unsure"), [
    ("quasi-periodic", 16.0, 26.0, False, True),   # the 8-24 ± 13-39 1/s at N_b 7
    ("quasi-periodic", -0.5, 3.0, False, True),
    ("quasi-periodic", -40.0, 10.0, True, False),  # a stable torus, firmly
    ("chaotic", 50.0, 16.0, False, False),          # firm, and not what the row asks
    ("periodic-1", 5.0, 30.0, False, False),        # decided by its section, not by λ1
])
def test_a_class_decided_by_an_interval_through_zero_is_doubtful(nature, lam, ci, matched,
                                                                 unsure):
    result = member(nature, lam, ci)
    assert row_marks(N_B7, result)[0] is matched
    assert doubtful_match(N_B7, result) is unsure


def test_a_class_that_changes_with_the_step_halved_is_doubtful():
    firm = member("quasi-periodic", -40.0, 10.0)
    assert row_marks(N_B7, firm)[0] and not doubtful_match(N_B7, firm)
    same = MemberRow("quasi-periodic", -40.0, 10.0, {}, {}, math.nan, "quasi-periodic")
    assert row_marks(N_B7, same)[0]
    flips = MemberRow("quasi-periodic", -40.0, 10.0, {}, {}, math.nan, "chaotic")
    assert not row_marks(N_B7, flips)[0] and doubtful_match(N_B7, flips)


def calibration(values: np.ndarray, weights: np.ndarray, matched: np.ndarray,
                unsure: np.ndarray) -> Calibration:
    """A finished one-round calibration of damping (log prior 10-1000 N s/m) by hand."""
    n = len(values)
    first = Round(0, np.zeros((n, 1)), values[:, None], [[] for _ in range(n)],
                  np.zeros(n), matched, matched, 0.0, weights / weights.sum(), unsure)
    return Calibration(MODEL, TARGET, (parse_prior("damping:10:1000:log"),), Options(), [first])


def test_narrowing_and_effective_sample_size():
    rng = np.random.default_rng(1)
    wide = 10 ** rng.uniform(1, 3, 4000)  # the whole prior
    cal = calibration(wide, np.ones(4000), np.full(4000, 5), np.zeros(4000, int))
    assert cal.effective_sample_size() == pytest.approx(4000)
    assert cal.narrowing()["damping"] == pytest.approx(1.0, abs=0.03)
    assert "narrower" in cal.verdict()
    narrow = 10 ** rng.uniform(1.9, 2.1, 4000)  # a tenth of the prior's log width
    weights = np.r_[np.ones(2000), 3 * np.ones(2000)]
    cal = calibration(narrow, weights, np.full(4000, 5), np.zeros(4000, int))
    assert cal.narrowing()["damping"] == pytest.approx(0.1, abs=0.01)
    assert cal.effective_sample_size() == pytest.approx(1 / np.sum((weights / 8000) ** 2))
    assert cal.verdict() == ""
    cal.posterior.epsilon = 2.5  # the posterior's sets miss 2.5 rows, the best none
    assert "more than a row above the best" in cal.verdict()


def test_share_of_prior_counts_doubtful_matches_apart():
    matched = np.array([4, 3, 3, 2, 4])
    unsure = np.array([0, 1, 0, 2, 1])
    cal = calibration(np.full(5, 100.0), np.ones(5), matched, unsure)
    assert cal.share_of_prior()[4] == pytest.approx(2 / 5)
    doubtful = cal.doubtful_share()
    assert doubtful[4] == pytest.approx(2 / 5)  # 3 + 1 and 2 + 2 reach four rows
    assert doubtful[5] == pytest.approx(1 / 5)  # 4 + 1
    assert doubtful[3] == pytest.approx(1 / 5)  # 2 + 2 passes three as well


def test_a_tiny_calibration_says_it_cannot_conclude(cli, tmp_path):
    args = ("calibrate", "vakharia2015", "--target", "paper-table2", "--prior",
            "damping:100:1000:log", *TINY)
    res = cli(*args, "-o", str(tmp_path / "a.nc"), "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["verdict"] and "effective sample size" in doc["verdict"]
    assert set(doc["narrowing"]) == {"damping"} and doc["effective_sample_size"] <= 4
    assert list(doc["doubtful_share"]) == list(doc["share_of_prior"])
    check = doc["halved_step_check"]
    assert check["rows_checked"] > 0 and 0 <= check["rows_changed"] <= check["rows_checked"]
    best = [row for b in doc["best"] for row in b["rows"] if row["class_at_half_step"]]
    assert len(best) >= 1 and all(r["class_ok"] != r["doubtful"] or not r["class_ok"]
                                  for r in best)
    for b in doc["best"]:
        assert b["matched"] == sum(r["class_ok"] for r in b["rows"])
    assert "calibrate: " in res.stderr and " runs/s" in res.stderr, "progress under --json"
    text = cli(*args, "-o", str(tmp_path / "b.nc"))
    assert text.returncode == 0, text.stderr
    assert "too small to conclude: effective sample size" in text.stdout
    assert "of the prior's width" in text.stdout and "effective sample size" in text.stdout
    assert "step halved at the best sets: " in text.stdout


def test_the_suggested_dt_is_accepted_at_every_corner():
    """Issue 41: the hint said --dt 0.0002, then refused it at a corner of the prior ("got
    0.00015000000000000001": the per-revolution step it makes at 5000 rpm). The hint now
    passes the same check, at the value the user types."""
    from analysis.errors import InputError
    from analysis.inference.abc import calibrate_cost, prepare
    from analysis.inference.simulate import RunSettings

    priors = ["rotor_mass:0.1:10:log", "damping:10:3162:log",
              "contact_stiffness:3e9:2e10:log"]
    cost = calibrate_cost("vakharia2015", "paper-table2", priors, samples=2048, rounds=2)
    hint = [line for line in cost.lines() if line.startswith("hint: --dt ")]
    assert hint, cost.lines()
    typed = float(hint[0].split()[2])
    assert typed == cost.kernels.coarsest_dt == 5e-5
    prepare("vakharia2015", "paper-table2", priors, samples=8, rounds=1,
            settings=RunSettings(dt=typed))
    with pytest.raises(InputError, match=r"0\.00015000000000000001"):  # the old hint
        prepare("vakharia2015", "paper-table2", priors, samples=8, rounds=1,
                settings=RunSettings(dt=2e-4))
