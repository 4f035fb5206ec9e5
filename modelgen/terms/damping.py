"""Damping terms.

``viscous_damping``: F = -c·(ẋ, ẏ) on the rotor (N), c in N·s/m. This is the paper's Eq. 10
with q = 1 and the per-ball coefficients lumped into one rotor-level coefficient; the phase
space then contracts at the constant rate -2c/M_R (used by the Liouville tests).
"""

from __future__ import annotations

from typing import ClassVar, Literal

import sympy as sp

from modelgen.symbols import Context
from modelgen.terms.base import Term


class ViscousDamping(Term):
    kind: Literal["viscous_damping"] = "viscous_damping"

    needs: ClassVar[tuple[str, ...]] = ("damping",)
    summary: ClassVar[str] = "linear viscous damping −c·(ẋ, ẏ) on the rotor"

    def rotor_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        c = ctx.p("damping")
        return (-c * ctx.vx, -c * ctx.vy)
