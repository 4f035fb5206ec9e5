"""Centrifugal force of the balls, in the variants the paper and the textbooks give.

``paper_eq9`` is the paper as written: P_c = 2.26e-11 · D_b² · ω_cage · D_m (Eq. 9), with D_b
and D_m in mm and ω_cage in rpm (the units of the empirical formula it comes from), subtracted
from the load of *every* ball (Eqs. 7-8). Summed over equally spaced balls,
Σ P_c cos θ_i = Σ P_c sin θ_i = 0: the term cancels exactly and has no effect.
Eq. 9 also is not Harris' formula, F_c = 2.26e-11 · D³ · d_m · n_m² (D, d_m in mm, n_m in rpm):
the ball diameter is squared instead of cubed and the speed is not squared.

``loaded_zone`` is physically consistent: Harris' F_c = ½ m_b D_m ω_cage² (N), with
m_b = ρ_b π D_b³ / 6, carried by the outer race, so it relieves the inner-race load of the
balls *in contact* only. The gated sum of a ball (Hertz load - F_c) is clamped at zero: a
ball whose Hertz load is below its centrifugal force has left the inner race.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Owner, Term

HARRIS_STEEL_COEFFICIENT = "2.26e-11"
"""Harris' coefficient for steel balls, N/(mm^3 · mm · rpm^2), as the text of its SymPy
Float; Eq. 9 of the paper uses it."""


def paper_eq9_force(ctx: Context) -> sp.Expr:
    """Paper Eq. 9 as printed (N by the formula's convention): D in mm, ω_cage in rpm."""
    d_b_mm = 1000 * ctx.p("ball_diameter")
    d_m_mm = 1000 * ctx.p("pitch_diameter")
    cage_rpm = ctx.omega_cage * 30 / sp.pi
    return sp.Float(HARRIS_STEEL_COEFFICIENT) * d_b_mm**2 * cage_rpm * d_m_mm


def harris_force(ctx: Context) -> sp.Expr:
    """Harris' centrifugal force of one ball, ½ m_b D_m ω_cage² (N)."""
    d_b = ctx.p("ball_diameter")
    ball_mass = ctx.p("ball_density") * sp.pi * d_b**3 / 6
    return ball_mass * ctx.p("pitch_diameter") * ctx.omega_cage**2 / 2


class Centrifugal(Term):
    kind: Literal["centrifugal"] = "centrifugal"
    variant: Literal["paper_eq9", "loaded_zone"]
    """``paper_eq9``: paper Eq. 9 as printed, on every ball (cancels for equally spaced balls);
    ``loaded_zone``: Harris' ½ m_b D_m ω_cage², relieving the balls in contact only."""

    attaches: ClassVar[tuple[Owner, ...]] = ("bearing",)
    summary: ClassVar[str] = "centrifugal ball force"

    def required_parameters(self) -> tuple[str, ...]:
        if self.variant == "paper_eq9":
            return ("ball_diameter", "pitch_diameter", "speed_rpm")
        return ("ball_diameter", "pitch_diameter", "ball_density", "speed_rpm")

    def is_gated(self) -> bool:
        return self.variant == "loaded_zone"

    def ball_load(self, ctx: Context) -> sp.Expr:
        force = paper_eq9_force(ctx) if self.variant == "paper_eq9" else harris_force(ctx)
        return -force

    def describe(self) -> str:
        if self.variant == "paper_eq9":
            return ("centrifugal force P_c of paper Eq. 9 (2.26e-11·D_b²·ω_cage·D_m, mm and rpm), "
                    "subtracted from every ball's load as in Eqs. 7–8: cancels exactly for "
                    "equally spaced balls")
        return ("centrifugal force F_c = ½ m_b D_m ω_cage² (Harris), m_b = ρ_b π D_b³/6, "
                "relieving the inner-race load of balls in contact only (loaded zone)")
