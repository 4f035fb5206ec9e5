"""Waviness of the races and the balls: an offset of every ball's deflection,
δ_i → δ_i − h_i(t), as for a localized defect (``modelgen/terms/defects.py``).

A wavy surface deviates from its circle by Σ_k A_k cos(k φ) (m) at the angle φ of the
surface, outwards positive, for the orders k (``orders``, lobes per turn) and amplitudes
A_k (``amplitudes``: the names of the runtime parameters that hold them, m). The models
of S. P. Harsha, K. Sandeep, R. Prakash, "Non-linear dynamic behaviors of rolling element
bearings due to surface waviness", J. Sound Vib. 272 (2004) 557–580, and N. Aktürk, "The
effect of waviness on vibrations associated with ball bearings", J. Tribol. 121 (1999)
667–677, add it to the deflection of each ball in the same way:

- ``outer_race_waviness``: the outer race is fixed; ball i at θ_i meets it at φ = θ_i:
  h_i = Σ A_k cos(k θ_i) (an outward bulge opens the contact);
- ``inner_race_waviness``: the inner race turns with the shaft; ball i meets it at
  φ = θ_i − ω t: h_i = −Σ A_k cos(k (θ_i − ω t)) (an outward bulge of the inner race closes
  the contact);
- ``ball_waviness``: every ball (or the one numbered ``ball``) has the same profile,
  turning with its spin relative to the cage β = ω_spin t; it touches the outer race at β
  and the inner race at β + π, so its diameter along the contact line changes by
  Σ A_k [cos(k β) + cos(k (β + π))] and h_i = −Σ A_k cos(k β)(1 + (−1)^k): only even
  orders act (Harsha et al. 2004, Sec. 2.2).

θ_i = atan2(sin θ_i, cos θ_i) is computed from the ball's (cos θ_i, sin θ_i), so the sum over
balls is still built at run time for any N_b. Known consequence (Wardle 1988; Aktürk 1999),
checked in ``tests/modelgen/test_faults_waviness.py``: outer-race orders k = q N_b ± 1 produce a
radial force at q·BPFO, other orders none.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, ClassVar, Literal

from pydantic import Field, model_validator

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.base import Owner, Term
from modelgen.terms.defects import ball_selector

if TYPE_CHECKING:
    from modelgen.terms.contact import HertzContact

PARAMETER_NAME = r"^[a-z][a-z0-9_]{0,31}$"


class Waviness(Term):
    """Race or ball waviness of given orders; amplitudes are runtime parameters (m)."""

    orders: list[int] = Field(min_length=1, max_length=16)
    """Waviness orders (lobes per turn), each in [1, 200]."""
    amplitudes: list[str] = Field(min_length=1, max_length=16)
    """The names of the parameters holding the amplitudes A_k (m), one per order (declare
    each in [parameters] with unit 'm', low and high)."""

    attaches: ClassVar[tuple[Owner, ...]] = ("bearing",)
    gated: ClassVar[bool] = False
    surface: ClassVar[str] = ""

    @model_validator(mode="after")
    def _check(self) -> Waviness:
        if len(self.orders) != len(self.amplitudes):
            raise ValueError(f"orders and amplitudes must be as long as each other, got "
                             f"{len(self.orders)} and {len(self.amplitudes)}")
        for k in self.orders:
            if not 1 <= k <= 200:
                raise ValueError(f"orders: each must be in [1, 200], got {k}")
        for name in self.amplitudes:
            if re.fullmatch(PARAMETER_NAME, name) is None:
                raise ValueError(f"amplitudes: {name!r} is not a parameter name (lower case "
                                 "letters, digits and '_', starting with a letter)")
        return self

    def required_parameters(self) -> tuple[str, ...]:
        names = ("speed_rpm",) if self.surface != "outer" else ()
        return (*names, *dict.fromkeys(self.amplitudes))

    def angle(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        """The angle of the wavy surface where ball i meets it (rad)."""
        raise NotImplementedError

    def deflection_offset(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        """h_i(t) (m) of one ball."""
        phi = self.angle(ctx, contact)
        return sp.Add(*(self.weight(k) * ctx.p(a) * sp.cos(k * phi)
                        for k, a in zip(self.orders, self.amplitudes, strict=True)))

    def weight(self, order: int) -> int:
        return 1

    def describe(self) -> str:
        lobes = ", ".join(f"{k} ({a})" for k, a in zip(self.orders, self.amplitudes,
                                                       strict=True))
        return f"{self.summary}; orders (amplitude parameter): {lobes}"


class OuterRaceWaviness(Waviness):
    kind: Literal["outer_race_waviness"] = "outer_race_waviness"
    surface: ClassVar[str] = "outer"
    summary: ClassVar[str] = ("outer-race waviness: h_i = Σ A_k cos(k θ_i), δ_i − h_i "
                              "(modelgen/terms/waviness.py)")

    def angle(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        return sp.atan2(ctx.s, ctx.c)


class InnerRaceWaviness(Waviness):
    kind: Literal["inner_race_waviness"] = "inner_race_waviness"
    surface: ClassVar[str] = "inner"
    summary: ClassVar[str] = ("inner-race waviness: h_i = −Σ A_k cos(k (θ_i − ω t)), "
                              "δ_i − h_i (modelgen/terms/waviness.py)")

    def angle(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        # θ_i − ω t from cos/sin of θ_i and of ω t (no wrap-around in time)
        wt = ctx.omega * ctx.t
        return sp.atan2(ctx.s * sp.cos(wt) - ctx.c * sp.sin(wt),
                        ctx.c * sp.cos(wt) + ctx.s * sp.sin(wt))

    def weight(self, order: int) -> int:
        return -1


class BallWaviness(Waviness):
    kind: Literal["ball_waviness"] = "ball_waviness"
    ball: int | None = Field(None, ge=1, le=64)
    """The number (1 … N_b) of the one wavy ball; left out: every ball, in phase."""
    surface: ClassVar[str] = "ball"
    summary: ClassVar[str] = ("ball waviness: h_i = −Σ A_k cos(k β)(1 + (−1)^k), β = ω_spin t, "
                              "δ_i − h_i (modelgen/terms/waviness.py)")

    def angle(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        return contact.spin_speed(ctx) * ctx.t

    def deflection_offset(self, ctx: Context, contact: HertzContact) -> sp.Expr:
        offset = super().deflection_offset(ctx, contact)
        return offset if self.ball is None else ball_selector(ctx, self.ball) * offset

    def describe(self) -> str:
        which = "every ball" if self.ball is None else f"ball {self.ball}"
        return f"{super().describe()}; on {which}"

    def weight(self, order: int) -> int:
        return -2 if order % 2 == 0 else 0
