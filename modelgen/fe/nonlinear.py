"""The nonlinear model of a finite-element rotor: its reduced equations as SymPy expressions,
generated into CasADi like every other model (``modelgen.assemble`` and ``modelgen.codegen``
call in here for a spec with ``[shaft]``).

With the reduced coordinates q (``modelgen/fe/reduction.py``: u = T q, u the full DOFs;
T^T M T = diag(m)) the equations are

    m_j q_j'' = F_j,   F = -K_r q - (C_r + ω G_r) q' + T^T f(t) - Σ_b T_b^T (Σ_i Q_i cos θ_i,
                                                                    Σ_i Q_i sin θ_i),

with K_r, C_r, G_r the projected stiffness (shaft and linear bearings), damping and
gyroscopic matrices (numbers baked into the generated code), ω = π/30 · ``speed_rpm`` (a
parameter), f the unbalances (s_u m e ω² (cos(ωt + φ), sin(ωt + φ)) at their nodes, s_u the
parameter ``unbalance_scale`` when the spec declares it, else 1) and the body
terms at nodes (``radial_load`` … with ``body = "node<K>"``). A ball bearing at node K sees
the node's translation (x_K, y_K) = T_K q as its inner race's centre, so its contact,
clearance, centrifugal, varying-compliance and defect terms act unchanged: its station map
is T_K (the same coefficients carry its ball loads back to q, by virtual work).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from modelgen.assemble import Equations
from modelgen.errors import SpecError
from modelgen.lazy import sympy as sp
from modelgen.spec import Bearing, Body, Spec
from modelgen.symbols import Context

__all__ = ["FlexibleEquations", "flexible_card", "flexible_constants", "latex_lines",
           "reduced_rotor"]


@dataclass(frozen=True)
class ReducedRotor:
    """A spec's shaft assembled and reduced, with the reduction's stated error."""

    reduced: object
    """``modelgen.fe.reduction.Reduced``."""
    error: float
    """The reduction's error as stated (relative; ``reduction.stated``)."""
    error_text: str
    modes_compared: int
    limit_hz: float
    node_positions: tuple[float, ...]


def _spec_key(spec: Spec) -> str:
    return spec.model_dump_json()


@functools.lru_cache(maxsize=8)
def _reduce(key: str) -> ReducedRotor:
    from modelgen.fe.assembly import assemble as assemble_shaft
    from modelgen.fe.reduction import (
        ReductionError,
        reduce_rotor,
        reduction_error,
        stated,
    )

    spec = Spec.model_validate_json(key)
    shaft = spec.shaft
    assert shaft is not None
    for i, bearing in enumerate(shaft.bearings):
        if bearing.speed_rpm is not None:
            raise SpecError(spec.model.name, [
                f"shaft.bearings[{i}].speed_rpm: a generated (nonlinear) model takes constant "
                "linear-bearing coefficients; give numbers (the linear analyses read tables)"])
    rotor = assemble_shaft(shaft)
    k_b, c_b = rotor.bearing_matrices(0.0)
    options = spec.reduction_options()
    stiffness, damping = rotor.K + k_b, rotor.C + c_b
    try:
        reduced = reduce_rotor(rotor.M, stiffness, damping, rotor.G, spec.interface_nodes(),
                               options.method, options.modes, spec.shaft_node())
    except ReductionError as exc:
        raise SpecError(spec.model.name, [str(exc)]) from None
    full = (rotor.M, stiffness, damping, rotor.G)
    error, count, limit = reduction_error(full, reduced, options.max_speed_rpm)
    text = stated(error)
    return ReducedRotor(reduced=reduced, error=float("inf") if text == "inf" else
                        (0.0 if text.startswith("<") else float(text)), error_text=text,
                        modes_compared=count, limit_hz=limit,
                        node_positions=tuple(rotor.node_positions))


def reduced_rotor(spec: Spec) -> ReducedRotor:
    """The reduced shaft of ``spec`` (computed once per spec and process)."""
    return _reduce(_spec_key(spec))


def _number(value: float) -> sp.Expr:
    return sp.Integer(0) if value == 0 else sp.Float(float(value))


@dataclass
class FlexibleEquations(Equations):
    """The equations of a spec with ``[shaft]`` (see the module docstring)."""

    symbolic_nodes: bool = False
    """Bearings see their node's displacement as the symbols x_K, y_K (the model card's
    equations) instead of T_K q."""

    @cached_property
    def rotor(self) -> ReducedRotor:
        return reduced_rotor(self.spec)

    @cached_property
    def bodies(self) -> list[Body]:
        """The node whose displacements are the first states (its orbit is the model's)."""
        return [Body(name=f"node{self.spec.shaft_node()}")]

    def _node(self, body_or_node: str | int) -> int:
        return int(str(body_or_node).removeprefix("node"))

    def node_rows(self, node: int) -> list[tuple[int, sp.Expr, sp.Expr]]:
        """(state index j, ∂x/∂q_j, ∂y/∂q_j) of node ``node``'s translation, nonzero only."""
        tx, ty = self.rotor.reduced.node_rows(node)
        return [(j, _number(a), _number(b)) for j, (a, b) in enumerate(zip(tx, ty, strict=True))
                if a != 0 or b != 0]

    def station_map(self, bearing: Bearing) -> list[tuple[int, sp.Expr, sp.Expr]]:
        assert bearing.node is not None
        return self.node_rows(bearing.node)

    def _node_motion(self, node: int) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
        q, v = self.ctx.state[: self.n_dof], self.ctx.state[self.n_dof:]
        rows = self.node_rows(node)
        return (sp.Add(*(a * q[j] for j, a, _ in rows)), sp.Add(*(b * q[j] for j, _, b in rows)),
                sp.Add(*(a * v[j] for j, a, _ in rows)), sp.Add(*(b * v[j] for j, _, b in rows)))

    def bearing_context(self, bearing: Bearing) -> Context:
        if not self.symbolic_nodes:
            return super().bearing_context(bearing)
        x, y = (sp.Symbol(f"{axis}_{{{bearing.node}}}", real=True) for axis in ("x", "y"))
        vx, vy = (sp.Symbol(rf"\dot{{{axis}}}_{{{bearing.node}}}", real=True)
                  for axis in ("x", "y"))
        return self.ctx.scoped(bearing.name, x=x, y=y, vx=vx, vy=vy,
                               omega_cage=self.cage.get(bearing.name))

    def body_context(self, body: Body) -> Context:
        """The context of a term at node ``body.name``: the node's x, y, vx, vy."""
        x, y, vx, vy = self._node_motion(self._node(body.name))
        return self.ctx.scoped(body.name, x=x, y=y, vx=vx, vy=vy)

    @cached_property
    def masses(self) -> list[sp.Expr]:
        """The generalised mass of every coordinate, kg."""
        return [sp.Float(float(m)) for m in self.rotor.reduced.mass]

    def proportional_damping(self) -> tuple[float, float] | None:
        """(α, β) when the shaft's damping is C = α M + β K (every element with the same
        ROSS proportional damping, no linear bearings): the generated force then takes
        C_r = α diag(m) + β K_r exactly, as the projection gives it in exact arithmetic.
        (SymPy distributes β over K_r (q + β q'), so the operations are those of two
        products; the gain is one set of numbers, not speed.)"""
        shaft = self.spec.shaft
        assert shaft is not None
        pairs = {(e.alpha, e.beta) for e in shaft.elements}
        if len(pairs) == 1 and not shaft.bearings:
            return next(iter(pairs))
        return None

    def _spread(self, node: int, fx: sp.Expr, fy: sp.Expr, forces: list) -> None:
        for j, a, b in self.node_rows(node):
            forces[j] += a * fx + b * fy

    @cached_property
    def external_force(self) -> list[sp.Expr]:
        """Generalised force on every coordinate besides the ball loads (N)."""
        red = self.rotor.reduced
        q, v = self.ctx.state[: self.n_dof], self.ctx.state[self.n_dof:]
        omega, t = self.ctx.omega, self.ctx.t
        proportional = self.proportional_damping()
        if proportional is not None:  # C_r = α diag(m) + β K_r exactly
            alpha, beta = proportional
            moved = [q[k] + _number(beta) * v[k] for k in range(self.n_dof)]
        forces = []
        for j in range(self.n_dof):
            if proportional is not None:
                elastic = sp.Add(*(_number(-red.stiffness[j, k]) * moved[k]
                                   for k in range(self.n_dof) if red.stiffness[j, k] != 0))
                viscous = _number(-alpha * red.mass[j]) * v[j]
            else:
                elastic = sp.Add(*(_number(-red.stiffness[j, k]) * q[k]
                                   for k in range(self.n_dof) if red.stiffness[j, k] != 0))
                viscous = sp.Add(*(_number(-red.damping[j, k]) * v[k]
                                   for k in range(self.n_dof) if red.damping[j, k] != 0))
            gyro = sp.Add(*(_number(-red.gyroscopic[j, k]) * v[k] for k in range(self.n_dof)
                            if red.gyroscopic[j, k] != 0))
            forces.append(elastic + viscous + omega * gyro)
        assert self.spec.shaft is not None
        scale = self.ctx.p("unbalance_scale") if self.ctx.has("unbalance_scale") else 1
        for u in self.spec.shaft.unbalances:
            angle = omega * t + _number(u.phase)
            amplitude = scale * _number(u.magnitude) * omega**2
            self._spread(u.node, amplitude * sp.cos(angle), amplitude * sp.sin(angle), forces)
        for term in self.spec.terms:
            body = self.spec.attachment(term).get("body")
            if body is None:
                continue
            ctx = self.body_context(Body(name=body))
            force = term.body_force(term.bound(ctx))
            if force is not None:
                self._spread(self._node(body), force[0], force[1], forces)
        for bearing in self.bearings:
            ctx = self.bearing_context(bearing)
            for term in self.spec.terms:
                where = self.spec.attachment(term)
                if where.get("bearing") != bearing.name or "body" in where:
                    continue
                force = term.body_force(term.bound(ctx))
                if force is not None:
                    for j, ax, ay in self.station_map(bearing):
                        forces[j] += ax * force[0] + ay * force[1]
        return forces


def flexible_constants(spec: Spec) -> list[str]:
    """The generated module's constants of a shaft model: ``REDUCTION`` (what was kept, the
    stated error) and ``NODE_MAP`` (every node's translation as a linear map of the state)."""
    rotor = reduced_rotor(spec)
    red = rotor.reduced
    options = spec.reduction_options()
    info = {"method": red.method, "modes": red.modes, "node": red.node,
            "interface": red.interface, "full_dofs": red.full_dofs, "kept": red.kept(),
            "max_speed_rpm": options.max_speed_rpm, "error": rotor.error,
            "error_limit_hz": round(rotor.limit_hz, 6), "error_modes": rotor.modes_compared}
    rows = []
    for node in range(len(rotor.node_positions)):
        tx, ty = red.node_rows(node)
        entries = ", ".join(f"({j}, {float(a)!r}, {float(b)!r})"
                            for j, (a, b) in enumerate(zip(tx, ty, strict=True)) if a or b)
        rows.append(f"    # node {node} at z = {rotor.node_positions[node]!r} m\n    ({entries}),")
    items = "".join(f"    {k!r}: {v!r},\n" for k, v in info.items())
    return [f"REDUCTION = {{\n    # the reduced finite-element rotor (modelgen/fe/reduction.py)\n"
            f"{items}}}",
            "NODE_MAP = (\n    # per node: (state index, dx/dq, dy/dq) of its translation, m/m\n"
            + "\n".join(rows) + "\n)"]


def flexible_card(spec: Spec) -> str:
    """The model card's section on the shaft and its reduction."""
    from modelgen.fe.reduction import ERROR_SPEEDS, ERROR_STIFFNESSES

    rotor = reduced_rotor(spec)
    red = rotor.reduced
    shaft = spec.shaft
    assert shaft is not None
    options = spec.reduction_options()
    stiff = ", ".join(f"{k:.0e}" for k in ERROR_STIFFNESSES)
    length = rotor.node_positions[-1]
    disks = "; ".join(f"node {d.node}: {d.m:g} kg" for d in shaft.disks) or "none"
    unb = "; ".join(f"node {u.node}: {u.magnitude:g} kg·m at {u.phase:g} rad"
                    for u in shaft.unbalances) or "none"
    bearings = "; ".join(f"`{b.name}` at node {b.node}" for b in spec.bearing_list()) or "none"
    linear = "; ".join(f"node {b.node}" for b in shaft.bearings) or "none"
    return f"""
## Shaft and reduction

Finite-element shaft: {len(shaft.elements)} Timoshenko elements, {shaft.node_count} nodes over
{length:g} m ({red.full_dofs} DOFs: x, y, α, β per node); disks {disks}; unbalances {unb};
ball bearings {bearings}; linear bearings {linear}.

Kept: {red.kept()}.

Reduction error: {rotor.error_text} (the largest relative difference of the damped natural
frequencies of the reduced and the full model, every mode below {rotor.limit_hz:g} Hz,
twice the highest speed of interest {options.max_speed_rpm:g} rpm; {ERROR_SPEEDS} speeds
from 0 to {options.max_speed_rpm:g} rpm; the ball bearings as isotropic springs of {stiff}
N/m; {rotor.modes_compared} modes compared).
"""


def latex_lines(spec: Spec) -> list[str]:
    """LaTeX lines of a shaft model's equations, for the model card."""
    from modelgen.assemble import assemble

    eq = assemble(spec, display=True)
    assert isinstance(eq, FlexibleEquations)
    eq.symbolic_nodes = True
    full = assemble(spec)
    names = eq.ctx.latex_names()
    names[eq.ctx.omega] = r"\omega"
    names[sp.Symbol("omega_cage", real=True)] = r"\omega_{cage}"
    several = len(eq.bearings) > 1
    lines = [r"\mathrm{diag}(m)\,\ddot{q} = -K_r q - (C_r + \omega G_r)\,\dot{q} + T^\top f(t)"
             r" - \sum_b T_b^\top \sum_{i=1}^{N_b} Q^{(b)}_i (\cos\theta^{(b)}_i, "
             r"\sin\theta^{(b)}_i)^\top",
             r"u = T q \quad (u:\ x, y, \alpha, \beta \text{ of every node})",
             r"f(t) = " + (r"s_u\, " if "unbalance_scale" in spec.parameters else "")
             + r"m e\, \omega^2 (\cos(\omega t + \varphi), "
             r"\sin(\omega t + \varphi)) \text{ at each unbalance's node}"]
    theta = sp.Symbol(r"\theta_i", real=True)
    for bearing in eq.bearings:
        tag = f"^{{({bearing.name})}}" if several else ""
        load = eq.ball_load_of(bearing).subs({eq.ctx.c: sp.cos(theta), eq.ctx.s: sp.sin(theta)})
        node = bearing.node
        lines += [rf"Q{tag}_i = {sp.latex(load, symbol_names=names)}",
                  rf"\theta{tag}_i = \frac{{2\pi (i-1)}}{{N_b{tag}}} + \omega{tag}_{{cage}}\, t,"
                  rf"\quad (x_{{{node}}}, y_{{{node}}})^\top = T_{{{node}}} q",
                  rf"\omega{tag}_{{cage}} = "
                  rf"{sp.latex(full.cage[bearing.name], symbol_names=names)}"]
    lines.append(r"\omega = \frac{\pi}{30}\, n \quad (n = \text{speed\_rpm})")
    return lines


def node_displacement(node_map: tuple, state: np.ndarray, node: int) -> np.ndarray:
    """(x, y) of node ``node`` (m) from states ``state`` (n_state, or n_state × samples) by a
    generated module's ``NODE_MAP``."""
    rows = node_map[node]
    state = np.asarray(state, dtype=float)
    x = sum(a * state[j] for j, a, _ in rows)
    y = sum(b * state[j] for j, _, b in rows)
    return np.array([x, y])
