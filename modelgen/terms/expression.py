"""A custom force term written in the spec as expressions (``kind = "expression"``).

    [[terms]]
    kind = "expression"
    description = "cubic support spring"
    fx = "-k3*x**3"              # N, force on the rotor in x
    fy = "-k3*y**3"              # N, force on the rotor in y
    ball = "cb*(vx*c + vy*s)"    # N, radial load of every ball, only while it is in contact

``fx``, ``fy`` (force on the term's body, N) may use every state name of the model (``x, y,
vx, vy`` in a one-body model; ``x_rotor, vx_housing`` … with several bodies; m, m/s, rad,
rad/s), the time ``t`` (s), ``omega`` (shaft speed, rad/s), ``pi`` and the model's
parameters. ``ball`` (the radial load of one ball of the term's bearing on its inner race,
N, positive pushing it back towards the bearing centre) may also use ``c = cos θ_i``,
``s = sin θ_i``, ``theta`` (θ_i, rad), the ball index ``i`` (1 … N_b), ``n_balls`` (N_b) and
``delta``, the contact deflection δ_i = x c + y s − γ_0 (m) of the races' relative
displacement. The ball load is gated: it acts only while δ_i > 0, and it is added to the
Hertz load before the sum is clamped at zero (a ball never pulls). Parameters that are not
built-in quantities are declared in the spec with a unit and a range (``low``, ``high``).
The strings are read by ``modelgen.expressions`` (a whitelist over Python's syntax tree);
nothing in them is ever executed.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import ValidationInfo, field_validator, model_validator

from modelgen.expressions import check_expression, parse_expression
from modelgen.lazy import sympy as sp
from modelgen.symbols import STATE_NAMES, Context
from modelgen.terms.base import Owner, Term
from modelgen.terms.contact import deflection

TIME_SYMBOLS = ("t", "omega")
"""Names every force expression may use besides the state, parameters (and ``pi``)."""
ROTOR_SYMBOLS = (*STATE_NAMES, *TIME_SYMBOLS)
"""The symbols of a one-body model's expressions (besides parameters)."""
BALL_SYMBOLS = ("c", "s", "delta", "theta", "i", "n_balls")
"""Names only the per-ball expression ``ball`` may use."""
IMPLIED_PARAMETERS = {"delta": "radial_clearance", "omega": "speed_rpm"}
"""Parameters a symbol is computed from."""


class ExpressionTerm(Term):
    kind: Literal["expression"] = "expression"
    description: str = ""
    """What the term models, in words (for the model card)."""
    fx: str | None = None
    """Force on the rotor in x, N."""
    fy: str | None = None
    """Force on the rotor in y, N."""
    ball: str | None = None
    """Radial load of each ball in contact, N (gated)."""
    period: str | None = None
    """The parameter that holds the period (s) of the forcing the expressions describe, for
    the analysis layer (sections, spectra; default ``forcing_period`` when they use it)."""

    summary: ClassVar[str] = "custom expression"

    @field_validator("fx", "fy", "ball")
    @classmethod
    def _whitelisted(cls, text: str | None, info: ValidationInfo) -> str | None:
        if text is None:
            return None
        names = check_expression(text)
        ball_only = sorted(names & set(BALL_SYMBOLS))
        if info.field_name != "ball" and ball_only:
            raise ValueError(f"'{ball_only[0]}' is a per-ball symbol; it may be used in "
                             "'ball' only")
        return text

    @model_validator(mode="after")
    def _not_empty(self) -> ExpressionTerm:
        if self.fx is None and self.fy is None and self.ball is None:
            raise ValueError("an expression term needs at least one of fx, fy, ball")
        return self

    def owners(self) -> tuple[Owner, ...]:
        return ((("body",) if self.fx is not None or self.fy is not None else ())
                + (("bearing",) if self.ball is not None else ()))

    def expressions(self) -> dict[str, str]:
        """The given expression strings by field name."""
        return {k: v for k, v in (("fx", self.fx), ("fy", self.fy), ("ball", self.ball))
                if v is not None}

    def names(self, state: tuple[str, ...] = STATE_NAMES) -> dict[str, frozenset[str]]:
        """Names each expression uses that must be parameters (not symbols of a model with
        the state names ``state``)."""
        symbols = {*state, *TIME_SYMBOLS, *BALL_SYMBOLS}
        return {k: check_expression(v) - symbols for k, v in self.expressions().items()}

    def required_parameters(self, state: tuple[str, ...] = STATE_NAMES) -> tuple[str, ...]:
        used: set[str] = set().union(*(check_expression(v) for v in self.expressions().values()))
        implied = {IMPLIED_PARAMETERS[n] for n in used if n in IMPLIED_PARAMETERS}
        symbols = {*state, *TIME_SYMBOLS, *BALL_SYMBOLS}
        return tuple(sorted((used - symbols) | implied))

    def role_quantities(self) -> dict[str, str]:
        """The forcing period: ``period``, or ``forcing_period`` when the expressions use it."""
        used = set(self.required_parameters(()))
        name = self.period or ("forcing_period" if "forcing_period" in used else None)
        return {"forcing_period": name} if name is not None else {}

    def _symbols(self, ctx: Context, ball: bool) -> dict[str, sp.Expr]:
        table: dict[str, sp.Expr] = dict(ctx.named)
        table.update(t=ctx.t, omega=ctx.omega)
        if ball:
            table.update(c=ctx.c, s=ctx.s, theta=sp.atan2(ctx.s, ctx.c), i=ctx.i,
                         n_balls=ctx.n_balls)
            if ctx.has("radial_clearance"):
                table["delta"] = deflection(ctx)
        table.update(ctx.params)
        return table

    def parse(self, field: str, ctx: Context) -> sp.Expr:
        """The SymPy expression of ``field`` (fx, fy or ball; 0 when not given), N."""
        text = getattr(self, field)
        if text is None:
            return sp.Integer(0)
        return parse_expression(text, self._symbols(ctx, ball=field == "ball"))

    def body_force(self, ctx: Context) -> tuple[sp.Expr, sp.Expr] | None:
        if self.fx is None and self.fy is None:
            return None
        return self.parse("fx", ctx), self.parse("fy", ctx)

    def ball_load(self, ctx: Context) -> sp.Expr | None:
        if self.ball is None:
            return None
        return sp.Heaviside(deflection(ctx), 0) * self.parse("ball", ctx)

    def describe(self) -> str:
        parts = [f"F_x = {self.fx}" if self.fx else "", f"F_y = {self.fy}" if self.fy else "",
                 f"ball load in contact Q_i = {self.ball}" if self.ball else ""]
        what = f"{self.description}: " if self.description else ""
        return f"{what}custom expression, " + ", ".join(p for p in parts if p)
