"""Springs acting on the rotor directly (not through balls).

``cubic_spring``: F = −k_1·(x, y) − k_3·(x³, y³) (N), k_1 in N/m, k_3 in N/m³: with a harmonic
force and viscous damping it makes the forced Duffing oscillator, the textbook system the
stability tools are validated on.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Term


class CubicSpring(Term):
    kind: Literal["cubic_spring"] = "cubic_spring"

    needs: ClassVar[tuple[str, ...]] = ("linear_stiffness", "cubic_stiffness")
    summary: ClassVar[str] = "spring −k_1·(x, y) − k_3·(x³, y³) on the rotor"

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        k1, k3 = ctx.p("linear_stiffness"), ctx.p("cubic_stiffness")
        return (-k1 * ctx.x - k3 * ctx.x**3, -k1 * ctx.y - k3 * ctx.y**3)
