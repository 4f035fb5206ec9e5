"""Speed profiles (run-ups, coast-downs): the run against a hand-written integrator of the
same equations with the shaft angle integrated exactly, a constant profile against today's
run bit for bit, the profile in the attrs, and the bad inputs (one line, exit 2, nothing
written)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from analysis import simulate
from analysis.errors import InputError
from analysis.integrate.speed_profile import (
    SpeedProfile,
    parse_speed,
    read_table,
    time_dependence,
)
from analysis.model import load_model
from analysis.provenance import load_dataset

MODEL = "vakharia2015-consistent"  # unbalance (shaft angle), cage angle, centrifugal ∝ n²
DAMPING = 1000.0  # N·s/m: a forced, non-chaotic response through the whole ramp


def hand_rk4(values: dict, n_balls: int, speed, angle, duration: float, dt: float,
             z0) -> np.ndarray:
    """Classical RK4 of the model's equations (MODEL.md of vakharia2015-consistent), written
    here in NumPy: M ẍ = −c ẋ + P_r + P_u cos φ − Σ Q_i cos θ_i, M ÿ = −c ẏ + P_u sin φ −
    Σ Q_i sin θ_i, Q_i = max(0, k·max(0, x cos θ_i + y sin θ_i − γ0)^{3/2} − P_c),
    P_c = π³ρ D_b³ D_i² D_m n²/(10800 (D_i + D_o)²), θ_i = 2π(i−1)/N_b + D_i/(D_i + D_o)·φ,
    with the speed n(t) (rpm) and shaft angle φ(t) (rad) given as functions of t."""
    m, c, k = values["rotor_mass"], values["damping"], values["contact_stiffness"]
    gap, p_r, p_u = values["radial_clearance"], values["radial_load"], values["unbalance_force"]
    d_i, d_o = values["inner_race_diameter"], values["outer_race_diameter"]
    d_m, d_b, rho = values["pitch_diameter"], values["ball_diameter"], values["ball_density"]
    ratio = d_i / (d_i + d_o)
    base = 2 * np.pi * np.arange(n_balls) / n_balls

    def f(t, z):
        x, y, vx, vy = z
        phi, n = angle(t), speed(t)
        theta = base + ratio * phi
        cos, sin = np.cos(theta), np.sin(theta)
        delta = x * cos + y * sin - gap
        hertz = np.where(delta > 0, np.abs(delta) ** 1.5, 0.0)
        p_c = math.pi**3 * rho * d_b**3 * d_i**2 * d_m * n**2 / (10800 * (d_i + d_o) ** 2)
        q = np.maximum(0.0, k * hertz - p_c)
        fx = -c * vx + p_r + p_u * math.cos(phi) - np.sum(q * cos)
        fy = -c * vy + p_u * math.sin(phi) - np.sum(q * sin)
        return np.array([vx, vy, fx / m, fy / m])

    steps = round(duration / dt)
    out = np.empty((4, steps + 1))
    z = np.array(z0, dtype=float)
    out[:, 0] = z
    for j in range(steps):
        t = j * dt
        k1 = f(t, z)
        k2 = f(t + dt / 2, z + dt / 2 * k1)
        k3 = f(t + dt / 2, z + dt / 2 * k2)
        k4 = f(t + dt, z + dt * k3)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[:, j + 1] = z
    return out


def _values() -> dict:
    return {**load_model(MODEL).defaults, "damping": DAMPING}


def test_ramp_agrees_with_a_hand_written_integrator():
    """1000 → 10000 rpm in 0.05 s: the angle φ = π/30·(A t + (B − A) t²/(2T)) in closed
    form, the speed A + (B − A) t/T; every sample to 1e-9 of the largest displacement."""
    a, b, duration, dt = 1000.0, 10000.0, 0.05, 1e-5
    ds = simulate(MODEL, 8, duration=duration, transient=0.0, dt=dt, damping=DAMPING,
                  speed_rpm=SpeedProfile.ramp(a, b))
    want = hand_rk4(_values(), 8, lambda t: a + (b - a) * t / duration,
                    lambda t: math.pi / 30 * (a * t + (b - a) * t * t / (2 * duration)),
                    duration, dt, load_model(MODEL).initial_state)
    scale = np.abs(want[:2]).max()
    for i, name in enumerate(("x", "y", "vx", "vy")):
        got = ds[name].values
        assert got.shape == want[i].shape
        ref = scale if i < 2 else np.abs(want[2:]).max()
        assert np.abs(got - want[i]).max() <= 1e-9 * ref, name
    # the ramp does change the motion: the constant start speed is far from it
    still = simulate(MODEL, 8, duration=duration, transient=0.0, dt=dt, damping=DAMPING,
                     speed_rpm=a)
    assert np.abs(still["x"].values - want[0]).max() > 1e-3 * scale


def test_table_agrees_with_a_hand_written_integrator():
    """Up, down and level (kinks inside the run): φ integrated segment by segment in the
    test; 1e-9 of the largest displacement."""
    rows_t, rows_n = [0.0, 0.01, 0.02, 0.03], [2000.0, 8000.0, 3000.0, 3000.0]
    duration, dt = 0.03, 1e-5

    def speed(t):
        j = min(np.searchsorted(rows_t, t, side="right") - 1, len(rows_t) - 2)
        slope = (rows_n[j + 1] - rows_n[j]) / (rows_t[j + 1] - rows_t[j])
        return rows_n[j] + slope * (t - rows_t[j])

    def angle(t):
        turned = 0.0
        for j in range(len(rows_t) - 1):
            lo, hi = rows_t[j], rows_t[j + 1]
            slope = (rows_n[j + 1] - rows_n[j]) / (hi - lo)
            end = min(max(t, lo), hi) - lo
            turned += rows_n[j] * end + 0.5 * slope * end * end
        return math.pi / 30 * turned

    ds = simulate(MODEL, 8, duration=duration, transient=0.0, dt=dt, damping=DAMPING,
                  speed_rpm=SpeedProfile.table(rows_t, rows_n))
    want = hand_rk4(_values(), 8, speed, angle, duration, dt, load_model(MODEL).initial_state)
    assert np.abs(ds["x"].values - want[0]).max() <= 1e-9 * np.abs(want[:2]).max()
    assert np.abs(ds["y"].values - want[1]).max() <= 1e-9 * np.abs(want[:2]).max()


def test_profile_angle_and_inverse_are_exact():
    profile = SpeedProfile.table([0, 1, 3], [600, 1800, 1200])
    t = np.linspace(0, 3, 30001)
    fine = np.concatenate([[0], np.cumsum(np.diff(t) * 0.5 *
                                          (profile.speed(t[1:], 3) + profile.speed(t[:-1], 3)))])
    # the trapezoid rule is exact for a piecewise-linear speed whose rows are grid points
    assert np.allclose(profile.integral(t, 3), fine, rtol=1e-12, atol=1e-9)
    assert profile.speed(1.0, 3) == pytest.approx(1800)
    angles = profile.shaft_angle(t, 3)
    assert np.abs(profile.time_at_angle(angles, 3) - t).max() < 1e-12


@pytest.mark.parametrize("profile", [SpeedProfile.ramp(5000, 5000),
                                     SpeedProfile.table([0, 0.1, 0.3], [5000, 5000, 5000])])
def test_a_constant_profile_is_todays_run_bit_for_bit(profile, tmp_path):
    from analysis.integrate.simulate import simulate_to_file

    today = simulate("vakharia2015", 8, duration=0.2, transient=0.05, speed_rpm=5000)
    flat = simulate("vakharia2015", 8, duration=0.2, transient=0.05, speed_rpm=profile)
    for name in today.data_vars:
        assert np.array_equal(today[name].values, flat[name].values)
    assert np.array_equal(today["t"].values, flat["t"].values)
    assert today.attrs == flat.attrs  # no profile recorded: it is a constant-speed run
    simulate_to_file("vakharia2015", tmp_path / "a.nc", 8, duration=0.2, transient=0.05,
                     speed_rpm=5000)
    simulate_to_file("vakharia2015", tmp_path / "b.nc", 8, duration=0.2, transient=0.05,
                     speed_rpm=profile)
    a, b = load_dataset(tmp_path / "a.nc"), load_dataset(tmp_path / "b.nc")
    assert np.array_equal(a["x"].values, b["x"].values)


def test_the_attrs_record_the_profile_and_the_file_is_the_memory_run(tmp_path):
    from analysis.integrate.simulate import simulate_to_file

    ramp = SpeedProfile.ramp(2000, 6000)
    ds = simulate("vakharia2015", 8, duration=0.1, transient=0.0, speed_rpm=ramp)
    assert ds.attrs["speed_profile"] == "ramp"
    assert list(ds.attrs["speed_profile_t"]) == [0.0, 0.1]
    assert list(ds.attrs["speed_profile_rpm"]) == [2000.0, 6000.0]
    assert ds.attrs["speed_rpm"] == 2000.0  # the frequencies are those at t = 0
    assert ds.attrs["shaft_hz"] == pytest.approx(2000 / 60)
    path = simulate_to_file("vakharia2015", tmp_path / "r.nc", 8, duration=0.1,
                            transient=0.0, speed_rpm=ramp)
    back = load_dataset(path)
    assert np.array_equal(back["x"].values, ds["x"].values)
    assert SpeedProfile.from_attrs(back.attrs) == ramp


def test_cvodes_follows_the_profile_as_rk4_does():
    """CVODES on the profile's rhs against RK4 (a damped, non-chaotic case): they agree as
    closely as at constant speed (8.9e-7 of the amplitude there, 7.5e-7 on the ramp)."""
    ramp = SpeedProfile.ramp(2000, 6000)
    options = dict(duration=0.1, transient=0.0, damping=DAMPING)
    rk4 = simulate(MODEL, 8, speed_rpm=ramp, **options)
    cv = simulate(MODEL, 8, speed_rpm=ramp, method="cvodes", rtol=1e-10, atol=1e-14,
                  **options)
    gap = np.abs(cv["x"].values - rk4["x"].values).max() / np.abs(rk4["x"].values).max()
    assert gap < 2e-6
    still = simulate(MODEL, 8, speed_rpm=2000.0, **options)
    assert np.abs(still["x"].values - rk4["x"].values).max() > 1e3 * gap * \
        np.abs(rk4["x"].values).max()


def test_time_dependence_tells_a_rotating_forcing_from_a_clock():
    t, z, p = ca.SX.sym("t"), ca.SX.sym("z", 2), ca.SX.sym("p", 2)  # p = (speed_rpm, gain)
    rotating = ca.Function("rhs", [t, z, p], [ca.vertcat(
        z[1], p[1] * ca.cos(math.pi / 30 * p[0] * t) - z[0] - p[0] ** 2 * 1e-9)])
    clock = ca.Function("rhs", [t, z, p], [ca.vertcat(
        z[1], ca.cos(math.pi / 30 * p[0] * t) + ca.sin(2 * math.pi * 50 * t) - z[0])])
    decaying = ca.Function("rhs", [t, z, p], [ca.vertcat(z[1], ca.exp(-t) - z[0])])
    values = np.array([3000.0, 1.0])
    assert time_dependence(rotating, values, 0) == ""
    assert "does not turn with the shaft" in time_dependence(clock, values, 0)
    assert "other than through angles" in time_dependence(decaying, values, 0)


def test_parse_speed_and_tables(tmp_path):
    assert parse_speed("5000") == 5000.0
    assert parse_speed("3000:3000") == 3000.0  # constant: the plain speed
    assert parse_speed("1000:10000") == SpeedProfile.ramp(1000, 10000)
    table = tmp_path / "up.csv"
    table.write_text("# a run-up and a dwell\nt_s,speed_rpm\n0,1000\n2,6000  # ramp\n3,6000\n")
    profile = read_table(table)
    assert profile.times == (0.0, 2.0, 3.0) and profile.rpm == (1000.0, 6000.0, 6000.0)
    assert parse_speed(str(table)) == profile


@pytest.mark.parametrize("text, words", [
    ("0:5000", "--speed-rpm: the ramp's start speed must be a finite number > 0 rpm"),
    ("-100:5000", "the ramp's start speed must be"),
    ("5000:0", "the ramp's end speed must be"),
    ("fast", "--speed-rpm: must be a speed in rpm, a ramp A:B"),
])
def test_bad_ramps_one_line_exit_2_nothing_written(cli, tmp_path, text, words):
    res = cli("simulate", "vakharia2015", "--speed-rpm", text, "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.strip().count("\n") == 0 and words in res.stderr
    assert not (tmp_path / "r.nc").exists()


@pytest.mark.parametrize("rows, words", [
    ("t_s,speed_rpm\n0,1000\n0.3,5000\n0.2,6000\n", "line 4: t_s must increase, got 0.2 "
                                                    "after 0.3 (rows out of order)"),
    ("t_s,speed_rpm\n0,1000\n0.1,1000\n0.1,2000\n", "line 4: t_s must increase"),
    ("t_s,speed_rpm\n0.1,1000\n0.5,2000\n", "row 1: t_s must be 0"),
    ("t_s,speed_rpm\n0,1000\n0.2,0\n", "row 2: speed_rpm must be a finite number > 0 rpm"),
    ("time,rpm\n0,1000\n0.2,2000\n", "the header must be 't_s,speed_rpm'"),
    ("t_s,speed_rpm\n0,1000\n0.1,2000\n", "its last t_s (0.1 s) must reach the end of the run"),
])
def test_bad_tables_one_line_exit_2_nothing_written(cli, tmp_path, rows, words):
    (tmp_path / "p.csv").write_text(rows)
    res = cli("simulate", "vakharia2015", "--speed-rpm", "p.csv", "--duration", "0.2",
              "--transient", "0", "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip().count("\n") == 0 and words in res.stderr
    assert not (tmp_path / "r.nc").exists()


def test_a_model_without_a_turning_shaft_refuses_a_profile():
    with pytest.raises(InputError, match="speed_rpm"):
        simulate("mathieu", duration=1.0, speed_rpm=SpeedProfile.ramp(100, 200))


def test_spectrum_and_poincare_refuse_a_ramped_run(cli, tmp_path):
    res = cli("simulate", "vakharia2015", "--speed-rpm", "2000:4000", "--duration", "0.2",
              "--transient", "0", "-o", "r.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "ramp 2000 → 4000 rpm" in res.stdout
    for command in (["spectrum", "r.nc", "-o", "s.png"], ["poincare", "r.nc", "-o", "p.png"]):
        res = cli(*command, cwd=tmp_path)
        assert res.returncode == 2
        assert res.stderr.strip().count("\n") == 0
        assert "the run's speed changes (ramp 2000 → 4000 rpm)" in res.stderr
        assert "bearingdyn waterfall" in res.stderr
    assert not (tmp_path / "s.png").exists() and not (tmp_path / "p.png").exists()


@pytest.mark.parametrize("name", ["vakharia2015", "vakharia2015-consistent", "balanced-rotor",
                                  "rotor-housing", "two-bearing-rotor", "6205-outer-defect",
                                  "nu205-roller", "duffing"])
def test_the_shipped_rotors_turn_with_their_shaft(name):
    """Every shipped model with a shaft depends on the time only through angles that turn
    with it (the Duffing oscillator is forced at the shaft speed: a profile sweeps its
    forcing); the Mathieu equation has its own clock and no speed."""
    from analysis.integrate.speed_profile import check_model

    model = load_model(name)
    check_model(model, model.default_structure, model.defaults)  # raises if not


def test_a_ramp_on_two_bearings_names_each_bearings_lines():
    from analysis.signal.orders import order_lines

    ds = simulate("two-bearing-rotor", duration=0.1, transient=0.0,
                  speed_rpm=SpeedProfile.ramp(3000, 6000))
    names = {line.name for line in order_lines(ds.attrs)}
    assert {"X", "VC[left]", "VC[right]", "VC[left]+X", "BPFI[right]"} <= names
    assert np.all(np.isfinite(ds["x"].values)) and np.all(np.isfinite(ds["tx"].values))
