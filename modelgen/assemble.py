"""Sum a spec's terms into the equations of motion, their first-order form, and LaTeX.

The state is every body's coordinates q (m, rad) followed by their velocities v. With a
diagonal mass matrix (each coordinate's mass or transverse inertia),

    m_j q̈_j = F_j(q, q̇, t) + Σ_bearings Σ_i [∂X/∂q_j, ∂Y/∂q_j] · (−Q_i cos θ_i, −Q_i sin θ_i),

θ_i = 2π(i−1)/N_b + ω_cage t the angle of ball i of a bearing. F is the sum of the body
terms (loads, springs, damping, supports; at the body's centre) and of the forces between a
bearing's races (damping on the relative velocity). (X, Y) is the displacement of the inner
race relative to the outer race at the bearing's station, a linear function of q: the
inner body's centre plus its tilt times the station, minus the outer body's centre. The
ball loads push the inner race back and the outer race out (action and reaction, by virtual
work through ∂(X, Y)/∂q). Q_i is the sum of the bearing's ball terms; gated ball terms act
only in contact: their sum is clamped at zero. The number of balls of each bearing is
structural; everything else is a runtime parameter.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property

import sympy as sp

from modelgen.spec import GROUND, Bearing, Body, Spec
from modelgen.symbols import Context, make_context
from modelgen.terms import Centrifugal, HertzContact

StationMap = list[tuple[int, sp.Expr, sp.Expr]]
"""(state index j, ∂X/∂q_j, ∂Y/∂q_j) of a bearing's relative displacement, nonzero only."""


@dataclass
class Equations:
    """Symbolic equations of one spec. Expressions use the symbols of ``ctx``."""

    spec: Spec
    ctx: Context
    cage: dict[str, sp.Expr] = field(default_factory=dict)
    """Cage angular speed of each bearing, rad/s."""

    @property
    def parameter_names(self) -> list[str]:
        """Runtime parameters in the order of the parameter vector ``p``."""
        return list(self.ctx.params)

    @cached_property
    def bodies(self) -> list[Body]:
        return self.spec.body_list()

    @cached_property
    def bearings(self) -> list[Bearing]:
        return self.spec.bearing_list()

    @property
    def state_names(self) -> tuple[str, ...]:
        return tuple(self.ctx.named)

    @property
    def n_dof(self) -> int:
        return len(self.ctx.named) // 2

    def _coordinates(self, body: Body) -> dict[str, tuple[sp.Symbol, sp.Symbol, int]]:
        """Coordinate name -> (position symbol, velocity symbol, index) of ``body``."""
        index = 0
        for b in self.bodies:
            if b.name == body.name:
                break
            index += len(b.coordinates)
        sym = self.ctx.state
        return {c: (sym[index + k], sym[self.n_dof + index + k], index + k)
                for k, c in enumerate(body.coordinates)}

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    def body_context(self, body: Body) -> Context:
        """The context of terms acting on ``body``: its centre's x, y, vx, vy."""
        coords = self._coordinates(body)
        zero = sp.Integer(0)
        return self.ctx.scoped(body.name, x=coords["x"][0], vx=coords["x"][1],
                               y=coords["y"][0] if "y" in coords else zero,
                               vy=coords["y"][1] if "y" in coords else zero)

    def station_map(self, bearing: Bearing) -> StationMap:
        """∂(X, Y)/∂q of the bearing's relative displacement (inner minus outer race)."""
        rows: StationMap = []
        scope = self.ctx.scoped(bearing.name)
        station = scope.p("station") if scope.has("station") else sp.Integer(0)
        for side, sign in ((bearing.inner, 1), (bearing.outer, -1)):
            if side == GROUND:
                continue
            coords = self._coordinates(self.body(side))
            for name, (_, _, j) in coords.items():
                arm = station if name in ("tx", "ty") else 1
                ax = sign * arm if name in ("x", "tx") else 0
                ay = sign * arm if name in ("y", "ty") else 0
                rows.append((j, sp.sympify(ax), sp.sympify(ay)))
        return rows

    def bearing_context(self, bearing: Bearing) -> Context:
        """The context of a bearing's terms: relative displacement and velocity of its races
        at its station, its cage speed, its parameters."""
        q, v = self.ctx.state[: self.n_dof], self.ctx.state[self.n_dof:]
        rows = self.station_map(bearing)
        x = sp.Add(*(ax * q[j] for j, ax, _ in rows))
        y = sp.Add(*(ay * q[j] for j, _, ay in rows))
        vx = sp.Add(*(ax * v[j] for j, ax, _ in rows))
        vy = sp.Add(*(ay * v[j] for j, _, ay in rows))
        return self.ctx.scoped(bearing.name, x=x, y=y, vx=vx, vy=vy,
                               omega_cage=self.cage.get(bearing.name))

    def ball_load_of(self, bearing: Bearing, skip: type | None = None) -> sp.Expr:
        """Radial load Q of one ball of ``bearing`` at (cos θ, sin θ) = (c, s), in N."""
        ctx = self.bearing_context(bearing)
        terms = [t for t in self.spec.terms
                 if self.spec.attachment(t).get("bearing") == bearing.name]
        offsets = [t.deflection_offset(t.bound(ctx), self.spec.contacts()[bearing.name])
                   for t in terms if hasattr(t, "deflection_offset")]
        if offsets:  # defects and waviness: δ_i → δ_i − h_i inside the contact law
            ctx = dataclasses.replace(ctx, offset=sp.Add(*offsets))
        return ball_load(terms, ctx, skip)

    @cached_property
    def ball_load(self) -> sp.Expr:
        """The ball load of the first bearing (N)."""
        return self.ball_load_of(self.bearings[0])

    @cached_property
    def external_force(self) -> list[sp.Expr]:
        """Generalised force on every coordinate besides the ball loads (N, N·m)."""
        forces = [sp.Integer(0)] * self.n_dof
        for body in self.bodies:
            coords = self._coordinates(body)
            ctx = self.body_context(body)
            for fx, fy in self._body_forces(body, ctx):
                forces[coords["x"][2]] += fx
                if "y" in coords:
                    forces[coords["y"][2]] += fy
        for bearing in self.bearings:
            ctx = self.bearing_context(bearing)
            for term in self.spec.terms:
                if self.spec.attachment(term).get("bearing") != bearing.name or \
                        "body" in self.spec.attachment(term):
                    continue
                force = term.body_force(term.bound(ctx))
                if force is not None:
                    for j, ax, ay in self.station_map(bearing):
                        forces[j] += ax * force[0] + ay * force[1]
        return forces

    def _body_forces(self, body: Body, ctx: Context) -> list[tuple[sp.Expr, sp.Expr]]:
        out = []
        for term in self.spec.terms:
            if self.spec.attachment(term).get("body") != body.name:
                continue
            force = term.body_force(term.bound(ctx))
            if force is not None:
                out.append(force)
        if body.support is not None:
            k = ctx.p(body.support.stiffness) if body.support.stiffness else 0
            c = ctx.p(body.support.damping) if body.support.damping else 0
            out.append((-k * ctx.x - c * ctx.vx, -k * ctx.y - c * ctx.vy))
        return out

    @property
    def rotor_force(self) -> tuple[sp.Expr, sp.Expr]:
        """(F_x, F_y) of a one-planar-body model, N."""
        return self.external_force[0], self.external_force[1]

    @cached_property
    def masses(self) -> list[sp.Symbol]:
        """Mass (kg) or transverse inertia (kg·m²) of every coordinate."""
        return [self.ctx.params[n] for b in self.bodies for n in b.inertias()]

    @property
    def mass(self) -> sp.Symbol:
        return self.masses[0]

    @property
    def cage_speed(self) -> sp.Expr:
        """Cage speed of the first bearing (0 without bearings), rad/s."""
        return self.cage[self.bearings[0].name] if self.bearings else sp.Integer(0)

    @property
    def shaft_speed(self) -> sp.Expr:
        return self.ctx.omega

    def ball_angle(self, i: int, n_balls: int, bearing: Bearing | None = None) -> sp.Expr:
        """θ_i for i = 0 … N_b − 1 (the paper's i − 1), in rad."""
        cage = self.cage[bearing.name] if bearing is not None else self.cage_speed
        return 2 * sp.pi * i / n_balls + cage * self.ctx.t

    def ball_sum(self, load: sp.Expr, n_balls: int,
                 bearing: Bearing | None = None) -> tuple[sp.Expr, sp.Expr]:
        """(Σ Q_i cos θ_i, Σ Q_i sin θ_i) of a per-ball load expression over N_b balls."""
        sx, sy = sp.Integer(0), sp.Integer(0)
        for i in range(n_balls):
            theta = self.ball_angle(i, n_balls, bearing)
            q = load.subs({self.ctx.c: sp.cos(theta), self.ctx.s: sp.sin(theta),
                           self.ctx.i: i + 1, self.ctx.n_balls: n_balls}, simultaneous=True)
            sx, sy = sx + q * sp.cos(theta), sy + q * sp.sin(theta)
        return sx, sy

    def structure(self, n_balls: int | dict[str, int] | None) -> dict[str, int]:
        """Balls per bearing: the defaults, one number (one bearing) or a mapping."""
        if isinstance(n_balls, dict):
            return {b.name: n_balls.get(b.name, b.n_balls) for b in self.bearings}
        return {b.name: (b.n_balls if n_balls is None else n_balls) for b in self.bearings}

    def generalized_forces(self, n_balls: int | dict[str, int] | None = None) -> list[sp.Expr]:
        """Total generalised force on every coordinate for concrete numbers of balls."""
        forces = list(self.external_force)
        counts = self.structure(n_balls)
        for bearing in self.bearings:
            sx, sy = self.ball_sum(self.ball_load_of(bearing), counts[bearing.name], bearing)
            for j, ax, ay in self.station_map(bearing):
                forces[j] -= ax * sx + ay * sy
        return forces

    def forces(self, n_balls: int | dict[str, int] | None = None) -> tuple[sp.Expr, sp.Expr]:
        """Total force on a one-planar-body rotor (N) for a concrete number of balls."""
        f = self.generalized_forces(n_balls)
        return f[0], f[1]

    def first_order(self, n_balls: int | dict[str, int] | None = None) -> sp.Matrix:
        """Right-hand side of d/dt [q, v] for concrete numbers of balls."""
        f = self.generalized_forces(n_balls)
        v = self.ctx.state[self.n_dof:]
        return sp.Matrix([*v, *(fj / m for fj, m in zip(f, self.masses, strict=True))])

    def centrifugal_resultant(self, n_balls: int) -> tuple[sp.Expr, sp.Expr]:
        """What the centrifugal terms add to the first bearing's ball resultant over N_b
        balls (N).

        When the centrifugal change of a ball's load does not depend on the ball (paper Eqs.
        7-8), the resultant is that change times (Σ cos θ_i, Σ sin θ_i), and the sums over the
        equally spaced angles are reduced exactly (roots of unity); otherwise the difference
        of the two ball sums is returned as it stands.
        """
        bearing = self.bearings[0]
        without = self.ball_load_of(bearing, skip=Centrifugal)
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


def ball_load(terms: list, ctx: Context, skip: type | None = None) -> sp.Expr:
    """Sum of the ball terms (leaving out terms of type ``skip``); the gated ones are clamped
    at zero when more than the bare Hertz load (non-negative by itself) is gated."""
    gated, free = [], []
    for term in terms:
        skipped = skip is not None and isinstance(term, skip)
        load = None if skipped else term.ball_load(term.bound(ctx))
        if load is not None:
            (gated if term.is_gated() else free).append((term, load))
    gated_sum = sp.Add(*(load for _, load in gated))
    if any(not isinstance(term, HertzContact) for term, _ in gated):
        gated_sum = sp.Max(0, gated_sum)
    return gated_sum + sp.Add(*(load for _, load in free))


def assemble(spec: Spec, display: bool = False) -> Equations:
    """Build the symbolic equations of ``spec``. ``display`` keeps ω and ω_cage as symbols."""
    ctx = make_context(list(spec.parameters), display=display, state_names=spec.state_names())
    if spec.shaft is not None:  # a finite-element rotor, reduced (modelgen/fe/nonlinear.py)
        from modelgen.fe.nonlinear import FlexibleEquations

        eq: Equations = FlexibleEquations(spec=spec, ctx=ctx)
    else:
        eq = Equations(spec=spec, ctx=ctx)
    contacts = spec.contacts()
    for bearing in eq.bearings:
        scoped = ctx.scoped(bearing.name)
        eq.cage[bearing.name] = (sp.Symbol("omega_cage", real=True) if display
                                 else contacts[bearing.name].cage_speed(
                                     contacts[bearing.name].bound(scoped)))
    ctx.omega_cage = eq.cage_speed  # the first bearing's, for one-bearing callers of eq.ctx
    return eq


def latex_equations(spec: Spec) -> list[str]:
    """LaTeX lines of the equations of motion of ``spec``, for the model card."""
    if spec.shaft is not None:
        from modelgen.fe.nonlinear import latex_lines

        return latex_lines(spec)
    eq = assemble(spec, display=True)
    names = eq.ctx.latex_names()
    names.update({eq.ctx.omega: r"\omega"})
    omega_cage = sp.Symbol("omega_cage", real=True)
    names[omega_cage] = r"\omega_{cage}"
    theta = sp.Symbol(r"\theta_i", real=True)
    tex = lambda e: sp.latex(e, symbol_names=names)  # noqa: E731
    full = assemble(spec)
    several = len(eq.bearings) > 1
    lines = []
    dots = [rf"\ddot{{{sp.latex(s, symbol_names=names)}}}" for s in eq.ctx.state[: eq.n_dof]]
    for j, (acc, mass) in enumerate(zip(dots, eq.masses, strict=True)):
        rhs = tex(eq.external_force[j])
        for bearing in eq.bearings:
            tag = f"^{{({bearing.name})}}" if several else ""
            n_b = f"N_b{tag}"
            for k, ak, ay in eq.station_map(bearing):
                if k != j:
                    continue
                coef, trig = (ak, r"\cos") if ak != 0 else (ay, r"\sin")
                lead = {1: " -", -1: " +"}.get(coef, f" - {tex(coef)}")
                rhs += rf"{lead} \sum_{{i=1}}^{{{n_b}}} Q{tag}_i {trig}\theta{tag}_i"
        lines.append(rf"{tex(mass)} {acc} = {rhs}")
    for bearing in eq.bearings:
        tag = f"^{{({bearing.name})}}" if several else ""
        q = eq.ball_load_of(bearing).subs({eq.ctx.c: sp.cos(theta), eq.ctx.s: sp.sin(theta)})
        lines += [rf"Q{tag}_i = {tex(q)}",
                  rf"\theta{tag}_i = \frac{{2\pi (i-1)}}{{N_b{tag}}} + \omega{tag}_{{cage}}\, t",
                  rf"\omega{tag}_{{cage}} = "
                  rf"{sp.latex(full.cage[bearing.name], symbol_names=names)}"]
    lines.append(r"\omega = \frac{\pi}{30}\, n \quad (n = \text{speed\_rpm})")
    return lines
