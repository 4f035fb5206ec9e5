"""Hertz point contact of a ball with its races: curvatures, contact ellipse, stiffness.

Notation of Harris & Kotzalas, *Rolling Bearing Analysis* (ch. "Contact stress and
deformation"), zero contact angle (deep-groove ball bearing under radial load):

- ball diameter D_b, pitch diameter D_m, groove conformity f = r_groove / D_b (> 1/2),
  γ = D_b / D_m;
- curvatures (1/m, + convex): ball ρ_I1 = ρ_I2 = 2/D_b; race in the rolling direction
  ρ_II1 = ±(2/D_b)·γ/(1 ∓ γ) (+ inner race, − outer race), across the groove
  ρ_II2 = −1/(f D_b);
- curvature sum Σρ and curvature difference F(ρ) = (ρ_I1 − ρ_I2 + ρ_II1 − ρ_II2)/Σρ;
- the contact ellipse has axis ratio κ = a/b (ellipticity), the root of
  F(ρ) = [(κ² + 1) ℰ − 2 ℱ] / [(κ² − 1) ℰ], ℱ, ℰ the complete elliptic integrals of the
  first and second kind of modulus e = √(1 − 1/κ²);
- dimensionless a* = (2κ²ℰ/π)^{1/3}, b* = (2ℰ/(πκ))^{1/3}, δ* = (2ℱ/π)(π/(2κ²ℰ))^{1/3};
- load–deflection Q = K δ^{3/2} (N, m) with K = π κ E' √(2ℰ / (9 ℱ³ Σρ)) (Hamrock's form),
  E' = E / (1 − ν²) for ball and race of the same material (E in Pa);
- ball between both races, contacts in series: K = [(1/K_i)^{2/3} + (1/K_o)^{2/3}]^{−3/2}.

``race_contact`` solves the ellipticity exactly (SciPy's ``ellipk``/``ellipe`` and Brent's
method); ``hamrock_brewe`` gives the closed-form approximations of Hamrock & Brewe (1983),
k ≈ α^{2/π}, ℰ ≈ 1 + q/α, ℱ ≈ π/2 + q ln α, q = π/2 − 1, α = R_y/R_x = (1 + F)/(1 − F).
``unrolled_stiffness`` is what generated models compute: Hamrock–Brewe as the start, then
Newton steps on κ with ℱ and ℰ from the arithmetic–geometric mean, all as one expression of
the parameters (so E, ν, f, D_b, D_m stay runtime parameters).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

from modelgen.unrolled import NUMPY, Ops, unrolled_base

Race = Literal["inner", "outer"]
RACE_SIGN: dict[str, int] = {"inner": 1, "outer": -1}
"""Sign of the race's curvature in the rolling direction (convex inner, concave outer)."""
NEWTON_STEPS = 4
"""Newton steps on the ellipticity from the Hamrock–Brewe start: the start is off by a few
%, each step squares the relative error; 4 steps leave < 2e-14 for groove conformities
0.505…1 and D_b/D_m 0.02…0.45 (tests/modelgen/test_hertz.py)."""
AGM_STEPS = 6
"""Arithmetic–geometric-mean steps for ℱ and ℰ (double precision for κ up to ~100)."""


def curvatures(ball_diameter: Any, pitch_diameter: Any, conformity: Any,
               sign: Any) -> tuple[Any, Any]:
    """Curvature sum Σρ (1/m) and curvature difference F(ρ) of a ball–race contact;
    ``sign`` is +1 for the inner race, −1 for the outer race (``RACE_SIGN``)."""
    gamma = ball_diameter / pitch_diameter
    ball = 2 / ball_diameter
    rolling = sign * ball * gamma / (1 - sign * gamma)
    groove = -1 / (conformity * ball_diameter)
    total = 2 * ball + rolling + groove
    return total, (rolling - groove) / total


def reduced_modulus(youngs_modulus: Any, poisson_ratio: Any) -> Any:
    """E' = E/(1 − ν²) (Pa) of a contact of two bodies of the same material."""
    return youngs_modulus / (1 - poisson_ratio**2)


def combined_stiffness(inner: Any, outer: Any) -> Any:
    """K = [(1/K_i)^{2/3} + (1/K_o)^{2/3}]^{−3/2}: ball between both races, contacts in
    series (N/m^1.5). Floats, arrays or SymPy (exact exponents)."""
    return (inner ** Fraction(-2, 3) + outer ** Fraction(-2, 3)) ** Fraction(-3, 2)


def load_deflection_constant(curvature_sum: Any, ellipticity: Any, first_kind: Any,
                             second_kind: Any, modulus: Any, ops: Ops = NUMPY) -> Any:
    """K = π κ E' √(2ℰ / (9 ℱ³ Σρ)) in N/m^1.5 (Q = K δ^{3/2})."""
    return ops.pi * ellipticity * modulus * ops.sqrt(
        2 * second_kind / (9 * first_kind**3 * curvature_sum))


def elliptic_integrals_agm(ellipticity: Any, ops: Ops = NUMPY,
                           steps: int = AGM_STEPS) -> tuple[Any, Any]:
    """ℱ, ℰ of modulus e = √(1 − 1/κ²) by the arithmetic–geometric mean (κ >= 1).

    ℱ = π / (2 M(1, 1/κ)); ℰ = ℱ (1 − Σ_n 2^{n−1} c_n²), c_0² = e², c_{n+1} = (a_n − b_n)/2.
    """
    a, b = 1, 1 / ellipticity
    total = (1 - b**2) / 2
    weight = 1
    for _ in range(steps):
        a, b, c = (a + b) / 2, ops.sqrt(a * b), (a - b) / 2
        total += weight * c**2
        weight *= 2
    first = ops.pi / (2 * a)
    return first, first * (1 - total)


def difference_of_ellipticity(ellipticity: Any, first: Any, second: Any) -> Any:
    """F(ρ) = [(κ² + 1) ℰ − 2 ℱ] / [(κ² − 1) ℰ] of an ellipse of axis ratio κ."""
    k2 = ellipticity**2
    return ((k2 + 1) * second - 2 * first) / ((k2 - 1) * second)


def unrolled_ellipticity(difference: Any, ops: Ops = NUMPY, steps: int = NEWTON_STEPS) -> Any:
    """κ solving F(κ) = F(ρ): Hamrock–Brewe start, then Newton steps (AGM integrals)."""
    kappa = ops.power((1 + difference) / (1 - difference), 2 / ops.pi)
    for _ in range(steps):
        first, second = elliptic_integrals_agm(kappa, ops)
        m = 1 - 1 / kappa**2
        # d/dm of ℱ(m), ℰ(m); dm/dκ = 2/κ³
        d_first = (second - (1 - m) * first) / (2 * m * (1 - m)) * 2 / kappa**3
        d_second = (second - first) / (2 * m) * 2 / kappa**3
        k2 = kappa**2
        num = (k2 + 1) * second - 2 * first
        den = (k2 - 1) * second
        d_num = 2 * kappa * second + (k2 + 1) * d_second - 2 * d_first
        d_den = 2 * kappa * second + (k2 - 1) * d_second
        residual = num / den - difference
        slope = (d_num * den - num * d_den) / den**2
        kappa = kappa - residual / slope
    return kappa


def unrolled_stiffness(ball_diameter: Any, pitch_diameter: Any, conformity: Any,
                       youngs_modulus: Any, poisson_ratio: Any, sign: Any,
                       ops: Ops = NUMPY) -> Any:
    """K of one ball–race contact (N/m^1.5) as computed by the generated code; ``sign`` as
    in ``curvatures``."""
    total, difference = curvatures(ball_diameter, pitch_diameter, conformity, sign)
    kappa = unrolled_ellipticity(difference, ops)
    first, second = elliptic_integrals_agm(kappa, ops)
    return load_deflection_constant(total, kappa, first, second,
                                    reduced_modulus(youngs_modulus, poisson_ratio), ops)


@dataclass(frozen=True)
class RaceContact:
    """Hertz contact of a ball with one race (SI units; Σρ in 1/m, K in N/m^1.5)."""

    curvature_sum: float
    curvature_difference: float
    ellipticity: float
    """κ = a/b, semi-major over semi-minor axis of the contact ellipse."""
    first_kind: float
    """ℱ, complete elliptic integral of the first kind."""
    second_kind: float
    """ℰ, complete elliptic integral of the second kind."""
    stiffness: float
    """K of Q = K δ^{3/2}."""

    @property
    def a_star(self) -> float:
        return (2 * self.ellipticity**2 * self.second_kind / math.pi) ** (1 / 3)

    @property
    def b_star(self) -> float:
        return (2 * self.second_kind / (math.pi * self.ellipticity)) ** (1 / 3)

    @property
    def delta_star(self) -> float:
        return (2 * self.first_kind / math.pi
                * (math.pi / (2 * self.ellipticity**2 * self.second_kind)) ** (1 / 3))


def exact_ellipticity(difference: float) -> float:
    """κ solving F(κ) = F(ρ) to machine precision (Brent's method, SciPy integrals)."""
    if not 0 < difference < 1:
        raise ValueError(f"curvature difference must be in (0, 1), got {difference}")
    from scipy.optimize import brentq  # here, not at import: a spec is judged without SciPy
    from scipy.special import ellipe, ellipk

    def residual(kappa: float) -> float:
        m = 1 - 1 / kappa**2
        return difference_of_ellipticity(kappa, ellipk(m), ellipe(m)) - difference

    high = 2.0
    while residual(high) < 0:
        high *= 2
    return brentq(residual, 1 + 1e-12, high, xtol=1e-14, rtol=1e-15, maxiter=200)


def hamrock_brewe(difference: float) -> tuple[float, float, float]:
    """Hamrock–Brewe (1983) approximations (κ, ℱ, ℰ) for curvature difference F(ρ)."""
    alpha = (1 + difference) / (1 - difference)
    q = math.pi / 2 - 1
    return alpha ** (2 / math.pi), math.pi / 2 + q * math.log(alpha), 1 + q / alpha


def race_contact(ball_diameter: float, pitch_diameter: float, conformity: float,
                 youngs_modulus: float, poisson_ratio: float, race: Race,
                 method: Literal["exact", "hamrock_brewe"] = "exact") -> RaceContact:
    """Hertz contact of a ball with the inner or outer race (SI units)."""
    total, difference = curvatures(ball_diameter, pitch_diameter, conformity, RACE_SIGN[race])
    if method == "exact":
        from scipy.special import ellipe, ellipk

        kappa = exact_ellipticity(difference)
        m = 1 - 1 / kappa**2
        first, second = float(ellipk(m)), float(ellipe(m))
    else:
        kappa, first, second = hamrock_brewe(difference)
    modulus = reduced_modulus(youngs_modulus, poisson_ratio)
    return RaceContact(total, difference, kappa, first, second,
                       load_deflection_constant(total, kappa, first, second, modulus))



@functools.cache
def race_stiffness_class() -> type:
    """The class ``RaceStiffness`` (made on first use: an ``Unrolled`` SymPy function needs
    SymPy, and validating a spec does not; ``modelgen.lazy``)."""

    class RaceStiffness(unrolled_base()):
        """K(D_b, D_m, f, E, ν, s): ball–race load–deflection constant (N/m^1.5), s = +1 for the
        inner race (K_i), −1 for the outer race (K_o)."""

        nargs = 6
        code_name = "race_stiffness"
        arg_names = ("d_b", "d_m", "f", "e", "nu", "sign")
        doc = ("Hertz load-deflection constant K (N/m^1.5) of a ball (diameter d_b) and a race "
               "(sign +1 inner, -1 outer) of groove conformity f, pitch diameter d_m, modulus e, "
               f"Poisson ratio nu: Hamrock-Brewe start, {NEWTON_STEPS} Newton steps on the "
               f"ellipticity, elliptic integrals by {AGM_STEPS} AGM steps (modelgen/hertz.py).")
        is_positive = True

        @staticmethod
        def algorithm(d_b: Any, d_m: Any, f: Any, e: Any, nu: Any, sign: Any, ops: Ops) -> Any:
            return unrolled_stiffness(d_b, d_m, f, e, nu, sign, ops)

        def latex_name(self) -> str:
            return "K_i" if self.args[5] == 1 else "K_o"

        def latex_args(self, printer: Any) -> str:
            return ", ".join(printer._print(a) for a in self.args[:5])

    RaceStiffness.__module__, RaceStiffness.__qualname__ = __name__, "RaceStiffness"
    return RaceStiffness


def __getattr__(name: str) -> Any:
    """``RaceStiffness``, made on first use (``race_stiffness_class``)."""
    if name == "RaceStiffness":
        return race_stiffness_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
