"""What a force term is: a validated spec entry that returns SymPy force expressions.

A term contributes either to the radial load of every ball (``ball_load``, N, positive when
the ball pushes the rotor back towards the bearing centre) or directly to the rotor
(``rotor_force``, (F_x, F_y) in N), or both. A ball load marked ``gated`` acts only while the
ball is in contact: the gated loads of one ball are summed and clamped at zero, because a
ball can push the inner race but never pull it.
"""

from __future__ import annotations

from typing import ClassVar

import sympy as sp
from pydantic import BaseModel, ConfigDict

from modelgen.symbols import Context


class Term(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    needs: ClassVar[tuple[str, ...]] = ()
    """Runtime parameters the term's expressions use."""
    gated: ClassVar[bool] = True
    """Whether the ball load acts only while the ball is in contact."""
    summary: ClassVar[str] = ""
    """One line for the model card."""

    def required_parameters(self) -> tuple[str, ...]:
        """Runtime parameters this term, as configured, needs."""
        return self.needs

    def is_gated(self) -> bool:
        """Whether this term's ball load acts only while the ball is in contact."""
        return self.gated

    def ball_load(self, ctx: Context) -> sp.Expr | None:
        """Radial load of one ball on the rotor (N), in terms of ``ctx.c``, ``ctx.s``."""
        return None

    def rotor_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr] | None:
        """External force on the rotor (F_x, F_y) in N."""
        return None

    def describe(self) -> str:
        """Markdown description of the term as configured (for MODEL.md)."""
        return self.summary
