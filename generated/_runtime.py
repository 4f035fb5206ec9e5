"""Runtime shared by every generated model: builds its CasADi Functions for N_b balls.

Emitted verbatim by bearingdyn modelgen (modelgen/templates/runtime.py.tmpl); do not edit.
Imports only casadi and the standard library, so a generated model runs without SymPy.
"""

import math

import casadi as ca


def hertz15(d):
    """max(0, d)^(3/2) written as d·sqrt(|d|) behind a switch (a select, no branch in C).

    Same value as the power; its derivatives of every order stay finite at d = 0, where
    AD of the power form gives NaN or inf (the contact opening and closing). The |d| keeps
    the discarded branch finite for d < 0 and costs one bit operation in compiled code,
    where fmax(d, 0) would be a library call per ball and RK4 stage.
    """
    return ca.if_else(d > 0, d * ca.sqrt(ca.fabs(d)), 0)


class ModelFunctions:
    """The CasADi Functions of one generated model for fixed numbers of balls.

    rhs(t, z, p) -> dz/dt        right-hand side, t in s, z the model's STATE (n values:
                                 positions, then velocities; SI units)
    jac(t, z, p) -> d rhs / d z  n x n Jacobian (AD; CasADi name rhs_jac)
    rk4_step(t, z, p, h) -> z(t + h)  one classical Runge-Kutta step of h seconds

    ``structure`` holds the number of balls of each bearing, in the order of the model's
    BEARINGS (one number for a model with one bearing). The ball angles use angle addition, θ_i = φ_i + ψ with φ_i = 2π (i−1)/N_b fixed
    and ψ = ω_cage t of the bearing, so one sin/cos pair of ψ serves every ball. rk4_step also
    reaches the cage angle of its later stages by angle addition, ψ(t + h/2) = ψ(t) +
    ω_cage h/2 and ψ(t + h) = ψ(t) + ω_cage h: the rotations depend on parameters only
    (compiled RK4 blocks compute them once per call), so a step needs one sin/cos pair of ψ
    per bearing, not three.
    """

    def __init__(self, model, structure):
        self.model = model
        if isinstance(structure, int):  # one number: the model's one bearing
            structure = (structure,)
        self.structure = tuple(int(n) for n in structure)
        self.bearings = [(row[0], n, getattr(model, f"ball_load_{row[0]}"),
                          getattr(model, f"cage_speed_{row[0]}"),
                          getattr(model, f"station_map_{row[0]}"))
                         for row, n in zip(model.BEARINGS, self.structure, strict=True)]
        n_state, n_par = len(model.STATE), len(model.PARAMETERS)
        t, h = ca.SX.sym("t"), ca.SX.sym("h")
        z, p = ca.SX.sym("z", n_state), ca.SX.sym("p", n_par)
        cages = [cage(p) for _, _, _, cage, _ in self.bearings]
        angles = [(ca.cos(w * t), ca.sin(w * t)) for w in cages]
        dz = ca.cse(self.derivative(t, z, p, angles))
        names = ["t", "z", "p"]
        self.rhs = ca.Function("rhs", [t, z, p], [dz], names, ["dz"])
        self.jac = ca.Function("rhs_jac", [t, z, p], [ca.jacobian(dz, z)], names, ["dfdz"])
        half, full = [], []
        for w, (c0, s0) in zip(cages, angles, strict=True):
            ch, sh = ca.cos(w * (h / 2)), ca.sin(w * (h / 2))
            cf, sf = ca.cos(w * h), ca.sin(w * h)
            half.append((c0 * ch - s0 * sh, s0 * ch + c0 * sh))
            full.append((c0 * cf - s0 * sf, s0 * cf + c0 * sf))
        k1 = self.derivative(t, z, p, angles)
        k2 = self.derivative(t + h / 2, z + h / 2 * k1, p, half)
        k3 = self.derivative(t + h / 2, z + h / 2 * k2, p, half)
        k4 = self.derivative(t + h, z + h * k3, p, full)
        z_next = ca.cse(z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
        self.rk4_step = ca.Function("rk4_step", [t, z, p, h], [z_next], [*names, "h"], ["z_next"])

    def derivative(self, t, z, p, angles):
        """dz/dt at time t, with angles[k] = (cos ψ, sin ψ) of bearing k's cage angle ψ(t):
        the right-hand side with the cage angles given (symbolic CasADi expressions), the
        public door for builders of other equations on the same forces (the torus's
        separate phases, the static balance)."""
        state = ca.vertsplit(z)
        n_dof = len(state) // 2
        forces = list(self.model.external_force(state, t, p))
        for (_, n, ball_load, _, station), (c0, s0) in zip(self.bearings, angles, strict=True):
            rows = station(p)
            for i in range(n):
                phi = 2 * math.pi * i / n
                cp, sp = math.cos(phi), math.sin(phi)
                c, s = cp * c0 - sp * s0, sp * c0 + cp * s0
                q = ball_load(c, s, i + 1, n, state, t, p)
                push_x, push_y = q * c, q * s
                for j, ax, ay in rows:
                    forces[j] = _push(_push(forces[j], ax, push_x), ay, push_y)
        mass = self.model.mass(p)
        return ca.vertcat(*state[n_dof:], *(f / m for f, m in zip(forces, mass, strict=True)))


def _push(force, coefficient, push):
    """force − coefficient·push, with the unit and zero coefficients of plain translation
    written without a multiplication (so a one-body model computes what it always did)."""
    if isinstance(coefficient, (int, float)):
        if coefficient == 0:
            return force
        if coefficient == 1:
            return force - push
        if coefficient == -1:
            return force + push
    return force - coefficient * push
