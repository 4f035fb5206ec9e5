"""Two-parameter curves (``analysis.stability.curves``, ``bearingdyn curve``) against
independent computations.

* Duffing fold curve: its two frequencies at F = 0.3 N against a fold solve written here
  (SciPy DOP853 period map and variational equation, ``fsolve`` on the periodic-orbit and
  det(DP − I) = 0 equations, a harmonic-balance start), and its cusp (CP) against the
  smallest F of that independent fold set.
* Mathieu period-doubling curves against the Ince–Strutt series of the first tongue.
* Balanced rotor period-doubling curve in (speed, radial load) against continuations in
  speed at fixed loads and against the classes of a brute-force stability chart.
* ``bearingdyn curve`` end to end, and its bad inputs (one line, exit code 2).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve, minimize_scalar

from analysis.io import open_result
from analysis.stability.continuation import continue_orbits
from analysis.stability.curves import continue_curve, special_lines
from analysis.sweeps.chart import stability_chart
from analysis.sweeps.grid import Axis, Setting
from tests.conftest import run_cli

pytestmark = pytest.mark.xdist_group(__name__)
"""This module's tests on one xdist worker (``--dist loadgroup``: tests/conftest.py), so its
module fixtures run once, not once per worker."""
RPM = 30 / math.pi
"""rad/s -> rpm."""

# ---- Duffing: x'' + c x' + k1 x + k3 x³ = F cos(ωt), m = 1 kg --------------------------

C, K1, K3 = 0.1, 1.0, 0.5
DUFFING = dict(linear_stiffness=K1, cubic_stiffness=K3, damping=C)
F_START, F_CHECK = 0.5, 0.3
"""Forcing amplitude of the branch and of the comparison (N)."""


def _duffing_rhs(t: float, y: np.ndarray, omega: float, force: float) -> np.ndarray:
    """State (x, v) and the 2 × 2 variational matrix, flattened."""
    x, v = y[0], y[1]
    phi = y[2:].reshape(2, 2)
    jac = np.array([[0.0, 1.0], [-K1 - 3 * K3 * x**2, -C]])
    return np.concatenate([[v, force * math.cos(omega * t) - C * v - K1 * x - K3 * x**3],
                           (jac @ phi).ravel()])


def period_map(u: np.ndarray, omega: float, force: float) -> tuple[np.ndarray, np.ndarray]:
    """P(u) and DP(u) over one forcing period from t = 0 (DOP853, rtol = atol = 1e-12)."""
    sol = solve_ivp(_duffing_rhs, (0.0, 2 * math.pi / omega),
                    np.concatenate([u, np.eye(2).ravel()]), method="DOP853",
                    rtol=1e-12, atol=1e-12, args=(omega, force))
    return sol.y[:2, -1], sol.y[2:, -1].reshape(2, 2)


def _fold_equations(u: np.ndarray, omega: float, force: float) -> np.ndarray:
    end, dp = period_map(u, omega, force)
    return np.concatenate([end - u, [np.linalg.det(dp - np.eye(2))]])


def fold_at_force(guess: np.ndarray, force: float) -> tuple[np.ndarray, float]:
    """(u, ω) with P(u) = u and det(DP(u) − I) = 0 at F = ``force`` (fsolve)."""
    sol, _, ok, msg = fsolve(lambda s: _fold_equations(s[:2], s[2], force), guess,
                             xtol=1e-12, full_output=True)
    assert ok == 1, msg
    return sol[:2], float(sol[2])


def fold_at_x0(x0: float, guess: np.ndarray) -> np.ndarray:
    """(v0, ω, F) of the fold whose orbit passes x = x0 at t = 0: the fold set
    parametrised by x0 (smooth through the cusp, unlike F or ω)."""
    sol, _, ok, msg = fsolve(lambda s: _fold_equations(np.array([x0, s[0]]), s[1], s[2]),
                             guess, xtol=1e-12, full_output=True)
    assert ok == 1, msg
    return sol


def harmonic_balance_folds(force: float) -> list[np.ndarray]:
    """First-harmonic estimates (x0, v0, ω) of the folds at F: x ≈ a cos ωt + b sin ωt,
    A² [(k1 − ω² + ¾ k3 A²)² + (cω)²] = F²; the folds where the number of amplitudes
    changes between 1 and 3 on a fine ω grid."""
    omegas = np.linspace(0.8, 3.0, 4401)
    counts, roots = [], []
    for w in omegas:
        d = K1 - w**2
        s = np.roots([9 / 16 * K3**2, 1.5 * K3 * d, d**2 + (C * w) ** 2, -force**2])
        s = np.sort(s[(abs(s.imag) < 1e-9) & (s.real > 0)].real)
        counts.append(len(s))
        roots.append(s)
    out = []
    for i in np.nonzero(np.diff(counts))[0]:
        j = i if counts[i] == 3 else i + 1  # the side with three amplitudes
        w, s = omegas[j], roots[j]
        pair = int(np.argmin(np.diff(s)))  # the two amplitudes about to merge
        amp2 = (s[pair] + s[pair + 1]) / 2
        k = K1 - w**2 + 0.75 * K3 * amp2
        a, b = np.linalg.solve([[k, C * w], [-C * w, k]], [force, 0.0])
        out.append(np.array([a, b * w, w]))
    return out


@pytest.fixture(scope="module")
def duffing_branch():
    """Continuation in ω from 1 to 2.2 rad/s at F = 0.5 N: two folds (LP)."""
    return continue_orbits("duffing", param="speed_rpm", start=1.0 * RPM, stop=2.2 * RPM,
                           period="shaft", dt=0.01, settle=200.0, max_points=400,
                           forcing_amplitude=F_START, **DUFFING)


@pytest.fixture(scope="module")
def fold_curve(duffing_branch):
    """The fold curve from the branch's first LP (the upper fold) down in F towards
    0.05 N: through the cusp and back up to 0.5 N, solved exactly at F = 0.3 N."""
    return continue_curve(duffing_branch, "LP", param="forcing_amplitude", stop=0.05,
                          marks=[F_CHECK])


def test_duffing_fold_curve_crosses_both_independent_folds(duffing_branch, fold_curve):
    """One fold curve joins both folds of the branch through a turning point in F (the
    cusp); at F = 0.3 N it passes both folds of the independent DOP853 fold solve.
    Measured: ω = 1.26161022 and 1.55557862 rad/s, 8.3e-11 and 8.8e-11 rad/s from the
    independent folds (RK4 with 629 steps per period against DOP853)."""
    cv = fold_curve
    lp = np.sort(duffing_branch.speed_rpm.values[duffing_branch.special.values == "LP"])
    assert len(lp) == 2
    # it starts at the upper fold and ends, back at F = 0.5 N, at the lower one
    assert cv.speed_rpm.values[0] == pytest.approx(lp[1], rel=1e-9)
    assert cv.forcing_amplitude.values[-1] == pytest.approx(F_START, rel=1e-12)
    assert cv.speed_rpm.values[-1] == pytest.approx(lp[0], rel=1e-6)
    marked = np.sort(cv.speed_rpm.values[cv.marked.values == 1] / RPM)
    assert len(marked) == 2
    np.testing.assert_allclose(cv.forcing_amplitude.values[cv.marked.values == 1], F_CHECK,
                               rtol=1e-12)
    guesses = harmonic_balance_folds(F_CHECK)
    assert len(guesses) == 2
    independent = np.sort([fold_at_force(g, F_CHECK)[1] for g in guesses])
    assert abs(independent[1] - independent[0]) > 0.2  # two distinct folds
    np.testing.assert_allclose(marked, independent, atol=1e-4)


def test_duffing_cusp_is_the_lowest_force_of_the_independent_fold_set(fold_curve):
    """One CP on the fold curve, at its smallest F (where the two folds meet), and at the
    smallest F of the independent fold set: that set, parametrised by x(0) from the upper
    to the lower fold at F = 0.3 N (DOP853 + fsolve, as above), has its minimum at the
    cusp, so no fold (and no hysteresis) exists below it. Measured: F = 0.0726389612 N
    on both (|ΔF| = 7e-12 N), ω = 1.0901095 rad/s (|Δω| < 1e-8 rad/s)."""
    cv = fold_curve
    labels = [str(s) for s in cv.special.values if s]
    assert labels == ["CP"], special_lines(cv)
    i = int(np.nonzero(cv.special.values == "CP")[0][0])
    f_cp, w_cp = float(cv.forcing_amplitude[i]), float(cv.speed_rpm[i]) / RPM
    assert f_cp == pytest.approx(float(cv.forcing_amplitude.min()), rel=1e-8)
    # the normal-form coefficient changes sign there
    assert np.sign(cv.test_CP.values[i - 1]) != np.sign(cv.test_CP.values[i + 1])
    # independent: march along the fold set in x(0) from the upper to the lower fold
    (u_low, _), (u_up, w_up) = sorted(
        (fold_at_force(g, F_CHECK) for g in harmonic_balance_folds(F_CHECK)),
        key=lambda fold: fold[0][0])
    xs = np.linspace(u_up[0], u_low[0], 9)
    sols, guess = [], np.array([u_up[1], w_up, F_CHECK])
    for x0 in xs:
        guess = fold_at_x0(x0, guess)
        sols.append(guess)
    sols = np.array(sols)
    k = int(np.argmin(sols[:, 2]))
    assert 0 < k < len(xs) - 1  # an interior minimum of F between the two folds

    def force_at(x0: float) -> float:
        guess = np.array([np.interp(x0, xs[::-1], sols[::-1, j]) for j in range(3)])
        return float(fold_at_x0(x0, guess)[2])

    res = minimize_scalar(force_at, bounds=(xs[k + 1], xs[k - 1]), method="bounded",
                          options=dict(xatol=1e-7))
    assert xs[k + 1] + 1e-6 < res.x < xs[k - 1] - 1e-6
    guess = np.array([np.interp(res.x, xs[::-1], sols[::-1, j]) for j in range(3)])
    _, w_ind, f_ind = fold_at_x0(res.x, guess)
    assert f_cp == pytest.approx(f_ind, rel=1e-6)
    assert w_cp == pytest.approx(w_ind, abs=1e-5)
    assert float(cv.z0.values[i, 0]) == pytest.approx(res.x, abs=1e-4)


# ---- Mathieu: x'' + c x' + (δ + ε cos(2πt/T)) x = 0, m = 1 kg, T = 2π s ------------------
# δ = stiffness_mean, ε = stiffness_amplitude: with T = 2π s the textbook form
# x'' + (δ + ε cos t) x = 0 exactly (no rescaling of δ or ε).

MATHIEU = dict(oscillator_mass=1.0, forcing_period=2 * math.pi, damping=0.0,
               stiffness_amplitude=0.1)
MATHIEU_DT = 2 * math.pi / 2000


def ince_strutt(eps: np.ndarray, sign: int, order: int) -> np.ndarray:
    """First tongue of x'' + (δ + ε cos t) x = 0 (sign +1: upper boundary, −1: lower),
    from a = 1 ± q − q²/8 ∓ q³/64 − q⁴/1536 ± 11q⁵/36864 (y'' + (a − 2q cos 2τ) y = 0,
    Abramowitz & Stegun 20.2.25) with a = 4δ, q = −2ε (t = 2τ):
    δ = 1/4 ± ε/2 − ε²/8 ∓ ε³/32 − ε⁴/384 ± 11ε⁵/4608, truncated after ε^order."""
    terms = [0.25 + 0 * eps, sign * eps / 2, -eps**2 / 8, -sign * eps**3 / 32,
             -eps**4 / 384, sign * 11 * eps**5 / 4608]
    return sum(terms[: order + 1])


@pytest.mark.parametrize("stop", [0.02, 0.2])
def test_mathieu_period_doubling_curves_follow_the_ince_strutt_series(stop):
    """Both boundaries of the first tongue, followed in ε from ε = 0.1 (the PD points of a
    continuation in δ) to ``stop``, against the series truncated after ε³: the gap is
    within the first two omitted terms, |δ − series₃| ≤ ε⁴/384 + 11ε⁵/4608 + 1e-9
    (measured 0.67–1.00 of that); with the ε⁴ and ε⁵ terms, within the ε⁶ term,
    |δ − series₅| ≤ 1.2·49ε⁶/36864 + 2e-9 (measured 0.98–1.02 of 49ε⁶/36864, at most
    8.7e-8 at ε = 0.2, 1.3e-9 at ε = 0.02). Undamped, −1 is a double multiplier all along
    (a Jordan block): the curve carries no codimension-two label."""
    br = continue_orbits("mathieu", param="stiffness_mean", start=0.15, stop=0.35,
                         dt=MATHIEU_DT, ds_max=0.02, **MATHIEU)
    for k, sign in ((1, -1), (2, +1)):
        cv = continue_curve(br, f"PD[{k}]", param="stiffness_amplitude", stop=stop)
        assert cv.attrs["status"] == "reached the end of the range"
        assert set(cv.special.values) == {""}
        eps, delta = cv.stiffness_amplitude.values, cv.stiffness_mean.values
        assert eps.min() == pytest.approx(min(0.1, stop)) and \
            eps.max() == pytest.approx(max(0.1, stop))
        assert len(eps) >= 10
        gap3 = np.abs(delta - ince_strutt(eps, sign, 3))
        assert np.all(gap3 <= eps**4 / 384 + 11 * eps**5 / 4608 + 1e-9), gap3.max()
        gap5 = np.abs(delta - ince_strutt(eps, sign, 5))
        assert np.all(gap5 <= 1.2 * 49 * eps**6 / 36864 + 2e-9), gap5.max()
        np.testing.assert_allclose(cv.multiplier_real.values, -1, atol=1e-4)


# ---- balanced rotor: period doubling in (speed_rpm, radial_load), N_b = 8, VC section ----

ROTOR_LOAD = 50.0
"""Radial load of the branch (N): PDs at 8141.4 and 8342.2 rpm on 7700–8600 rpm."""
LOADS = (49.35, 49.75, 50.1, 50.3)
"""Radial loads (N) of the chart rows: three cut the period-2 region, one passes above it;
chosen so that every cell is at least 20 rpm from the curve."""
SPEEDS = Axis.linear("speed_rpm", 7900.0, 8600.0, 8)
"""Chart columns (rpm), 100 rpm apart."""


@pytest.fixture(scope="module")
def rotor_curves():
    """The period-1 branch at 50 N, and the PD curve pieces: from the first PD up in load
    (towards 60 N: over the top of the period-2 region and back down to 50 N, where it
    ends, at the second PD), and from both PDs down to 49.35 N; solved exactly at the
    chart's loads. (Up towards 50.3 N instead, i.e. with load steps scaled by 0.3 N, the
    steps near the top at 50.166 N, 8308 rpm shrink below ds_min: see docs/stability.md.)"""
    br = continue_orbits("balanced-rotor", 8, param="speed_rpm", start=7700.0, stop=8600.0,
                         ds_max=0.1, radial_load=ROTOR_LOAD)
    up = continue_curve(br, "PD", param="radial_load", stop=60.0, marks=LOADS)
    down = [continue_curve(br, f"PD[{k}]", param="radial_load", stop=LOADS[0], marks=LOADS)
            for k in (1, 2)]
    return br, up, down


def _crossings(curves, load: float) -> np.ndarray:
    """Speeds (rpm) where the curve pieces cross ``load`` (linear between points)."""
    out = []
    for cv in curves:
        s, f = cv.speed_rpm.values, cv.radial_load.values
        out.extend(s[f == load])
        for i in range(len(s) - 1):
            if (f[i] - load) * (f[i + 1] - load) < 0:
                out.append(s[i] + (load - f[i]) / (f[i + 1] - f[i]) * (s[i + 1] - s[i]))
    return np.unique(np.round(out, 6))


def test_rotor_pd_curve_joins_both_doublings_and_matches_speed_continuations(rotor_curves):
    """From the first PD the curve rises in load, turns (measured 50.161 N at 8305 rpm) and
    comes back to 50 N at the branch's second PD: the period-2 region is closed above.
    At 49.35 and 49.75 N the curve's speeds equal the PDs of continuations in speed at those
    loads (independent one-parameter computations). The tolerance, 5e-6 relative
    (0.04 rpm), is set by the one-parameter side: its PDs are located by 12 bisections of
    a step of up to 90 rpm (0.02 rpm); the curve solves det-free bordered equations to
    1e-9. Measured: 1.3e-6 at 50 N (8342.1899 vs 8342.1789 rpm); 1.9e-6, 1.1e-6 at
    49.35 N (7925.436, 8423.204 rpm), 0.9e-6, 1.9e-6 at 49.75 N (8031.547, 8376.048 rpm)."""
    br, up, down = rotor_curves
    pd = br.speed_rpm.values[br.special.values == "PD"]
    assert len(pd) == 2 and abs(pd[0] - 8141.4) < 0.5 and abs(pd[1] - 8342.2) < 0.5
    assert up.radial_load.values[-1] == pytest.approx(ROTOR_LOAD, rel=1e-12)
    assert up.speed_rpm.values[-1] == pytest.approx(pd[1], rel=5e-6)
    top = float(up.radial_load.max())
    assert ROTOR_LOAD < top < LOADS[-1]
    for load in LOADS[:2]:
        along = np.sort([float(cv.speed_rpm.values[(cv.marked.values == 1)
                                                   & (cv.radial_load.values == load)][0])
                         for cv in down])
        one = continue_orbits("balanced-rotor", 8, param="speed_rpm", start=7700.0,
                              stop=8600.0, ds_max=0.1, radial_load=load)
        pds = np.sort(one.speed_rpm.values[one.special.values == "PD"])
        assert len(pds) == 2
        np.testing.assert_allclose(along, pds, rtol=5e-6)


def test_rotor_pd_curve_bounds_the_period_two_cells_of_a_chart(rotor_curves, tmp_path):
    """A brute-force chart (simulation from the model's initial state and classification on
    the VC section, no Floquet analysis) over the same two parameters: every periodic-2
    cell lies inside the PD curve and every periodic-1 cell outside it (the period-1 orbit
    is unstable inside). A stable period-3 orbit coexists here (docs/sweeps.md), so some
    cells are periodic-3 (or quasi-periodic): they are not counted. Every cell is at least
    20 rpm from the curve. Measured: 6 periodic-2 cells inside, 16 periodic-1 outside, of
    32. The transient is 0.3 s: with 0.1 s the cell at 8600 rpm, 49.35 N (stable period 1,
    multipliers ≤ 0.69) was still in a transient and classified periodic-2."""
    _, up, down = rotor_curves
    setting = Setting("balanced-rotor", 8, {}, transient=0.3, samples=24, section="vc",
                      lyapunov=False)
    chart = stability_chart(setting, SPEEDS, Axis("radial_load", LOADS),
                            tmp_path / "chart.nc")
    inside_count = {True: 0, False: 0}
    for load in LOADS:
        cross = _crossings([up, *down], load)
        assert len(cross) in (0, 2)
        for speed in SPEEDS.values:
            assert len(cross) == 0 or np.min(np.abs(cross - speed)) > 20.0
            inside = len(cross) == 2 and cross[0] < speed < cross[1]
            nature = str(chart.nature.sel(radial_load=load, speed_rpm=speed).item())
            if nature == "periodic-2":
                assert inside, (load, speed)
                inside_count[True] += 1
            elif nature == "periodic-1":
                assert not inside, (load, speed)
                inside_count[False] += 1
    assert inside_count[True] >= 4 and inside_count[False] >= 12


# ---- bearingdyn curve ------------------------------------------------------------------

CLI_DUFFING = ["--period", "shaft", "--dt", "0.01", "--set", f"linear_stiffness={K1}",
               "--set", f"cubic_stiffness={K3}", "--set", f"damping={C}",
               "--set", f"forcing_amplitude={F_START}"]


@pytest.fixture(scope="module")
def cli_branch(tmp_path_factory):
    """``bearingdyn continue duffing`` in ω (rpm) from 1 to 2.2 rad/s at F = 0.5 N."""
    out = tmp_path_factory.mktemp("curve") / "branch.nc"
    res = run_cli("continue", "duffing", "--param", "speed_rpm", "--from", f"{RPM:.6f}",
                  "--to", f"{2.2 * RPM:.6f}", *CLI_DUFFING, "--settle", "200",
                  "--max-points", "400", "--quiet", "-o", str(out))
    assert res.returncode == 0, res.stderr
    return out


def test_curve_command_writes_both_parameters_and_the_special_lines(cli_branch):
    """The fold curve from the branch's second LP towards F = 0.05 N, stopped after 40
    points (past the cusp): the netCDF file has speed_rpm and forcing_amplitude as data
    variables along ``point`` with their units, the printed lines are those of the file,
    and the CP line is printed; --plot writes a PNG."""
    out, png = cli_branch.with_name("curve.nc"), cli_branch.with_name("curve.png")
    res = run_cli("curve", str(cli_branch), "--point", "LP[2]", "--param",
                  "forcing_amplitude", "--to", "0.05", "--max-points", "40", "--quiet",
                  "-o", str(out), "--plot", str(png))
    assert res.returncode == 0, res.stderr
    cv = open_result(out)
    for name, unit in (("speed_rpm", "rpm"), ("forcing_amplitude", "N")):
        assert name in cv.data_vars and cv[name].dims == ("point",)
        assert cv[name].attrs["units"] == unit
    assert cv.attrs["param1"] == "speed_rpm" and cv.attrs["param2"] == "forcing_amplitude"
    assert cv.attrs["curve"] == "LP" and cv.attrs["branch_file"] == str(cli_branch)
    branch = open_result(cli_branch)
    lp = branch.speed_rpm.values[branch.special.values == "LP"]
    assert cv.speed_rpm.values[0] == pytest.approx(lp[1], rel=1e-9)
    assert cv.forcing_amplitude.values[0] == pytest.approx(F_START)
    lines = special_lines(cv)
    assert [ln for ln in res.stdout.splitlines() if " at forcing_amplitude = " in ln] == lines
    assert len(lines) == 1 and lines[0].startswith("CP at forcing_amplitude = 0.07263")
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


BAD_INPUTS = [
    (["--point", "PD", "--param", "forcing_amplitude", "--to", "0.3"],
     "error: point: the branch has 0 PD point(s), not 1 (special points: LP, LP)"),
    (["--point", "FOLD", "--param", "forcing_amplitude", "--to", "0.3"],
     "error: point: must be LP, PD or NS, optionally with [k]"),
    (["--point", "LP[3]", "--param", "forcing_amplitude", "--to", "0.3"],
     "error: point: the branch has 2 LP point(s), not 3"),
    (["--point", "LP", "--param", "stiffness", "--to", "0.3"],
     "error: param: 'stiffness' is not a parameter of 'duffing'"),
    (["--point", "LP", "--param", "speed_rpm", "--to", "12"],
     "error: param: 'speed_rpm' is the branch's own parameter"),
    (["--point", "LP", "--param", "forcing_amplitude", "--to", str(F_START)],
     "error: stop: must differ from start"),
]
"""(arguments, start of the one error line): unknown --point, a point the branch lacks,
unknown --param, the branch's own parameter, --to equal to the start value."""


@pytest.fixture(scope="module")
def bad_outcomes(cli_branch):
    """Every bad input's command, run at once (each takes about 1.5 s to start)."""
    def run(args):
        return run_cli("curve", str(cli_branch), *args, "-o",
                       str(cli_branch.with_name("bad.nc")))

    with ThreadPoolExecutor(len(BAD_INPUTS)) as pool:
        return list(pool.map(run, [args for args, _ in BAD_INPUTS]))


@pytest.mark.parametrize("case", range(len(BAD_INPUTS)))
def test_curve_bad_inputs_one_line_exit_2(cli_branch, bad_outcomes, case):
    res, message = bad_outcomes[case], BAD_INPUTS[case][1]
    assert res.returncode == 2, res.stdout + res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(message), res.stderr
    assert not cli_branch.with_name("bad.nc").exists()
