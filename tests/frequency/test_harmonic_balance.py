"""Harmonic balance (analysis.frequency) against independent computations.

* the AFT matrices and the exact Jacobian (against the matrix products and finite
  differences, the period's dependence on the speed included);
* Duffing x'' + 0.1 x' + x + 0.5 x³ = 0.3 cos ωt: the folds of the HB branch against a fold
  solve written here (the second-order HB of the same H in numpy, extended by J φ = 0 and a
  normalisation, solved by scipy's fsolve with finite-difference Jacobians), and Hill's
  stability against shooting's Floquet multipliers (RK4, dt = 1e-3 s) along the branch;
* the balanced rotor (N_b = 8, 50 N, period vc): both period doublings of the HB branch
  with Hill's stability within 0.5 rpm of shooting continuation's;
* the command: a single solve and a branch as JSON, the file, and the bad inputs (one line,
  exit 2, nothing written).
"""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest
import scipy.optimize
import tomli_w

from analysis.errors import InputError
from analysis.frequency import (
    Basis,
    HarmonicSystem,
    continue_harmonic,
    harmonic_balance,
    harmonic_convergence,
)
from analysis.integrate.flow import Period
from analysis.model import System
from analysis.stability.periodic import shoot
from tests.conftest import SPECS

DUFFING = dict(linear_stiffness=1.0, cubic_stiffness=0.5, damping=0.1,
               forcing_amplitude=0.3)
RPM = 30 / math.pi
"""speed_rpm per rad/s of the Duffing forcing (period shaft: ω = speed_rpm·π/30)."""
H_DUFFING = 11
ROTOR_PD = (8141.8, 8342.3)
"""Shooting continuation's period doublings of the balanced rotor (rpm; the issue's)."""
H_ROTOR = 80
"""Harmonics the rotor's PD points need to land within 0.5 rpm (measured: H = 60 puts the
second 0.9 rpm off; docs/frequency.md)."""


def test_basis_matrices():
    basis = Basis(5, 17)
    assert np.abs(basis.P @ basis.E - np.eye(11)).max() < 1e-13
    values = np.random.default_rng(1).normal(size=(17, 3))
    direct = np.array([basis.P @ np.diag(values[:, m]) @ basis.E for m in range(3)])
    assert np.abs(basis.product_matrices(values) - direct).max() < 1e-13
    series = 2 + np.sin(3 * basis.theta) - 0.5 * np.cos(basis.theta)
    expected = np.zeros(11)
    expected[[0, 1, 6]] = 2, -0.5, 1
    assert np.abs(basis.project(series[:, None])[:, 0] - expected).max() < 1e-13


@pytest.mark.parametrize("model, period, extra", [
    ("duffing", "shaft", dict(DUFFING, speed_rpm=1.2 * RPM)),
    ("balanced-rotor", "vc", dict(n_balls=8, radial_load=50.0, speed_rpm=8000.0)),
])
def test_exact_jacobian(model, period, extra):
    """∂R/∂X (FFT-assembled from the generated jac) and ∂R/∂speed (forward AD, the period's
    own dependence included) against central differences."""
    system = System.make(model, **extra)
    hs = HarmonicSystem(system, Period.parse(period), 4, None)
    rng = np.random.default_rng(2)
    scale = np.tile([1e-5, 1e-5, 1e-2, 1e-2] if model != "duffing" else [1, 1, 1, 1], 9)
    x = rng.normal(size=hs.size) * scale
    p = system.p
    _r, jac, along = hs.evaluate(x, p, 0)
    for k in rng.choice(hs.size, 6, replace=False):
        h = 1e-6 * scale[k]
        e = np.zeros(hs.size)
        e[k] = h
        fd = (hs.evaluate(x + e, p)[0] - hs.evaluate(x - e, p)[0]) / (2 * h)
        assert np.abs(fd - jac[:, k]).max() <= 1e-6 * np.abs(jac).max()
    dp = np.zeros_like(p)
    dp[0] = 1e-4 * p[0]
    fd = (hs.evaluate(x, p + dp)[0] - hs.evaluate(x, p - dp)[0]) / (2 * dp[0])
    assert np.abs(fd - along).max() <= 1e-6 * np.abs(along).max()


@pytest.fixture(scope="module")
def duffing_branch():
    return continue_harmonic("duffing", param="speed_rpm", start=0.5 * RPM, stop=2.5 * RPM,
                             period="shaft", harmonics=H_DUFFING, ds_max=0.3,
                             max_points=400, **DUFFING)


def duffing_hb_fold(coefficients: np.ndarray, omega: float, harmonics: int,
                    samples: int) -> float:
    """ω (rad/s) of the fold of x'' + c x' + k1 x + k3 x³ = F cos ωt near the given
    first-state coefficients (c0, a1, b1, …): its own second-order HB (cos block, then sin
    block) in numpy, extended by J(X, ω) φ = 0 and φ·φ0 = 1, solved by fsolve."""
    c, k1, k3, force = (DUFFING[k] for k in ("damping", "linear_stiffness",
                                             "cubic_stiffness", "forcing_amplitude"))
    h = harmonics
    k = np.arange(1, h + 1)
    theta = 2 * np.pi * np.arange(samples) / samples
    synth = np.hstack([np.ones((samples, 1)), np.cos(np.outer(theta, k)),
                       np.sin(np.outer(theta, k))])
    project = np.linalg.pinv(synth)

    def linear(w):
        m = np.zeros((2 * h + 1, 2 * h + 1))
        m[0, 0] = k1
        for i, kk in enumerate(k):
            m[1 + i, 1 + i] = m[h + 1 + i, h + 1 + i] = k1 - (kk * w) ** 2
            m[1 + i, h + 1 + i], m[h + 1 + i, 1 + i] = c * kk * w, -c * kk * w
        return m

    def residual(x, w):
        f = np.zeros(2 * h + 1)
        f[1] = force
        return linear(w) @ x + project @ (k3 * (synth @ x) ** 3) - f

    def jacobian(x, w):
        return linear(w) + project @ (3 * k3 * (synth @ x)[:, None] ** 2 * synth)

    x0 = np.concatenate([[coefficients[0]], coefficients[1::2], coefficients[2::2]])
    phi0 = np.linalg.svd(jacobian(x0, omega))[2][-1]

    def extended(u):
        x, w, phi = u[:2 * h + 1], u[2 * h + 1], u[2 * h + 2:]
        return np.concatenate([residual(x, w), jacobian(x, w) @ phi, [phi @ phi0 - 1]])

    u, _info, _ok, msg = scipy.optimize.fsolve(extended, np.concatenate([x0, [omega], phi0]),
                                              xtol=1e-13, full_output=True)
    assert np.abs(extended(u)).max() < 1e-10, msg  # converged (to rounding: fsolve may
    # still say 'not making good progress' there)
    return float(u[2 * h + 1])


def test_duffing_folds_agree_with_an_independent_fold_solve(duffing_branch):
    br = duffing_branch
    assert br.attrs["status"] == "reached the end of the range"
    folds = np.nonzero(br.special.values == "LP")[0]
    assert len(folds) == 2
    assert br.residual.values.max() < 1e-10
    for j in folds:
        omega = float(br.speed_rpm.values[j]) / RPM
        independent = duffing_hb_fold(br.coefficients.values[j, :, 0], omega, H_DUFFING, 48)
        assert abs(omega - independent) < 1e-6, (omega, independent)
    lower, upper = sorted(float(br.speed_rpm.values[j]) / RPM for j in folds)
    assert 1.2 < lower < 1.3 and 1.5 < upper < 1.6  # the hardening resonance's two folds


def test_hill_equals_shooting_along_the_branch(duffing_branch):
    """At points spread over the whole branch (both stable parts and the unstable middle
    one), shooting from the HB state at t = 0 finds the same orbit, and Hill's multipliers
    equal its Floquet multipliers (so the stability verdicts agree)."""
    br = duffing_branch
    picks = np.linspace(0, br.sizes["point"] - 1, 12).round().astype(int)
    verdicts = set()
    for j in picks:
        rpm = float(br.speed_rpm.values[j])
        coeffs = br.coefficients.values[j]
        z0 = coeffs[0] + coeffs[1::2].sum(axis=0)  # t = 0: c0 + Σ a_k
        orbit = shoot("duffing", None, "shaft", z0, 0.0, dt=1e-3, speed_rpm=rpm, **DUFFING)
        assert orbit.converged
        assert np.abs(orbit.z0 - z0).max() < 1e-6
        hill = br.multiplier_real.values[j] + 1j * br.multiplier_imag.values[j]
        for mu in orbit.multipliers:
            assert np.min(np.abs(hill - mu)) < 1e-6, (rpm, hill, orbit.multipliers)
        assert bool(br.stable.values[j]) == (orbit.stability == "stable")
        verdicts.add(bool(br.stable.values[j]))
    assert verdicts == {True, False}


def test_convergence_in_harmonics_is_reported():
    r = harmonic_balance("duffing", None, "shaft", 5, speed_rpm=1.2 * RPM, **DUFFING)
    assert r.converged and r.residual < 1e-10
    report = harmonic_convergence(r)
    assert report["harmonics_more"] == 10 and report["converged_more"]
    assert report["residual_in_more"] > report["residual_more"]
    assert 0 < report["change"] < 1e-3


def test_rotor_period_doublings_match_shooting_continuation():
    br = continue_harmonic("balanced-rotor", 8, param="speed_rpm", start=8000.0,
                           stop=8450.0, period="vc", harmonics=H_ROTOR, radial_load=50.0)
    pd = sorted(float(v) for v, s in zip(br.speed_rpm.values, br.special.values,
                                          strict=True) if s == "PD")
    assert len(pd) == 2, pd
    for got, want in zip(pd, ROTOR_PD, strict=True):
        assert abs(got - want) < 0.5, (pd, ROTOR_PD)
    between = (br.speed_rpm.values > pd[0] + 1) & (br.speed_rpm.values < pd[1] - 1)
    assert not br.stable.values[between].any()
    assert br.residual.values.max() < 1e-9


def test_subharmonic_response_vc2():
    """Between the rotor's period doublings the attractor is the period-2 response: HB with
    period vc:2 finds it (odd harmonics of VC/2 present), stable, with shooting's verdict
    and multipliers (H = 40 over two VC periods: 20 per VC period, hence 2e-2)."""
    r = harmonic_balance("balanced-rotor", 8, "vc:2", 40, radial_load=50.0, speed_rpm=8250.0)
    orbit = shoot("balanced-rotor", 8, "vc:2", radial_load=50.0, speed_rpm=8250.0)
    assert r.converged and orbit.converged and r.residual < 1e-10
    assert r.stability == orbit.stability == "stable"
    for mu in orbit.multipliers:
        assert np.min(np.abs(r.multipliers - mu)) < 2e-2
    c = r.coefficients.reshape(-1, 4)  # rows c0, a1, b1, a2, b2, …
    odd = np.abs(c[1::4]).max() + np.abs(c[2::4]).max()
    assert odd > 1e-3 * np.abs(c[3::4]).max()


def test_bad_inputs_of_the_api():
    with pytest.raises(InputError, match="harmonics: must be a whole number >= 1"):
        harmonic_balance("duffing", None, "shaft", 0)
    with pytest.raises(InputError, match="GiB"):
        harmonic_balance("duffing", None, "shaft", 10**6)
    with pytest.raises(InputError, match="sort"):
        harmonic_balance("duffing", None, "shaft", 3, sort="nearest")


DUFFING_ARGS = ["--period", "shaft", "--set", "linear_stiffness=1", "--set",
                "cubic_stiffness=0.5", "--set", "damping=0.1", "--set",
                "forcing_amplitude=0.3"]


def test_command_single_solve_and_branch(cli, tmp_path):
    out = cli("hb", "duffing", *DUFFING_ARGS, "--set", "speed_rpm=12", "--harmonics", "7",
              "-o", str(tmp_path / "one.nc"), "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert len(data["points"]) == 1
    point = data["points"][0]
    assert set(point) == {"amplitude", "stable", "special", "residual"}
    assert set(point["amplitude"]) == {"x", "y", "vx", "vy"} and point["stable"]
    assert data["provenance"]["model"] == "duffing"
    out = cli("hb", "duffing", *DUFFING_ARGS, "--harmonics", "5", "--param", "speed_rpm",
              "--from", "10", "--to", "16", "--ds-max", "0.5", "-o", str(tmp_path / "br.nc"),
              "--plot", str(tmp_path / "br.png"), "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    points = json.loads(out.stdout)["points"]
    assert all(set(p) == {"speed_rpm", "amplitude", "stable", "special", "residual"}
               for p in points)
    assert [p["special"] for p in points].count("LP") == 2  # up the resonance and back
    assert (tmp_path / "br.png").stat().st_size > 0
    from analysis.io import open_result

    stored = open_result(tmp_path / "br.nc")
    assert stored.attrs["harmonics"] == 5 and stored.attrs["param"] == "speed_rpm"
    assert np.allclose(stored.speed_rpm.values, [p["speed_rpm"] for p in points])


def unforced_spec(folder) -> str:
    data = tomllib.loads((SPECS / "duffing.toml").read_text())
    data["model"]["name"] = "free-duffing"
    data["terms"] = [t for t in data["terms"] if t["kind"] != "harmonic_force"]
    data["parameters"].pop("forcing_amplitude")
    path = folder / "free-duffing.toml"
    path.write_text(tomli_w.dumps(data))
    return str(path)


@pytest.mark.parametrize("args, words", [
    (["duffing", "--period", "shaft", "--harmonics", "0"], "--harmonics: must be a whole"),
    (["duffing", "--period", "shaft", "--harmonics", "5000"], "GiB"),
    (["duffing", "--period", "shaft", "--param", "speed_rpm", "--from", "5"],
     "give --to"),
    (["UNFORCED", "--period", "shaft"], "has no forcing"),
])
def test_command_bad_inputs(cli, tmp_path, args, words):
    if args[0] == "UNFORCED":
        args = [unforced_spec(tmp_path), *args[1:]]
    target = tmp_path / "hb.nc"
    out = cli("hb", *args, "-o", str(target), env={"BEARINGDYN_CACHE": str(tmp_path / "c")})
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], lines
    assert not target.exists()
