"""Localized defects: a pit on the outer race, the inner race or one ball, as an offset of
the deflection of the ball that meets it (δ_i → δ_i − h_i(t), inside the contact law).

A ball over a pit is pressed less: its deflection drops by the depth h_i the ball actually
sinks into the pit, and the contact law (Hertz, two-contact, line) acts on the reduced
deflection. This is the model of the bearing-diagnostics literature (N. Sawalhi, R. B.
Randall, "Simulating gear and bearing interactions in the presence of faults", MSSP 22 (2008)
1924–1951; M. S. Patil et al., "A theoretical model to predict the effect of localized defect
on vibrations associated with ball bearing", Int. J. Mech. Sci. 52 (2010) 1193–1201), not an
added force.

Geometry (all lengths in m). The pit has a length L (``defect_length``, along the rolling
direction) and a depth H (``defect_depth``). On a race of contact radius R it spans the angle
Δφ = L/R around its centre; on a ball of radius ρ the angle Δβ = L/ρ. The ball cannot sink
deeper than where it touches both edges of the pit (two circles, chord geometry):

- outer race (concave, ball inside): r_c = R cos(Δφ/2) − √(ρ² − R² sin²(Δφ/2)),
  reach = r_c − (R − ρ);
- inner race (convex, ball outside): r_c = R cos(Δφ/2) + √(ρ² − R² sin²(Δφ/2)),
  reach = (R + ρ) − r_c;
- pit on the ball against the inner race of radius R_i:
  d = ρ cos(Δβ/2) + √(R_i² − ρ² sin²(Δβ/2)), reach = R_i + ρ − d; against the outer race
  R_o: d = √(R_o² − ρ² sin²(Δβ/2)) − ρ cos(Δβ/2), reach = d − (R_o − ρ).

The offset's amplitude is H_eff = min(H, reach) (Sawalhi & Randall 2008, Sec. 3.3, bound the
ball's path by the pit's edges in the same way). A race pit longer than the ball fits
(ρ < R sin(Δφ/2)) lets the ball reach the bottom: H_eff = H.

The contact radii and the ball's spin come from the bearing's contact term (its cage
option), so the pit moves with the model's own kinematics: with ``cage = "pitch_diameter"``
R_i, R_o = (D_m ∓ D_b cos α)/2, ρ = D_b/2; with ``race_diameters`` R_i = D_i/2, R_o = D_o/2,
ρ = (D_o − D_i)/4 (the ball that fits between the races, and the one Eq. 1's cage rolls).

Where the pit is, seen by ball i at θ_i = 2π(i−1)/N_b + ω_cage t (only cos θ_i = c and
sin θ_i = s of the ball and the time t are used, so the sum over the balls is still built at
run time for any N_b):

- ``race = "outer"``: fixed at φ_d = ``defect_angle`` (rad; 0 is +x, the direction of the
  radial load, the middle of the loaded zone). Ball i is over it while
  cos(θ_i − φ_d) > cos(Δφ/2), cos(θ_i − φ_d) = c cos φ_d + s sin φ_d;
- ``race = "inner"``: turning with the shaft, φ_d(t) = ``defect_angle`` + ω t;
- ``race = "ball"``: on ball number ``ball`` (1 … N_b), turning with the ball's spin
  relative to the cage, β(t) = ``defect_angle`` + ω_spin t, ω_spin = ω_cage R_o/ρ (rolling
  without slip on the outer race). The pit meets the outer race while cos β > cos(Δβ/2)
  and the inner race while −cos β > cos(Δβ/2): two strikes per spin turn (2·BSF).

Profiles (``profile``) of the offset across the pit, u the angle from the pit's centre:

- ``rectangular``: h = H_eff (the ball drops at the edge; Sawalhi & Randall 2008);
- ``half_sine``: h = H_eff cos(π u/Δ) over |u| < Δ/2 (Δ the pit's angle), continuous at the
  edges (A. Rafsanjani et al., "Nonlinear dynamic modeling of surface defects in rolling
  element bearing systems", J. Sound Vib. 319 (2009) 1150–1174, use this smooth entry and
  exit). This is the default: a continuous offset keeps RK4's error at its order and the
  Jacobian finite; the window is a select (``ca.if_else``) whose discarded side is zero.

With ``defect_depth = 0`` every offset is exactly 0·(finite) = 0 and the model computes what
the defect-free model computes, bit for bit (``tests/signal/test_faults.py``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, Literal

from pydantic import Field

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Owner, Term

if TYPE_CHECKING:
    from modelgen.terms.contact import HertzContact

Race = Literal["outer", "inner", "ball"]
Profile = Literal["rectangular", "half_sine"]


def window(cos_u: sp.Expr, half_width: sp.Expr) -> sp.Expr:
    """1 while the angle u from a pit's centre is within ±half_width (cos u > cos half_width),
    else 0: a select in the generated code."""
    return sp.Heaviside(cos_u - sp.cos(half_width))


def profile_shape(profile: Profile, cos_u: sp.Expr, sin_u: sp.Expr,
                  width: sp.Expr) -> sp.Expr:
    """The profile over a pit of angle ``width`` (rad), at the angle u from its centre given by
    (cos u, sin u): 1 (rectangular) or cos(π u/width) (half-sine), times the window."""
    inside = window(cos_u, width / 2)
    if profile == "rectangular":
        return inside
    return inside * sp.cos(sp.pi * sp.atan2(sin_u, cos_u) / width)


def race_reach(rho: sp.Expr, radius: sp.Expr, width: sp.Expr, race: str,
               depth: sp.Expr) -> sp.Expr:
    """The depth a ball of radius ``rho`` sinks into a pit of angle ``width`` on a race of
    contact radius ``radius`` (m); ``depth`` where the pit is longer than the ball spans."""
    half = width / 2
    room = rho**2 - radius**2 * sp.sin(half) ** 2
    root = sp.sqrt(sp.Max(0, room))
    if race == "outer":
        reach = radius * sp.cos(half) - root - (radius - rho)
    else:
        reach = radius + rho - radius * sp.cos(half) - root
    fits = sp.Heaviside(room)
    return fits * reach + (1 - fits) * depth


def ball_reach(rho: sp.Expr, radius: sp.Expr, width: sp.Expr, race: str) -> sp.Expr:
    """The depth a race of contact radius ``radius`` enters a pit of angle ``width`` on a ball
    of radius ``rho`` (m)."""
    half = width / 2
    root = sp.sqrt(radius**2 - rho**2 * sp.sin(half) ** 2)
    if race == "outer":
        return root - rho * sp.cos(half) - (radius - rho)
    return radius + rho - rho * sp.cos(half) - root


def ball_selector(ctx: Context, ball: int) -> sp.Expr:
    """1 for ball number ``ball`` (the index i of the generated ball load is an integer),
    else 0."""
    return sp.Heaviside(sp.Rational(1, 2) - sp.Abs(ctx.i - ball))


class LocalizedDefect(Term):
    """A pit on the outer race, the inner race or one ball: an offset of the deflection of the
    ball that meets it (see the module docstring for the geometry and the sources)."""

    kind: Literal["localized_defect"] = "localized_defect"
    race: Race = "outer"
    """Where the pit is: ``outer`` (fixed), ``inner`` (turning with the shaft) or ``ball``."""
    profile: Profile = "half_sine"
    """The offset across the pit: ``half_sine`` (continuous) or ``rectangular``."""
    ball: int = Field(1, ge=1, le=64)
    """With ``race = "ball"``: the number (1 … N_b) of the ball with the pit."""

    needs: ClassVar[tuple[str, ...]] = ("defect_depth", "defect_length", "defect_angle")
    attaches: ClassVar[tuple[Owner, ...]] = ("bearing",)
    gated: ClassVar[bool] = False
    summary: ClassVar[str] = "localized defect: offset of the ball's deflection, δ_i − h_i(t)"

    def required_parameters(self) -> tuple[str, ...]:
        return (*self.needs, "speed_rpm")

    def deflection_offset(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        """h_i(t) of one ball (m), in terms of ``ctx.c``, ``ctx.s``, ``ctx.i`` and ``ctx.t``."""
        depth, length = ctx.p("defect_depth"), ctx.p("defect_length")
        angle = ctx.p("defect_angle")
        r_i, r_o, rho = contact.contact_radii(ctx)
        if self.race == "ball":
            width = length / rho
            beta = angle + contact.spin_speed(ctx) * ctx.t
            cb, sb = sp.cos(beta), sp.sin(beta)
            outer = sp.Min(depth, ball_reach(rho, r_o, width, "outer"))
            inner = sp.Min(depth, ball_reach(rho, r_i, width, "inner"))
            strikes = (outer * profile_shape(self.profile, cb, sb, width)
                       + inner * profile_shape(self.profile, -cb, -sb, width))
            return ball_selector(ctx, self.ball) * strikes
        radius = r_o if self.race == "outer" else r_i
        width = length / radius
        phi = angle if self.race == "outer" else angle + ctx.omega * ctx.t
        cos_u = ctx.c * sp.cos(phi) + ctx.s * sp.sin(phi)  # cos(θ_i − φ_d)
        sin_u = ctx.s * sp.cos(phi) - ctx.c * sp.sin(phi)  # sin(θ_i − φ_d)
        reach = race_reach(rho, radius, width, self.race, depth)
        return sp.Min(depth, reach) * profile_shape(self.profile, cos_u, sin_u, width)

    def describe(self) -> str:
        where = {"outer": "on the outer race at φ_d = defect_angle",
                 "inner": "on the inner race at φ_d = defect_angle + ω t",
                 "ball": f"on ball {self.ball}, at spin angle defect_angle + ω_spin t"}[self.race]
        shape = {"half_sine": "half-sine", "rectangular": "rectangular"}[self.profile]
        return (f"localized defect {where}: {shape} offset h_i(t) of the ball's deflection "
                "(δ_i → δ_i − h_i inside the contact law), depth min(defect_depth, the depth a "
                "ball reaches in a pit of defect_length) (modelgen/terms/defects.py)")
