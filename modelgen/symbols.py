"""The SymPy symbols of the rotor-bearing equations and the context terms build on.

State ``[x, y, vx, vy]``: rotor centre displacement (m) and velocity (m/s). ``x`` points
along the radial load (Eq. 11 of the paper puts P_r in the x equation; downward when the
load is the rotor weight), ``y`` is perpendicular to it in the bearing plane.
One ball is described by ``c = cos θ_i`` and ``s = sin θ_i`` of its angular position.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from modelgen.quantities import QUANTITIES

STATE_NAMES = ("x", "y", "vx", "vy")
LATEX_NAMES = {
    "x": "x", "y": "y", "vx": r"\dot{x}", "vy": r"\dot{y}", "t": "t",
    "c": r"\cos\theta_i", "s": r"\sin\theta_i",
}


def real(name: str) -> sp.Symbol:
    return sp.Symbol(name, real=True)


@dataclass
class Context:
    """Symbols shared by all terms of one model.

    ``params`` maps each runtime parameter name to its symbol; ``omega`` is the shaft speed
    (rad/s) and ``omega_cage`` the cage speed (rad/s), both expressions in the parameters.
    """

    params: dict[str, sp.Symbol]
    x: sp.Symbol = field(default_factory=lambda: real("x"))
    y: sp.Symbol = field(default_factory=lambda: real("y"))
    vx: sp.Symbol = field(default_factory=lambda: real("vx"))
    vy: sp.Symbol = field(default_factory=lambda: real("vy"))
    t: sp.Symbol = field(default_factory=lambda: real("t"))
    c: sp.Symbol = field(default_factory=lambda: real("c"))
    s: sp.Symbol = field(default_factory=lambda: real("s"))
    omega: sp.Expr | None = None
    """Shaft angular speed (rad/s): π/30 · speed_rpm, or a plain symbol for display."""
    omega_cage: sp.Expr | None = None
    """Cage angular speed (rad/s), set from the contact term's kinematics."""

    def p(self, name: str) -> sp.Symbol:
        return self.params[name]

    @property
    def state(self) -> tuple[sp.Symbol, ...]:
        return (self.x, self.y, self.vx, self.vy)

    def latex_names(self) -> dict[sp.Symbol, str]:
        names = {getattr(self, k): v for k, v in LATEX_NAMES.items()}
        names.update({sym: QUANTITIES[n].latex for n, sym in self.params.items()
                      if n in QUANTITIES})  # user-declared parameters: SymPy's own LaTeX
        return names


def make_context(parameter_names: list[str], display: bool = False) -> Context:
    """Symbols for the given runtime parameters. With ``display``, ω and ω_cage stay symbols
    (for the model card) instead of expressions in ``speed_rpm`` and the geometry."""
    params = {n: real(n) for n in parameter_names}
    omega = real("omega") if display else sp.pi / 30 * params.get("speed_rpm", sp.Integer(0))
    return Context(params=params, omega=omega)
