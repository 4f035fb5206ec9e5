"""The one continuation engine with a family written in a few lines (the example of
docs/architecture.md, "Adding a branch family"): x² + λ² = r², whose branch folds at λ = r.

The engine must locate that fold (LP) by bisection, turn with the branch and stop where λ
leaves the range; an ``accept`` hook stops it with its reason in the status; the two
tangent methods give the same branch; ``ContinuedRange`` refuses a bad range in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from analysis.errors import InputError
from analysis.model import load_model
from analysis.stability.continuation import (
    BranchPoint,
    ContinuationOptions,
    ContinuedRange,
    Hooks,
    Newton,
    start_at,
    trace,
)


@dataclass
class RoundBranch:
    """x² + λ² = r²: unknowns w = (x, λ), one equation; a fold at λ = ±r."""

    radius: float
    param_name = "lam"
    tangent_method = "svd"
    s_lam = 1.0

    def residual(self, w: np.ndarray):
        x, lam = w
        return (np.array([x * x + lam * lam - self.radius ** 2]),
                np.array([[2 * x, 2 * lam]]), np.zeros((0, 0)))

    def point(self, corrected: Newton, tangent: np.ndarray) -> BranchPoint:
        w = corrected.w
        return BranchPoint(lam=w[-1], z0=w[:-1], multipliers=np.zeros(0),
                           monodromy=corrected.mono, tangent=tangent, amplitude=abs(w[0]),
                           newton_iterations=corrected.iterations)

    def unknowns(self, point: BranchPoint) -> np.ndarray:
        return np.concatenate([point.z0, [point.lam]])

    def value(self, point: BranchPoint) -> float:
        return point.lam

    def describe(self, point: BranchPoint) -> str:
        return f"lam = {point.lam:.4g}"


def _first(prob: RoundBranch) -> BranchPoint:
    first = start_at(prob, np.array([prob.radius, 0.0]), +1.0, 1e-10)
    first.ds = 0.05
    return first


@pytest.mark.parametrize("method", ["svd", "bordered"])
def test_the_engine_turns_at_the_fold_and_stops_at_the_range(method):
    prob = RoundBranch(2.0)
    out = trace(prob, _first(prob), 3.0, ContinuationOptions(ds_max=0.2, tangent=method))
    lam = np.array([p.lam for p in out.points])
    x = np.array([p.z0[0] for p in out.points])
    assert out.status == "reached the end of the range" and out.ended == "end"
    assert np.allclose(x ** 2 + lam ** 2, 4.0, atol=1e-9)
    folds = [p for p in out.points if p.special == "LP"]
    assert len(folds) == 1 and folds[0].lam == pytest.approx(2.0, abs=1e-6)
    assert lam[-1] < 0 < x[0] and x[-2] < 0  # went round the fold, left the range below
    assert out.refused == 0 and out.last_tried is None


def test_the_tangent_methods_give_the_same_branch():
    prob = RoundBranch(1.0)
    a, b = (trace(prob, _first(prob), 3.0, ContinuationOptions(ds_max=0.1, tangent=m))
            for m in ("svd", "bordered"))
    assert len(a.points) == len(b.points)
    for p, q in zip(a.points, b.points, strict=True):
        assert p.lam == pytest.approx(q.lam, abs=1e-9)
        assert np.allclose(p.tangent, q.tangent, atol=1e-9)


def test_an_accept_hook_stops_the_branch_with_its_reason():
    prob = RoundBranch(1.0)
    out = trace(prob, _first(prob), 3.0, ContinuationOptions(ds_max=0.1),
                hooks=Hooks(accept=lambda p: "x fell below 0.5" if p.z0[0] < 0.5 else None))
    assert out.ended == "accept"
    assert out.status.startswith("stopped at lam = ") and out.status.endswith(
        ": x fell below 0.5")
    assert min(p.z0[0] for p in out.points) >= 0.5


def test_max_points_and_ds_min_end_with_their_status():
    prob = RoundBranch(1.0)
    out = trace(prob, _first(prob), 3.0, ContinuationOptions(max_points=3))
    assert len(out.points) == 3 and out.status == "stopped after max_points = 3"
    never = Hooks(found_between=lambda a, b: "refused by the test")
    out = trace(prob, _first(prob), 3.0, ContinuationOptions(ds_min=0.01), hooks=never)
    assert out.ended == "refused" and out.refused > 0 and out.last_tried is not None
    assert "refused every step down to ds_min = 0.01 from lam = 0" in out.status
    assert "(refused by the test)" in out.status


@pytest.mark.parametrize(("param", "start", "stop", "message"), [
    ("sped", 1.0, 2.0, "param: 'sped' is not a parameter of 'balanced-rotor'; choose one of "),
    ("speed_rpm", 7000.0, 7000.0, "stop: must differ from start"),
    ("speed_rpm", 7000.0, float("nan"), "speed_rpm: must be in [0, 1e+06] rpm, got nan"),
    ("speed_rpm", 7000.0, -5.0, "speed_rpm: must be in [0, 1e+06] rpm, got -5.0"),
])
def test_the_range_is_checked_once_with_one_message_each(param, start, stop, message):
    with pytest.raises(InputError) as err:
        ContinuedRange.check(load_model("balanced-rotor"), param, start, stop)
    assert str(err.value).startswith(message)
    with pytest.raises(InputError, match=r"^stop: must be a finite number, got nan$"):
        ContinuedRange.finite_stop(float("nan"))
