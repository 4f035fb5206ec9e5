"""Per-ball contact damping: the nonlinear damping of paper Eq. 10 as a contact law.

The paper's Eq. 10 states a per-ball damping force c(r)·ṙ^q and never uses it (docs/
paper-slips.md S7). We use the law of Hunt & Crossley (K. H. Hunt, F. R. E. Crossley,
"Coefficient of restitution interpreted as damping in vibroimpact", J. Appl. Mech. 42 (1975)
440–445), the usual choice for Hertz contacts:

    Q = K δ^{3/2} (1 + (3/2) α δ̇)        (N; δ in m, δ̇ in m/s)

i.e. c·δ^e·δ̇ with e = 3/2 and c = (3/2) α K. The damping grows with the contact area, so the
force is continuous at touch-down and lift-off (no pull at δ = 0, unlike a viscous dashpot
per ball). α (s/m, ``hunt_crossley_damping``) sets the energy lost in an impact: for a
collision at approach speed v, the coefficient of restitution is e ≈ 1 − α v when α v ≪ 1.
A ball cannot pull the race: where a fast separation makes the factor negative, the load is
clamped at zero.

The approach rate of ball i follows from δ_i = x cos θ_i + y sin θ_i − γ_0 with
θ̇_i = ω_cage: δ̇_i = ẋ cos θ_i + ẏ sin θ_i + ω_cage (−x sin θ_i + y cos θ_i).
"""

from __future__ import annotations

from typing import Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context

DampingLaw = Literal["none", "hunt_crossley"]
DAMPING_PARAMETERS: dict[str, tuple[str, ...]] = {
    "none": (), "hunt_crossley": ("hunt_crossley_damping",),
}
"""Runtime parameters each contact-damping law needs."""


def deflection_rate(ctx: Context) -> sp.Expr:
    """dδ_i/dt of one ball (m/s): rotor velocity and the ball moving with the cage."""
    rate = (ctx.vx * ctx.c + ctx.vy * ctx.s
            + ctx.omega_cage * (-ctx.x * ctx.s + ctx.y * ctx.c))
    h = ctx.offset  # a defect's or waviness' offset h_i(c, s, t) moves with the ball too
    if h == 0:
        return rate
    h_rate = (sp.diff(h, ctx.t)
              + ctx.omega_cage * (-ctx.s * sp.diff(h, ctx.c) + ctx.c * sp.diff(h, ctx.s)))
    # the pit's edges (selects) count as fixed: their derivative is zero off the edge
    return rate - h_rate.replace(sp.DiracDelta, lambda *args: sp.Integer(0))


def damping_factor(ctx: Context, law: DampingLaw) -> sp.Expr:
    """Factor on the elastic load K δ^{3/2}: max(0, 1 + (3/2) α δ̇) (Hunt–Crossley) or 1."""
    if law == "none":
        return sp.Integer(1)
    alpha = ctx.p("hunt_crossley_damping")
    return sp.Max(0, 1 + sp.Rational(3, 2) * alpha * deflection_rate(ctx))


def describe_damping(law: DampingLaw) -> str:
    """Markdown of the law for the model card ('' without damping)."""
    if law == "none":
        return ""
    return ("; Hunt–Crossley contact damping, load × max(0, 1 + 3/2·α·δ̇_i), "
            "δ̇_i = ẋ cos θ_i + ẏ sin θ_i + ω_cage(−x sin θ_i + y cos θ_i)")
