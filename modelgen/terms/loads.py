"""External loads on the rotor: constant radial load, rotating unbalance (paper Eq. 11-12) and a
harmonic force in x synchronous with the shaft."""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Term


class RadialLoad(Term):
    kind: Literal["radial_load"] = "radial_load"

    needs: ClassVar[tuple[str, ...]] = ("radial_load",)
    summary: ClassVar[str] = "constant radial load P_r in +x"

    def role_quantities(self) -> dict[str, str]:
        return {"radial_load": "radial_load"}

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        return (ctx.p("radial_load"), sp.Integer(0))


class Unbalance(Term):
    kind: Literal["unbalance"] = "unbalance"

    needs: ClassVar[tuple[str, ...]] = ("unbalance_force", "speed_rpm")
    summary: ClassVar[str] = "rotating unbalance P_u·(cos ωt, sin ωt)"

    def role_quantities(self) -> dict[str, str]:
        return {"unbalance_force": "unbalance_force"}

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        p_u, wt = ctx.p("unbalance_force"), ctx.omega * ctx.t
        return (p_u * sp.cos(wt), p_u * sp.sin(wt))


class HarmonicForce(Term):
    """F·cos(ωt) in x (N), ω the shaft speed: a unidirectional synchronous excitation."""

    kind: Literal["harmonic_force"] = "harmonic_force"

    needs: ClassVar[tuple[str, ...]] = ("forcing_amplitude", "speed_rpm")
    summary: ClassVar[str] = "harmonic force F·cos(ωt) in x"

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr]:
        return (ctx.p("forcing_amplitude") * sp.cos(ctx.omega * ctx.t), sp.Integer(0))
