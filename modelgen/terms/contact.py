"""Hertz ball contact with radial clearance, and the cage kinematics that move the balls.

Paper Eqs. 1-6: ball i sits at θ_i = 2π(i-1)/N_b + ω_cage t and is compressed by
δ_i = x cos θ_i + y sin θ_i - γ_0 (m); its load on the rotor is k·max(0, δ_i)^{3/2} (N).
"""

from __future__ import annotations

from typing import ClassVar, Literal

import sympy as sp

from modelgen.symbols import Context
from modelgen.terms.base import Term


def deflection(ctx: Context) -> sp.Expr:
    """Contact deflection δ_i of one ball (m), paper Eq. 5."""
    return ctx.x * ctx.c + ctx.y * ctx.s - ctx.p("radial_clearance")


def hertz_load(ctx: Context) -> sp.Expr:
    """Hertz point-contact load k·max(0, δ)^{3/2} (N), paper Eqs. 3 and 6."""
    return ctx.p("contact_stiffness") * sp.Max(0, deflection(ctx)) ** sp.Rational(3, 2)


class HertzContact(Term):
    """Hertz contact of every ball with both races, one combined stiffness ``k``.

    ``cage``: ``race_diameters`` is paper Eq. 1, ω_cage = ω·r/(R + r) with r = D_i/2 and
    R = D_o/2; ``pitch_diameter`` is the rolling-without-slip formula
    ω_cage = ω/2·(1 - D_b/D_m) (zero contact angle). The two agree when
    D_m = (D_i + D_o)/2 and D_o - D_i = 2 D_b.
    """

    kind: Literal["hertz_contact"] = "hertz_contact"
    cage: Literal["race_diameters", "pitch_diameter"] = "race_diameters"

    needs: ClassVar[tuple[str, ...]] = ("contact_stiffness", "radial_clearance", "speed_rpm")
    summary: ClassVar[str] = (
        "Hertz contact with clearance, load k·max(0, x cos θ_i + y sin θ_i − γ_0)^{3/2} "
        "per ball (paper Eqs. 3–6)"
    )

    def required_parameters(self) -> tuple[str, ...]:
        if self.cage == "race_diameters":
            return (*self.needs, "inner_race_diameter", "outer_race_diameter")
        return (*self.needs, "ball_diameter", "pitch_diameter")

    def cage_speed(self, ctx: Context) -> sp.Expr:
        """Cage angular speed ω_cage (rad/s)."""
        if self.cage == "race_diameters":
            d_i, d_o = ctx.p("inner_race_diameter"), ctx.p("outer_race_diameter")
            return ctx.omega * d_i / (d_i + d_o)
        d_b, d_m = ctx.p("ball_diameter"), ctx.p("pitch_diameter")
        return ctx.omega / 2 * (1 - d_b / d_m)

    def ball_load(self, ctx: Context) -> sp.Expr:
        return hertz_load(ctx)

    def describe(self) -> str:
        cage = {
            "race_diameters": "ω_cage = ω·D_i/(D_i + D_o) (paper Eq. 1)",
            "pitch_diameter": "ω_cage = ω/2·(1 − D_b/D_m) (rolling without slip)",
        }[self.cage]
        return f"{self.summary}; cage speed {cage}"
