"""Two-contact ball model: inner- and outer-race contacts in series, centrifugal force in
each ball's radial equilibrium.

A ball between the races is pressed outwards by its centrifugal force
F_c = ½ m_b D_m ω_cage² (Harris; m_b = ρ_b π D_b³/6). With the total approach of the races
at ball i, δ = x cos θ_i + y sin θ_i − γ_0 (m), shared by the two contacts,

    δ = δ_i + δ_o,   Q_i = K_i max(0, δ_i)^{3/2},   Q_o = K_o max(0, δ_o)^{3/2} = Q_i + F_c,

K_i, K_o the ball–race Hertz constants (``modelgen/hertz.py``). The rotor (inner race) feels
Q_i; the outer race carries Q_i + F_c. So the centrifugal force acts at speed: it softens the
loaded balls and, below the opening approach δ_c = (F_c/K_o)^{2/3}, lifts the ball off the
inner race (Q_i = 0: the ball rides on the outer race only). With F_c = 0 the model is
exactly the one-contact model with K = [K_i^{−2/3} + K_o^{−2/3}]^{−3/2}:
δ_i = δ/(1 + (K_i/K_o)^{2/3}).

Per ball the scalar equation h(u) = u + ((K_i max(0, u)^{3/2} + F_c)/K_o)^{2/3} − δ = 0 in
u = δ_i is solved by ``STEPS`` Newton steps. h is increasing and convex in u, and both
u = δ/(1 + (K_i/K_o)^{2/3}) and u = δ − δ_c are upper bounds of its root; Newton from the
smaller of them descends monotonically onto the root (no overshoot, no safeguard needed).
The generated code runs the steps unrolled (``inner_race_load``); every branch is a select
whose discarded side is never differentiated, so the Jacobian stays finite at the switch,
as with ``hertz15``.
"""

from __future__ import annotations

import functools
from typing import Any, ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.centrifugal import harris_force
from modelgen.terms.contact import HertzContact, deflection, race_stiffnesses
from modelgen.unrolled import NUMPY, Ops, numpy_call, unrolled_base

STEPS = 4
"""Newton steps per ball: the force error is below 1e-15 of K_i δ^{3/2} over F_c/K_o from
0 to 1e-6 m^{3/2} (tests/modelgen/test_two_contact.py)."""


def inner_race_load(delta: Any, k_i: Any, k_o: Any, f_c: Any, ops: Ops = NUMPY,
                    steps: int = STEPS) -> Any:
    """Q_i (N) of a ball with total approach ``delta`` (m), races in series, F_c >= 0 (N)."""
    two_thirds = ops.rational(2, 3)
    ratio = (k_i / k_o) ** two_thirds
    opening = ops.power(f_c / k_o, two_thirds)
    u = ops.minimum(delta / (1 + ratio), delta - opening)
    for _ in range(steps):
        # where u > 0: c = δ_o^{1/2} = ((K_i u^{3/2} + F_c)/K_o)^{1/3}, h'(u) = 1 + K_i √u/(K_o c);
        # where u <= 0 the inner contact is open: δ_o = δ_c, h'(u) = 1
        cube = ((k_i * ops.hertz15(u) + f_c) / k_o) ** ops.rational(1, 3)
        outer = ops.if_positive(u, cube * cube, opening)
        slope = ops.if_positive(u, 1 + k_i / k_o * ops.sqrt(u) / cube, 1)
        u = u - (u + outer - delta) / slope
    return k_i * ops.hertz15(u)


def race_loads(delta: Any, k_i: Any, k_o: Any, f_c: Any) -> dict[str, Any]:
    """Inner and outer loads (N) and deflections (m) of one ball, NumPy (for checks)."""
    q_i = numpy_call(inner_race_load, delta, k_i, k_o, f_c)
    delta_i = (q_i / k_i) ** (2 / 3)
    delta_o = ((q_i + f_c) / k_o) ** (2 / 3)
    return {"inner_load": q_i, "outer_load": q_i + f_c, "inner_deflection": delta_i,
            "outer_deflection": delta_o}


@functools.cache
def inner_race_load_class() -> type:
    """The class ``InnerRaceLoad`` (made on first use: an ``Unrolled`` SymPy function needs
    SymPy, and validating a spec does not; ``modelgen.lazy``)."""

    class InnerRaceLoad(unrolled_base()):
        """Q_i(δ; K_i, K_o, F_c): inner-race load of a ball between two races, N."""

        nargs = 4
        code_name = "inner_race_load"
        arg_names = ("delta", "k_i", "k_o", "f_c")
        doc = ("Inner-race load Q_i (N) of a ball with total approach delta (m) between races of "
               "Hertz constants k_i, k_o (N/m^1.5), centrifugal force f_c (N): "
               f"{STEPS} Newton steps on the inner deflection (modelgen/terms/two_contact.py).")
        is_nonnegative = True

        @staticmethod
        def algorithm(delta: Any, k_i: Any, k_o: Any, f_c: Any, ops: Ops) -> Any:
            return inner_race_load(delta, k_i, k_o, f_c, ops)

        def latex_name(self) -> str:
            return r"Q_{in}"

        def latex_args(self, printer: Any) -> str:
            delta, *rest = (printer._print(a) for a in self.args)
            return rf"{delta};\ {', '.join(rest)}"

    InnerRaceLoad.__module__, InnerRaceLoad.__qualname__ = __name__, "InnerRaceLoad"
    return InnerRaceLoad


def __getattr__(name: str) -> Any:
    """``InnerRaceLoad``, made on first use (``inner_race_load_class``)."""
    if name == "InnerRaceLoad":
        return inner_race_load_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class TwoContact(HertzContact):
    """Inner and outer race contacts in series with the centrifugal force between them.

    Replaces ``hertz_contact`` + ``centrifugal`` in a spec; the stiffnesses come from the
    geometry (``stiffness = "geometry"``), the centrifugal force from Harris' formula.
    """

    kind: Literal["two_contact"] = "two_contact"  # type: ignore[assignment]
    stiffness: Literal["geometry"] = "geometry"  # type: ignore[assignment]
    damping: Literal["none"] = "none"  # type: ignore[assignment]

    summary: ClassVar[str] = (
        "two-contact balls: inner and outer race contacts in series, δ_i + δ_o = "
        "x cos θ_i + y sin θ_i − γ_0, K_o δ_o^(3/2) = K_i δ_i^(3/2) + F_c, load Q_i = "
        "K_i δ_i^(3/2) on the rotor"
    )

    def required_parameters(self) -> tuple[str, ...]:
        return (*super().required_parameters(), "ball_density")

    def ball_load(self, ctx: Context) -> sp.Expr:
        k_i, k_o = race_stiffnesses(ctx)
        return inner_race_load_class()(deflection(ctx, self.clearance), k_i, k_o,
                                       harris_force(ctx))

    def describe(self) -> str:
        return (super().describe() + "; F_c = ½ m_b D_m ω_cage² (Harris), m_b = ρ_b π D_b³/6; "
                f"Q_i solved per ball by {STEPS} Newton steps")

    def _describe_stiffness(self) -> str:
        return ("; K_i, K_o from Hertz point contact (groove conformities f_i, f_o, E, ν; "
                "modelgen/hertz.py)")
