"""Normal forms at the special points of shooting branches, against simulation.

The Duffing oscillator (smooth): its period doublings get flip coefficients by AD of the
period map, supercritical, and the predicted period-2 amplitude √(β/c) matches the branch
that branch switching finds, within 10 % next to the point. The balanced rotor (50 N,
N_b 8): its balls enter and leave contact along every orbit, so both doublings (near 8142
and 8342 rpm) are flagged non-smooth, with no coefficient, their criticality taken from the
period-2 orbit solved next to each (supercritical); simulation just past each agrees (a
small stable period-2 orbit growing as the square root of the distance) and shows what the
flag protects against: the AD coefficient of the discrete map says subcritical."""

from __future__ import annotations

import math

import numpy as np
import pytest

from analysis.integrate.flow import orbit_states
from analysis.stability.continuation import branch_summary, continue_orbits, switch_and_continue
from analysis.stability.continuation.dataset import special_point_notes
from analysis.stability.continuation.normal_form import orbit_criticality, period_map
from analysis.stability.continuation.problem import BranchPoint
from analysis.stability.continuation.shooting import _problem_of_branch
from analysis.stability.normal_forms import amplitude, normal_form, transversality

DUFFING = dict(period="shaft", dt=0.01, settle=200, linear_stiffness=1, cubic_stiffness=1,
               damping=0.2, forcing_amplitude=20)
"""The Duffing oscillator of docs/stability.md's period-doubling bubble (PDs at 11.55 and
13.59 rpm, i.e. ω = 1.209 and 1.423 rad/s)."""


@pytest.fixture(scope="module")
def duffing():
    return continue_orbits("duffing", param="speed_rpm", start=11.46, stop=14.32, **DUFFING)


@pytest.fixture(scope="module")
def rotor():
    return continue_orbits("balanced-rotor", 8, param="speed_rpm", start=8000.0, stop=8500.0,
                           ds_max=0.1, radial_load=50.0)


def _sections(prob, z, lam, periods):
    """The states at the section after each of ``periods`` periods from ``z`` at ``lam``
    (plain simulation with the branch's RK4 steps)."""
    run = orbit_states(prob.model, prob.structure, prob.period, prob.n_steps)
    p = prob.p(lam)
    out = np.empty((periods, z.size))
    for k in range(periods):
        z = np.asarray(run(z, prob.t0, p))[:, -1]
        out[k] = z
    return out


def _at(branch, k):
    lam = float(branch.speed_rpm.values[k])
    return lam, _problem_of_branch(branch, lam, lam + 1.0, None)


def test_duffing_doublings_are_supercritical_with_the_flip_coefficient_stored(duffing):
    pd = np.nonzero(duffing.special.values == "PD")[0]
    assert len(pd) == 2
    assert list(duffing.criticality.values[pd]) == ["supercritical", "supercritical"]
    coefficients = duffing.normal_form_coefficient.values[pd]
    assert np.all(coefficients > 0)
    summary = branch_summary(duffing)
    forms = [p["normal_form"] for p in summary["special_points"] if p["kind"] == "PD"]
    assert [f["coefficient"] for f in forms] == coefficients.tolist()
    assert {f["criticality"] for f in forms} == {"supercritical"}
    assert "flip coefficient c" in special_point_notes(duffing)[0]
    assert np.isnan(duffing.normal_form_coefficient.values[duffing.special.values == ""]).all()


def test_duffing_second_doubling_by_simulation_just_past_it(duffing):
    """Below 13.59 rpm the period-1 orbit is unstable: from next to it (0.6 × the predicted
    amplitude), the simulation settles on a period-2 orbit whose amplitude ⟨p, z₁ − z₂⟩/2
    is √(β/c), within 10 % at 0.01 rpm (measured 1 %)."""
    k = int(np.nonzero(duffing.special.values == "PD")[0][1])
    lam, prob = _at(duffing, k)
    zs, p = duffing.z0.values[k] / prob.s_z, prob.p(lam)
    nf = normal_form(period_map(prob), zs, p, kind="PD")
    rate = transversality(period_map(prob), zs, p, nf, prob.param_index)
    assert nf.coefficient == pytest.approx(duffing.normal_form_coefficient.values[k], rel=1e-9)
    assert rate < 0  # unstable below the point
    dl = -0.01  # start at 0.6 × the predicted amplitude, along the eigenvector
    start = duffing.z0.values[k] + 0.6 * amplitude(nf, rate * dl) * nf.q * prob.s_z
    z = _sections(prob, start, lam + dl, 1500)
    eta = abs(nf.p @ ((z[-1] - z[-2]) / prob.s_z)) / 2
    assert eta == pytest.approx(amplitude(nf, rate * dl), rel=0.1)
    assert abs(nf.p @ ((z[-3] - z[-1]) / prob.s_z)) < 1e-3 * eta  # period 2, settled


def test_duffing_predicted_amplitude_matches_the_switched_branch(duffing):
    """The period-2 branch that branch switching finds at the first PD: its amplitude
    ⟨p, z − P(z)⟩/2 (P the period map) against √(β/c) at its points within 0.05 rpm of
    the PD: within 10 %, the gap closing towards the point. Measured: 1.5 % at 0.014 rpm, 3.4 % at
    0.032 rpm."""
    k = int(np.nonzero(duffing.special.values == "PD")[0][0])
    lam, prob = _at(duffing, k)
    P = period_map(prob)
    zs, p = duffing.z0.values[k] / prob.s_z, prob.p(lam)
    nf = normal_form(P, zs, p, kind="PD")
    rate = transversality(P, zs, p, nf, prob.param_index)
    switched = switch_and_continue(duffing, "PD", point=k, stop=11.7, offset=0.005)
    assert switched.ok, switched.message
    branch = switched.branch
    gaps = []
    for j in range(branch.sizes["point"]):
        l2 = float(branch.speed_rpm.values[j])
        if abs(l2 - lam) > 0.05:
            break
        za = branch.z0.values[j] / prob.s_z
        eta = abs(nf.p @ (za - np.asarray(P(za, prob.p(l2))).ravel())) / 2
        gaps.append(eta / amplitude(nf, rate * (l2 - lam)) - 1)
    assert len(gaps) >= 2
    assert max(abs(g) for g in gaps) < 0.1
    assert abs(gaps[0]) <= abs(gaps[-1])


def test_rotor_doublings_are_flagged_nonsmooth(rotor):
    pd = np.nonzero(rotor.special.values == "PD")[0]
    speeds = rotor.speed_rpm.values[pd]
    assert len(pd) == 2 and abs(speeds[0] - 8142) < 2 and abs(speeds[1] - 8342) < 2
    # no coefficient; the criticality from the period-2 orbit solved next to each point,
    # which the simulations of the next test confirm
    assert list(rotor.criticality.values[pd]) == ["nonsmooth supercritical"] * 2
    assert np.isnan(rotor.normal_form_coefficient.values[pd]).all()
    forms = [p["normal_form"] for p in branch_summary(rotor)["special_points"]]
    assert forms == [{"coefficient": None, "criticality": "supercritical", "nonsmooth": True,
                      "criticality_from": "period-2 orbit"}] * 2
    assert special_point_notes(rotor)[0].endswith("supercritical by its period-2 orbit")


def test_period_two_orbit_criticality_agrees_with_the_normal_form_where_smooth(duffing):
    """``orbit_criticality`` (what non-smooth points get) on the smooth Duffing doublings:
    the same verdict as the flip coefficient's sign."""
    for k in np.nonzero(duffing.special.values == "PD")[0]:
        lam, prob = _at(duffing, int(k))
        point = BranchPoint(lam, duffing.z0.values[k], np.zeros(0), np.zeros((0, 0)),
                            np.zeros(0), 0.0, "PD")
        assert orbit_criticality(prob, point) == duffing.criticality.values[k]


@pytest.mark.parametrize("which", [0, 1])
def test_rotor_doublings_are_supercritical_by_simulation(rotor, which):
    """Just past each PD (1 and 3 rpm into the unstable interval 8142–8342 rpm) the
    simulation from next to the period-1 orbit settles on a small period-2 orbit whose
    amplitude grows as √(distance) (ratio √3 within 10 %): supercritical. Just before
    (2 rpm on the stable side) the perturbation dies out. The AD flip coefficient of the
    discrete map is negative there (measured −5.1e4 and −2.1e4), the effective one from
    the amplitude positive (about +1.9e4): hence the non-smooth flag."""
    k = int(np.nonzero(rotor.special.values == "PD")[0][which])
    lam, prob = _at(rotor, k)
    inside = 1.0 if which == 0 else -1.0
    z0 = rotor.z0.values[k]
    etas = []
    for dl in (1.0, 3.0):
        z = _sections(prob, z0 * (1 + 1e-3), lam + inside * dl, 2500)
        half = np.abs((z[-1] - z[-2]) / prob.s_z).max() / 2
        assert np.abs((z[-3] - z[-1]) / prob.s_z).max() < 1e-3 * half  # period 2, settled
        etas.append(half)
    assert 1e-4 < etas[0] < 1e-3  # small: a fraction of a nanometre to a few
    assert etas[1] / etas[0] == pytest.approx(math.sqrt(3), rel=0.1)
    z = _sections(prob, z0 * (1 + 1e-3), lam - inside * 2.0, 1500)
    first, last = (np.abs((z[j] - z[j - 1]) / prob.s_z).max() for j in (1, -1))
    assert last < 0.01 * first and last < 0.01 * etas[0]
    zs = z0 / prob.s_z
    nf = normal_form(period_map(prob), zs, prob.p(lam), kind="PD")
    rate = transversality(period_map(prob), zs, prob.p(lam), nf, prob.param_index)
    assert nf.coefficient < 0 < rate * inside  # the AD coefficient: wrong sign


def test_branch_figure_marks_subcritical_and_nonsmooth_points_apart(duffing, rotor):
    from matplotlib.colors import to_rgba

    from analysis.reports.plots import branch_figure

    def pd_markers(branch):
        ax = branch_figure([branch]).axes[0]
        return [(to_rgba(line.get_color()), line.get_markerfacecolor())
                for line in ax.lines if line.get_marker() == "D" and len(line.get_xdata())]

    assert {c for c, _ in pd_markers(duffing)} == {to_rgba("k")}
    marked = duffing.copy()
    crit = marked.criticality.values.copy()
    crit[np.nonzero(marked.special.values == "PD")[0][0]] = "subcritical"
    marked["criticality"] = ("point", crit)
    assert sorted(c for c, _ in pd_markers(marked)) == sorted([to_rgba("k"), to_rgba("red")])
    assert {c for c, _ in pd_markers(rotor)} == {to_rgba("0.5")}


def test_pd_curve_carries_the_flip_coefficient_and_marks_no_false_gpd(duffing):
    """The first Duffing PD followed in the forcing amplitude (20 → 26 N): the test
    function GPD is the flip coefficient of the period map at each curve point, equal at
    the start to the branch's (the same point, re-solved on the curve) within 1 %, and to a direct
    ``normal_form`` at a later point; it stays positive there (measured 113 → 127), so no
    GPD label."""
    from analysis.stability.continuation import orbit_scale
    from analysis.stability.curves import continue_curve

    cv = continue_curve(duffing, "PD", param="forcing_amplitude", stop=26.0, max_points=12)
    gpd = cv.test_GPD.values
    k = int(np.nonzero(duffing.special.values == "PD")[0][0])
    # within 1 %: the curve has its own state scales (measured 113.47 vs 113.03)
    assert gpd[0] == pytest.approx(duffing.normal_form_coefficient.values[k], rel=1e-2)
    assert np.all(gpd > 0) and "GPD" not in set(cv.special.values)
    _, prob = _at(duffing, k)
    prob.s_z = orbit_scale(prob, duffing.z0.values[k])  # the curve's scales
    j = cv.sizes["point"] - 1
    prob.values["forcing_amplitude"] = float(cv.forcing_amplitude.values[j])
    l1 = float(cv.speed_rpm.values[j])
    nf = normal_form(period_map(prob), cv.z0.values[j] / prob.s_z, prob.p(l1), kind="PD")
    assert gpd[j] == pytest.approx(nf.coefficient, rel=1e-6)
