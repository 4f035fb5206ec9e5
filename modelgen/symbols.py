"""The SymPy symbols of the equations of motion and the context terms build on.

A model's state is its bodies' coordinates followed by their velocities (``assemble``).
A term sees the world through a ``Context``: a *body* term gets the body's own ``x, y``
(m) and ``vx, vy`` (m/s), a *bearing* term the displacement and velocity of the bearing's
inner race relative to its outer race at the bearing's station, and the bearing's cage speed.
So one term module serves a rotor on ground, a rotor in a housing and a tilting shaft. A
one-coordinate body has ``y = vy = 0``. ``x`` points along the radial load (Eq. 11 of the
paper puts P_r in the x equation), ``y`` is perpendicular to it in the bearing plane.
One ball is described by ``c = cos θ_i`` and ``s = sin θ_i`` of its angular position, its
index ``i`` (1 … N_b) and the number of balls ``n_balls`` of its bearing.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from modelgen.lazy import sympy as sp
from modelgen.quantities import QUANTITIES

STATE_NAMES = ("x", "y", "vx", "vy")
"""State names of a model with one planar body (the paper's rotor)."""
LATEX_NAMES = {
    "x": "x", "y": "y", "vx": r"\dot{x}", "vy": r"\dot{y}", "t": "t",
    "c": r"\cos\theta_i", "s": r"\sin\theta_i", "i": "i", "n_balls": "N_b",
}


def real(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


@dataclass
class Context:
    """Symbols shared by the terms of one model, seen from one body or bearing.

    ``params`` maps each runtime parameter name to its symbol; ``omega`` is the shaft speed
    (rad/s) and ``omega_cage`` the cage speed (rad/s) of the bearing in scope, both
    expressions in the parameters. ``x, y, vx, vy`` are the body's coordinates or the
    bearing's relative motion (expressions in the state). ``scope`` is the body or bearing
    name: ``p(name)`` reads ``<name>_<scope>`` when the spec declares it, else ``name``.
    ``named`` maps every state name of the model to its symbol (expression terms use them).
    """

    params: dict[str, sp.Symbol]
    x: sp.Expr = field(default_factory=lambda: real("x"))
    y: sp.Expr = field(default_factory=lambda: real("y"))
    vx: sp.Expr = field(default_factory=lambda: real("vx"))
    vy: sp.Expr = field(default_factory=lambda: real("vy"))
    t: sp.Symbol = field(default_factory=lambda: real("t"))
    c: sp.Symbol = field(default_factory=lambda: real("c"))
    s: sp.Symbol = field(default_factory=lambda: real("s"))
    i: sp.Symbol = field(default_factory=lambda: real("i"))
    n_balls: sp.Symbol = field(default_factory=lambda: real("n_balls"))
    omega: sp.Expr | None = None
    """Shaft angular speed (rad/s): π/30 · speed_rpm, or a plain symbol for display."""
    omega_cage: sp.Expr | None = None
    """Cage angular speed (rad/s) of the bearing in scope."""
    scope: str = ""
    named: dict[str, sp.Symbol] = field(default_factory=dict)
    offset: sp.Expr = field(default_factory=lambda: sp.Integer(0))
    """Offset h_i (m) of the ball's deflection, δ_i → δ_i − h_i: the sum of the bearing's
    defect and waviness terms (``modelgen/terms/defects.py``), 0 without them."""
    aliases: dict[str, str] = field(default_factory=dict)
    """Quantity -> the spec's parameter that holds it for the term in scope (a term's
    ``bind``): ``p("radial_clearance")`` then reads ``gap``."""

    @property
    def state(self) -> tuple[sp.Symbol, ...]:
        """The state symbols in the order of the state vector."""
        return tuple(self.named.values())

    def parameter_name(self, name: str) -> str:
        """The spec's parameter that holds quantity ``name`` here: the term's bound name,
        else ``<name>_<scope>`` when the spec declares it, else ``name``."""
        if name in self.aliases:
            return self.aliases[name]
        scoped = f"{name}_{self.scope}"
        return scoped if self.scope and scoped in self.params else name

    def p(self, name: str) -> sp.Symbol:
        """The parameter ``name`` as this body or bearing sees it (``<name>_<scope>`` first)."""
        return self.params[self.parameter_name(name)]

    def has(self, name: str) -> bool:
        return self.parameter_name(name) in self.params

    def scoped(self, scope: str, **symbols: sp.Expr) -> Context:
        """This context seen from body or bearing ``scope`` with its own x, y, vx, vy…"""
        return dataclasses.replace(self, scope=scope, **symbols)

    def latex_names(self) -> dict[sp.Symbol, str]:
        names = {getattr(self, k): v for k, v in LATEX_NAMES.items()
                 if isinstance(getattr(self, k), sp.Symbol)}
        names.update({sym: QUANTITIES[n].latex for n, sym in self.params.items()
                      if n in QUANTITIES})  # user-declared parameters: SymPy's own LaTeX
        return names


def make_context(parameter_names: list[str], display: bool = False,
                 state_names: tuple[str, ...] = STATE_NAMES) -> Context:
    """Symbols for the given runtime parameters and state. With ``display``, ω and ω_cage
    stay symbols (for the model card) instead of expressions in ``speed_rpm`` and the
    geometry."""
    params = {n: real(n) for n in parameter_names}
    omega = real("omega") if display else sp.pi / 30 * params.get("speed_rpm", sp.Integer(0))
    state = {n: real(n) for n in state_names}
    base = {k: state[k] for k in STATE_NAMES if k in state}
    return Context(params=params, omega=omega, named=state, **base)
