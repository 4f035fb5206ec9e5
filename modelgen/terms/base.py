"""What a force term is: a validated spec entry that returns SymPy force expressions.

A term attaches to a **body** or to a **bearing** (``body = "…"`` / ``bearing = "…"`` in the
spec; left out when the model has one body or one bearing). It contributes

- ``body_force``: a force (F_x, F_y) in N. On a body it acts at the body's centre; on a
  bearing it acts between the bearing's races (on the inner body, and the opposite on the
  outer one), with ``ctx.x, ctx.vx`` … the relative motion of the races;
- ``ball_load``: the radial load of every rolling element of a bearing (N, positive when
  the ball pushes the inner race back towards the bearing centre). A ball load marked
  ``gated`` acts only while the ball is in contact: the gated loads of one ball are summed
  and clamped at zero, because a ball can push the inner race but never pull it.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, model_serializer

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context

Owner = Literal["body", "bearing"]
OWNER_NAME = r"^[a-z][a-z0-9_]{0,23}$"
"""Names of bodies and bearings: lower case letters, digits and '_' (at most 24)."""
ROLE_NAMES = ("clearance", "ball_diameter", "contact_stiffness", "radial_load",
              "unbalance_force", "forcing_period")
"""What a parameter can be to the analysis layer: the radial clearance γ_0 (m), the ball
diameter D_b (m), the Hertz constant k of Q = k δ^{3/2} (N/m^1.5), the constant radial load
P_r (N), the unbalance force P_u (N) and the period of a forcing held by a parameter (s)."""


class Term(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    body: str | None = Field(None, pattern=OWNER_NAME)
    """The body the term acts on (default: the model's only body)."""
    bearing: str | None = Field(None, pattern=OWNER_NAME)
    """The bearing the term belongs to (default: the model's only bearing)."""
    bind: dict[str, str] | None = None
    """Parameters of other names: ``bind = { radial_clearance = "gap" }`` reads the quantity
    ``radial_clearance`` from the spec's parameter ``gap`` (declared with its unit and range)."""

    needs: ClassVar[tuple[str, ...]] = ()
    """Runtime parameters the term's expressions use."""
    attaches: ClassVar[tuple[Owner, ...]] = ("body",)
    """Where the term may act, the default first."""
    gated: ClassVar[bool] = True
    """Whether the ball load acts only while the ball is in contact."""
    summary: ClassVar[str] = ""
    """One line for the model card."""

    @model_serializer(mode="wrap")
    def _omit_unset(self, handler):
        """Leave out what is not given, so a dump is valid TOML (no None)."""
        return {k: v for k, v in handler(self).items() if v is not None}

    def owners(self) -> tuple[Owner, ...]:
        """Where this term, as configured, acts (a body, a bearing, or both)."""
        return self.attaches[:1]

    def required_parameters(self) -> tuple[str, ...]:
        """Runtime parameters this term, as configured, needs."""
        return self.needs

    def bound_name(self, name: str) -> str:
        """The spec's parameter this term reads for quantity ``name`` (its ``bind``)."""
        return (self.bind or {}).get(name, name)

    def bound(self, ctx: Context) -> Context:
        """``ctx`` reading this term's bound parameters (``bind``)."""
        if not self.bind:
            return ctx
        return dataclasses.replace(ctx, aliases={**ctx.aliases, **self.bind})

    def role_quantities(self) -> dict[str, str]:
        """Role (``ROLE_NAMES``) -> the quantity this term, as configured, reads for it."""
        return {}

    def is_gated(self) -> bool:
        """Whether this term's ball load acts only while the ball is in contact."""
        return self.gated

    def ball_load(self, ctx: Context) -> sp.Expr | None:
        """Radial load of one ball on the inner race (N), in terms of ``ctx.c``, ``ctx.s``."""
        return None

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr] | None:
        """Force (F_x, F_y) in N on the body in scope (or between a bearing's races)."""
        return None

    def describe(self) -> str:
        """Markdown description of the term as configured (for MODEL.md)."""
        return self.summary
