"""Sum a spec's terms into the equations of motion, their first-order form, and LaTeX.

    M_R ẍ = F_x(x, ẋ, t) − Σ_i Q_i cos θ_i
    M_R ÿ = F_y(y, ẏ, t) − Σ_i Q_i sin θ_i,     θ_i = 2π(i−1)/N_b + ω_cage t

F is the sum of the rotor terms (loads, damping) and Q_i the radial load of ball i, the sum of
the ball terms. Gated ball terms act only in contact: their sum is clamped at zero. The number
of balls is structural; everything else is a runtime parameter.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from modelgen.spec import Spec
from modelgen.symbols import Context, make_context
from modelgen.terms import Centrifugal, HertzContact


@dataclass
class Equations:
    """Symbolic equations of one spec. Expressions use the symbols of ``ctx``."""

    spec: Spec
    ctx: Context

    @property
    def parameter_names(self) -> list[str]:
        """Runtime parameters in the order of the parameter vector ``p``."""
        return list(self.ctx.params)

    @cached_property
    def ball_load(self) -> sp.Expr:
        """Radial load Q of one ball at (cos θ, sin θ) = (c, s), in N."""
        return ball_load(self.spec, self.ctx)

    @cached_property
    def rotor_force(self) -> tuple[sp.Expr, sp.Expr]:
        fx, fy = sp.Integer(0), sp.Integer(0)
        for term in self.spec.terms:
            force = term.rotor_force(self.ctx)
            if force is not None:
                fx, fy = fx + force[0], fy + force[1]
        return fx, fy

    @property
    def mass(self) -> sp.Symbol:
        return self.ctx.p("rotor_mass")

    @property
    def cage_speed(self) -> sp.Expr:
        return self.ctx.omega_cage

    @property
    def shaft_speed(self) -> sp.Expr:
        return self.ctx.omega

    def ball_angle(self, i: int, n_balls: int) -> sp.Expr:
        """θ_i for i = 0 … N_b − 1 (the paper's i − 1), in rad."""
        return 2 * sp.pi * i / n_balls + self.cage_speed * self.ctx.t

    def ball_sum(self, load: sp.Expr, n_balls: int) -> tuple[sp.Expr, sp.Expr]:
        """(Σ Q_i cos θ_i, Σ Q_i sin θ_i) of a per-ball load expression over N_b balls."""
        sx, sy = sp.Integer(0), sp.Integer(0)
        for i in range(n_balls):
            theta = self.ball_angle(i, n_balls)
            q = load.subs({self.ctx.c: sp.cos(theta), self.ctx.s: sp.sin(theta)},
                          simultaneous=True)
            sx, sy = sx + q * sp.cos(theta), sy + q * sp.sin(theta)
        return sx, sy

    def forces(self, n_balls: int) -> tuple[sp.Expr, sp.Expr]:
        """Total force on the rotor (N) for a concrete number of balls."""
        sx, sy = self.ball_sum(self.ball_load, n_balls)
        fx, fy = self.rotor_force
        return fx - sx, fy - sy

    def first_order(self, n_balls: int) -> sp.Matrix:
        """Right-hand side of d/dt [x, y, vx, vy] for a concrete number of balls."""
        fx, fy = self.forces(n_balls)
        c = self.ctx
        return sp.Matrix([c.vx, c.vy, fx / self.mass, fy / self.mass])

    def centrifugal_resultant(self, n_balls: int) -> tuple[sp.Expr, sp.Expr]:
        """What the centrifugal terms add to the ball resultant over N_b balls (N).

        When the centrifugal change of a ball's load does not depend on the ball (paper Eqs.
        7-8), the resultant is that change times (Σ cos θ_i, Σ sin θ_i), and the sums over the
        equally spaced angles are reduced exactly (roots of unity); otherwise the difference
        of the two ball sums is returned as it stands.
        """
        without = ball_load(self.spec, self.ctx, skip=Centrifugal)
        change = sp.simplify(self.ball_load - without)
        if change.has(self.ctx.c, self.ctx.s):
            sx, sy = self.ball_sum(self.ball_load, n_balls)
            wx, wy = self.ball_sum(without, n_balls)
            return sx - wx, sy - wy
        psi = self.cage_speed * self.ctx.t
        a = exact_algebraic(sp.Add(*(sp.cos(2 * sp.pi * i / n_balls) for i in range(n_balls))))
        b = exact_algebraic(sp.Add(*(sp.sin(2 * sp.pi * i / n_balls) for i in range(n_balls))))
        # Σ cos(φ_i + ψ) = a cos ψ − b sin ψ,  Σ sin(φ_i + ψ) = b cos ψ + a sin ψ
        return (change * (a * sp.cos(psi) - b * sp.sin(psi)),
                change * (b * sp.cos(psi) + a * sp.sin(psi)))


def exact_algebraic(value: sp.Expr) -> sp.Expr:
    """``value`` (an algebraic number) or exact 0 when its minimal polynomial is X."""
    x = sp.Symbol("X")
    return sp.Integer(0) if sp.minimal_polynomial(value, x) == x else value


def ball_load(spec: Spec, ctx: Context, skip: type | None = None) -> sp.Expr:
    """Sum of the ball terms (leaving out terms of type ``skip``); the gated ones are clamped
    at zero when more than the bare Hertz load (non-negative by itself) is gated."""
    gated, free = [], []
    for term in spec.terms:
        load = None if skip is not None and isinstance(term, skip) else term.ball_load(ctx)
        if load is not None:
            (gated if term.is_gated() else free).append((term, load))
    gated_sum = sp.Add(*(load for _, load in gated))
    if any(not isinstance(term, HertzContact) for term, _ in gated):
        gated_sum = sp.Max(0, gated_sum)
    return gated_sum + sp.Add(*(load for _, load in free))


def assemble(spec: Spec, display: bool = False) -> Equations:
    """Build the symbolic equations of ``spec``. ``display`` keeps ω and ω_cage as symbols."""
    ctx = make_context(list(spec.parameters), display=display)
    contact = spec.contact()
    if contact is None:
        ctx.omega_cage = sp.Integer(0)  # no balls
    elif display:
        ctx.omega_cage = sp.Symbol("omega_cage", real=True)
    else:
        ctx.omega_cage = contact.cage_speed(ctx)
    return Equations(spec=spec, ctx=ctx)


def latex_equations(spec: Spec) -> list[str]:
    """LaTeX lines of the equations of motion of ``spec``, for the model card."""
    eq = assemble(spec, display=True)
    names = eq.ctx.latex_names()
    theta = sp.Symbol(r"\theta_i", real=True)
    names.update({eq.ctx.omega: r"\omega", eq.ctx.omega_cage: r"\omega_{cage}"})
    q = eq.ball_load.subs({eq.ctx.c: sp.cos(theta), eq.ctx.s: sp.sin(theta)})
    fx, fy = eq.rotor_force
    tex = lambda e: sp.latex(e, symbol_names=names)  # noqa: E731
    full = assemble(spec)
    if spec.contact() is None:
        return [rf"M_R \ddot{{x}} = {tex(fx)}", rf"M_R \ddot{{y}} = {tex(fy)}",
                r"\omega = \frac{\pi}{30}\, n \quad (n = \text{speed\_rpm})"]
    return [
        rf"M_R \ddot{{x}} = {tex(fx)} - \sum_{{i=1}}^{{N_b}} Q_i \cos\theta_i",
        rf"M_R \ddot{{y}} = {tex(fy)} - \sum_{{i=1}}^{{N_b}} Q_i \sin\theta_i",
        rf"Q_i = {tex(q)}",
        r"\theta_i = \frac{2\pi (i-1)}{N_b} + \omega_{cage}\, t",
        rf"\omega_{{cage}} = {sp.latex(full.cage_speed, symbol_names=names)}",
        r"\omega = \frac{\pi}{30}\, n \quad (n = \text{speed\_rpm})",
    ]
