"""Normal-form coefficients of maps with known answers, each checked two ways: against the
analytic coefficient and by brute force (the new orbit's amplitude against the distance from
the bifurcation follows the square-root law whose prefactor the coefficient predicts)."""

import math

import casadi as ca
import numpy as np
import pytest

from analysis.errors import InputError
from analysis.stability.normal_forms import amplitude, normal_form, transversality


def _logistic():
    x, r = ca.SX.sym("x"), ca.SX.sym("r")
    return ca.Function("logistic", [x, r], [r * x * (1 - x)])


def _henon(b):
    x, a = ca.SX.sym("x", 2), ca.SX.sym("a")
    return ca.Function("henon", [x, a], [ca.vertcat(1 - a * x[0] ** 2 + x[1], b * x[0])])


def _delayed_logistic():
    x, r = ca.SX.sym("x", 2), ca.SX.sym("r")
    return ca.Function("dlog", [x, r], [ca.vertcat(r * x[0] * (1 - x[1]), x[0])])


def test_logistic_flip_coefficient_and_period_two_amplitude():
    f = _logistic()
    nf = normal_form(f, [2 / 3], [3.0])
    assert nf.kind == "PD" and nf.multiplier == pytest.approx(-1)
    # scalar map: c = f_xx²/4 + f_xxx/6 (Kuznetsov, Sec. 4.4) = (2r)²/4 = 9 at r = 3
    assert nf.coefficient == pytest.approx(9.0, rel=1e-12)
    assert nf.criticality == "supercritical"
    beta_rate = transversality(f, [2 / 3], [3.0], nf)
    assert beta_rate == pytest.approx(1.0, rel=1e-12)  # μ = 2 − r
    for dr in (1e-4, 1e-3):
        r = 3 + dr  # the period-2 orbit in closed form
        s = math.sqrt((r + 1) * (r - 3))
        half = abs(s / r) / 2
        assert half == pytest.approx(amplitude(nf, beta_rate * dr), rel=0.02)
        # and it is stable (supercritical): |(f∘f)'| < 1 on it
        xp, xm = (r + 1 + s) / (2 * r), (r + 1 - s) / (2 * r)
        assert abs(r * (1 - 2 * xp) * r * (1 - 2 * xm)) < 1


@pytest.mark.parametrize("b", [0.3, -0.2])
def test_henon_flip_against_closed_form_and_period_two_orbit(b):
    f = _henon(b)
    a0 = 3 * (1 - b) ** 2 / 4
    x0 = (-(1 - b) + math.sqrt((1 - b) ** 2 + 4 * a0)) / (2 * a0)
    nf = normal_form(f, [x0, b * x0], [a0])
    # by hand: q ∝ (1, −b), p ∝ (1, −1), h₂ = (I − A)⁻¹B(q, q), C = 0, |q| = 1
    assert nf.coefficient == pytest.approx(a0 ** 2 / (1 - b ** 4), rel=1e-10)
    assert nf.criticality == "supercritical"
    rate = transversality(f, [x0, b * x0], [a0], nf)
    for da in (1e-5, 1e-4):
        a = a0 + da  # the period-2 orbit of the Hénon map in closed form
        s = math.sqrt(4 * a - 3 * (1 - b) ** 2)
        x1, x2 = ((1 - b) + s) / (2 * a), ((1 - b) - s) / (2 * a)
        half = abs(nf.p @ (np.array([x1, b * x2]) - np.array([x2, b * x1]))) / 2
        assert half == pytest.approx(amplitude(nf, rate * da), rel=0.03)


def _circle_radius(r, p, n_settle=60_000, n_keep=3_000):
    """The mean |⟨p, x − x*⟩| on the delayed logistic map's attractor at r, by iteration."""
    xs = 1 - 1 / r
    x, y = xs + 1e-3, xs
    for _ in range(n_settle):
        x, y = r * x * (1 - y), x
    out = np.empty(n_keep)
    for k in range(n_keep):
        x, y = r * x * (1 - y), x
        out[k] = abs(np.vdot(p, [x - xs, y - xs]))
    return out


def test_delayed_logistic_neimark_sacker_is_supercritical_with_the_predicted_circle():
    f = _delayed_logistic()
    nf = normal_form(f, [0.5, 0.5], [2.0])
    assert nf.kind == "NS"
    assert nf.multiplier == pytest.approx(np.exp(1j * np.pi / 3))
    assert nf.coefficient < 0 and nf.criticality == "supercritical"
    rate = transversality(f, [0.5, 0.5], [2.0], nf)
    assert rate == pytest.approx(0.5, rel=1e-10)  # |μ|² = det A = r − 1
    for dr in (1e-3, 4e-3):
        radii = _circle_radius(2 + dr, nf.p)
        assert radii.std() < 0.1 * radii.mean()  # a circle, to leading order
        assert radii.mean() == pytest.approx(amplitude(nf, rate * dr), rel=0.03)


def _complex_map(d0):
    """z ↦ e^{iθ}(1 + α)z(1 + d0|z|²) in (Re z, Im z): d = d0·|z|²/|η|² = 2·d0 for |q| = 1."""
    x, a = ca.SX.sym("x", 2), ca.SX.sym("a")
    th = 1.1
    g = (1 + a) * (1 + d0 * (x[0] ** 2 + x[1] ** 2))
    return ca.Function("ns", [x, a], [g * ca.vertcat(math.cos(th) * x[0] - math.sin(th) * x[1],
                                                     math.sin(th) * x[0] + math.cos(th) * x[1])])


@pytest.mark.parametrize("d0", [-0.7, 0.4])
def test_neimark_sacker_sign_and_scale_on_the_complex_normal_form(d0):
    nf = normal_form(_complex_map(d0), [0.0, 0.0], [0.0])
    assert nf.coefficient == pytest.approx(2 * d0, rel=1e-10)
    assert nf.criticality == ("supercritical" if d0 < 0 else "subcritical")


def test_subcritical_flip_has_an_unstable_period_two_orbit_before_the_point():
    x, a = ca.SX.sym("x"), ca.SX.sym("a")
    f = ca.Function("f", [x, a], [-(1 + a) * x - x ** 3 + 0.5 * x ** 2])
    nf = normal_form(f, [0.0], [0.0])
    assert nf.coefficient == pytest.approx(0.25 - 1.0)  # a² + b with a = 0.5, b = −1
    assert nf.criticality == "subcritical"
    # brute force: before the point (α < 0) a period-2 orbit of amplitude √(β/c), unstable
    alpha = -1e-4
    g = ca.Function("g", [x], [f(f(x, alpha), alpha) - x])
    root = ca.rootfinder("r", "newton", g)
    x2 = float(root(0.015))
    assert abs(x2) > 1e-3
    half = abs(x2 - float(f(x2, alpha))) / 2
    assert half == pytest.approx(amplitude(nf, alpha), rel=0.03)  # β = α
    deriv = ca.Function("d", [x], [ca.jacobian(f(f(x, alpha), alpha), x)])
    assert abs(float(deriv(x2))) > 1


def test_fold_quadratic_coefficient_and_the_two_fixed_points():
    x, a = ca.SX.sym("x", 2), ca.SX.sym("a")
    f = ca.Function("f", [x, a], [ca.vertcat(x[0] + a + x[0] ** 2 + x[0] * x[1],
                                             0.5 * x[1] + x[0] ** 2)])
    nf = normal_form(f, [0.0, 0.0], [0.0])
    assert nf.kind == "LP" and nf.coefficient == pytest.approx(1.0, rel=1e-12)
    assert nf.criticality is None
    rate = transversality(f, [0.0, 0.0], [0.0], nf)
    assert rate == pytest.approx(1.0)
    eps = 1e-4  # fixed points at α = −ε: y = 2x², x² + 2x³ = ε
    xr = np.roots([2.0, 1.0, 0.0, -eps])
    xr = np.sort(xr[np.abs(xr.imag) < 1e-12].real)[-2:]
    assert np.abs(xr) == pytest.approx(amplitude(nf, rate * -eps), rel=0.03)


def test_bad_input_is_one_input_error():
    f = _logistic()
    with pytest.raises(InputError, match="x0"):
        normal_form(f, [0.1, 0.2], [3.0])
    with pytest.raises(InputError, match="alpha"):
        normal_form(f, [2 / 3])
    with pytest.raises(InputError, match="NS"):
        normal_form(f, [2 / 3], [3.0], kind="NS")
    with pytest.raises(InputError, match="kind"):
        normal_form(f, [2 / 3], [3.0], kind="XX")
    x = ca.SX.sym("x", 2)  # −1 as a Jordan block (1:2 resonance): no flip normal form
    jordan = ca.Function("j", [x], [ca.vertcat(-x[0] + x[1] + x[0] ** 3, -x[1])])
    with pytest.raises(InputError, match="Jordan"):
        normal_form(jordan, [0.0, 0.0], kind="PD")
