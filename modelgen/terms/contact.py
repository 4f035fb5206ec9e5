"""Hertz ball contact with radial clearance, and the cage kinematics that move the balls.

Paper Eqs. 1-6: ball i sits at θ_i = 2π(i-1)/N_b + ω_cage t and is compressed by
δ_i = x cos θ_i + y sin θ_i - γ_0 (m); its load on the rotor is k·max(0, δ_i)^{3/2} (N).

Options of ``hertz_contact`` (each with the paper's reading as default):

- ``stiffness``: ``given`` uses the parameter ``contact_stiffness`` k; ``geometry`` computes
  k from the ball, the groove conformities and the material, Hertz point contact at both
  races in series (``modelgen/hertz.py``), as an expression of those runtime parameters;
- ``clearance``: ``radial`` takes γ_0 = ``radial_clearance`` (the clearance of one ball in
  Eq. 5); ``diametral`` takes the total free play P_d = ``diametral_clearance`` of bearing
  catalogues and γ_0 = P_d/2 (docs/paper-slips.md S6);
- ``damping``: ``none`` or ``hunt_crossley`` (per-ball contact damping, paper Eq. 10;
  ``modelgen/terms/contact_damping.py``).
"""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.hertz import combined_stiffness, race_stiffness_class
from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Owner, Term
from modelgen.terms.contact_damping import (
    DAMPING_PARAMETERS,
    DampingLaw,
    damping_factor,
    describe_damping,
)

Clearance = Literal["radial", "diametral"]
CLEARANCE_PARAMETER: dict[str, str] = {"radial": "radial_clearance",
                                       "diametral": "diametral_clearance"}
"""The parameter each clearance convention reads."""
GEOMETRY_PARAMETERS = ("ball_diameter", "pitch_diameter", "groove_conformity_inner",
                       "groove_conformity_outer", "youngs_modulus", "poisson_ratio")
"""What the contact stiffness is computed from with ``stiffness = "geometry"``."""
STIFFNESS_PARAMETERS: dict[str, tuple[str, ...]] = {
    "given": ("contact_stiffness",), "geometry": GEOMETRY_PARAMETERS,
}


def clearance(ctx: Context, convention: Clearance = "radial") -> sp.Expr:
    """γ_0 of Eq. 5 (m): the radial clearance, or half the diametral clearance."""
    value = ctx.p(CLEARANCE_PARAMETER[convention])
    return value if convention == "radial" else value / 2


def deflection(ctx: Context, convention: Clearance = "radial") -> sp.Expr:
    """Contact deflection δ_i of one ball (m), paper Eq. 5, less the offset h_i of the
    bearing's defects and waviness (``ctx.offset``, 0 without them)."""
    return ctx.x * ctx.c + ctx.y * ctx.s - clearance(ctx, convention) - ctx.offset


def contact_cosine(ctx: Context) -> sp.Expr:
    """cos α of the contact angle α (``contact_angle``, rad) when the spec declares it, else 1.
    α enters the kinematics only (cage and ball spin with ``cage = "pitch_diameter"``); the
    loads stay radial."""
    return sp.cos(ctx.p("contact_angle")) if ctx.has("contact_angle") else sp.Integer(1)


def race_stiffnesses(ctx: Context) -> tuple[sp.Expr, sp.Expr]:
    """(K_i, K_o): ball–inner-race and ball–outer-race Hertz constants (N/m^1.5)."""
    args = [ctx.p(n) for n in ("ball_diameter", "pitch_diameter")]
    material = [ctx.p("youngs_modulus"), ctx.p("poisson_ratio")]
    race_stiffness = race_stiffness_class()
    return (race_stiffness(*args, ctx.p("groove_conformity_inner"), *material, 1),
            race_stiffness(*args, ctx.p("groove_conformity_outer"), *material, -1))


class HertzContact(Term):
    """Hertz contact of every ball with both races, one combined stiffness ``k``.

    ``cage``: ``race_diameters`` is paper Eq. 1, ω_cage = ω·r/(R + r) with r = D_i/2 and
    R = D_o/2; ``pitch_diameter`` is the rolling-without-slip formula
    ω_cage = ω/2·(1 - D_b/D_m) (zero contact angle). The two agree when
    D_m = (D_i + D_o)/2 and D_o - D_i = 2 D_b.
    """

    kind: Literal["hertz_contact"] = "hertz_contact"
    cage: Literal["race_diameters", "pitch_diameter"] = "race_diameters"
    """Cage speed: ``race_diameters`` ω·D_i/(D_i + D_o) (paper Eq. 1) or ``pitch_diameter`` ω/2·(1 −
    D_b/D_m) (rolling without slip)."""
    stiffness: Literal["given", "geometry"] = "given"
    """``given``: the parameter ``contact_stiffness``; ``geometry``: k from the ball, groove
    conformities and material (Hertz)."""
    clearance: Clearance = "radial"
    """``radial``: γ_0 = ``radial_clearance``; ``diametral``: γ_0 = ``diametral_clearance``/2."""
    damping: DampingLaw = "none"
    """Per-ball contact damping: ``none`` or ``hunt_crossley`` (``hunt_crossley_damping``)."""

    needs: ClassVar[tuple[str, ...]] = ("speed_rpm",)
    attaches: ClassVar[tuple[Owner, ...]] = ("bearing",)
    summary: ClassVar[str] = (
        "Hertz contact with clearance, load k·max(0, x cos θ_i + y sin θ_i − γ_0)^(3/2) "
        "per ball (paper Eqs. 3–6)"
    )

    def required_parameters(self) -> tuple[str, ...]:
        cage = (("inner_race_diameter", "outer_race_diameter")
                if self.cage == "race_diameters" else ("ball_diameter", "pitch_diameter"))
        names = (*STIFFNESS_PARAMETERS[self.stiffness], CLEARANCE_PARAMETER[self.clearance],
                 *self.needs, *cage, *DAMPING_PARAMETERS[self.damping])
        return tuple(dict.fromkeys(names))

    def role_quantities(self) -> dict[str, str]:
        """The radial clearance γ_0 (not a diametral one), the ball diameter of the bearing
        (its geometry, whether or not the cage reads it) and a given Hertz constant k."""
        roles = {"ball_diameter": "ball_diameter"}
        if self.clearance == "radial":
            roles["clearance"] = "radial_clearance"
        if self.stiffness == "given":
            roles["contact_stiffness"] = "contact_stiffness"
        return roles

    def cage_speed(self, ctx: Context) -> sp.Expr:
        """Cage angular speed ω_cage (rad/s)."""
        if self.cage == "race_diameters":
            d_i, d_o = ctx.p("inner_race_diameter"), ctx.p("outer_race_diameter")
            return ctx.omega * d_i / (d_i + d_o)
        d_b, d_m = ctx.p("ball_diameter"), ctx.p("pitch_diameter")
        return ctx.omega / 2 * (1 - d_b * contact_cosine(ctx) / d_m)

    def contact_radii(self, ctx: Context) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """(R_i, R_o, ρ) in m: the radii of the inner and outer race contacts and of the ball
        that this cage option's kinematics roll: (D_m ∓ D_b cos α)/2 and D_b/2 with
        ``pitch_diameter``; D_i/2, D_o/2 and (D_o − D_i)/4 with ``race_diameters``."""
        if self.cage == "race_diameters":
            d_i, d_o = ctx.p("inner_race_diameter"), ctx.p("outer_race_diameter")
            return d_i / 2, d_o / 2, (d_o - d_i) / 4
        d_b, d_m = ctx.p("ball_diameter"), ctx.p("pitch_diameter")
        lever = d_b * contact_cosine(ctx)
        return (d_m - lever) / 2, (d_m + lever) / 2, d_b / 2

    def spin_speed(self, ctx: Context) -> sp.Expr:
        """The ball's spin relative to the cage (rad/s), rolling without slip on the outer
        race: ω_cage R_o/ρ (its frequency is the BSF; with ``race_diameters`` the same ball
        also rolls without slip on the inner race)."""
        _, r_o, rho = self.contact_radii(ctx)
        return self.cage_speed(ctx) * r_o / rho

    def stiffness_constant(self, ctx: Context) -> sp.Expr:
        """k of Q = k δ^{3/2} (N/m^1.5): given, or both races in series from the geometry."""
        if self.stiffness == "given":
            return ctx.p("contact_stiffness")
        return combined_stiffness(*race_stiffnesses(ctx))

    def ball_load(self, ctx: Context) -> sp.Expr:
        delta = deflection(ctx, self.clearance)
        elastic = self.stiffness_constant(ctx) * sp.Max(0, delta) ** sp.Rational(3, 2)
        return elastic * damping_factor(ctx, self.damping)

    def describe(self) -> str:
        cage = {
            "race_diameters": "ω_cage = ω·D_i/(D_i + D_o) (paper Eq. 1)",
            "pitch_diameter": "ω_cage = ω/2·(1 − D_b/D_m) (rolling without slip)",
        }[self.cage]
        clearance = ("; γ_0 = P_d/2 from the diametral clearance P_d"
                     if self.clearance == "diametral" else "")
        return (f"{self.summary}; cage speed {cage}{self._describe_stiffness()}{clearance}"
                f"{describe_damping(self.damping)}")

    def _describe_stiffness(self) -> str:
        if self.stiffness == "given":
            return ""
        return ("; k = [K_i^(−2/3) + K_o^(−2/3)]^(−3/2) from Hertz point contact at the inner "
                "and outer race (groove conformities f_i, f_o, E, ν; modelgen/hertz.py)")
