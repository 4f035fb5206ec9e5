"""Damping terms.

``viscous_damping``: F = -c·(ẋ, ẏ) (N), c in N·s/m. On a body it damps the body's absolute
velocity; on a bearing it damps the relative velocity of the races (the reaction acts on the
outer body). This is the paper's Eq. 10 with q = 1 and the per-ball coefficients lumped into
one coefficient; the phase space of the one-body model then contracts at the constant rate
-2c/M_R (used by the Liouville tests).
"""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Owner, Term


class ViscousDamping(Term):
    kind: Literal["viscous_damping"] = "viscous_damping"

    needs: ClassVar[tuple[str, ...]] = ("damping",)
    attaches: ClassVar[tuple[Owner, ...]] = ("body", "bearing")
    summary: ClassVar[str] = "linear viscous damping −c·(ẋ, ẏ)"

    def owners(self) -> tuple[Owner, ...]:
        return ("bearing",) if self.bearing is not None else ("body",)

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        c = ctx.p("damping")
        return (-c * ctx.vx, -c * ctx.vy)
