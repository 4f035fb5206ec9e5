"""Runtime shared by every generated model: builds its CasADi Functions for N_b balls.

Emitted verbatim by bearingdyn modelgen (modelgen/templates/runtime.py.tmpl); do not edit.
Imports only casadi and the standard library, so a generated model runs without SymPy.
"""

import math

import casadi as ca

STATE = ("x", "y", "vx", "vy")
"""State vector: rotor centre displacement (m) and velocity (m/s)."""


def hertz15(d):
    """max(0, d)^(3/2) written as d·sqrt(|d|) behind a switch (a select, no branch in C).

    Same value as the power; its derivatives of every order stay finite at d = 0, where
    AD of the power form gives NaN or inf (the contact opening and closing). The |d| keeps
    the discarded branch finite for d < 0 and costs one bit operation in compiled code,
    where fmax(d, 0) would be a library call per ball and RK4 stage.
    """
    return ca.if_else(d > 0, d * ca.sqrt(ca.fabs(d)), 0)


class ModelFunctions:
    """The CasADi Functions of one generated model for a fixed number of balls.

    rhs(t, z, p) -> dz/dt        right-hand side, t in s, z = [x, y, vx, vy] (m, m/s)
    jac(t, z, p) -> d rhs / d z  4x4 Jacobian (AD; CasADi name rhs_jac)
    rk4_step(t, z, p, h) -> z(t + h)  one classical Runge-Kutta step of h seconds
    simulator(n_out, save_every) -> sim(z0, t0, p, h) -> (Z, T): n_out * save_every RK4
        steps in one call, keeping every save_every-th state (4 x n_out) and its time.

    The ball angles use angle addition, θ_i = φ_i + ψ with φ_i = 2π i/N_b fixed and
    ψ = ω_cage t, so one sin/cos pair of ψ serves every ball. rk4_step also reaches the
    cage angle of its later stages by angle addition, ψ(t + h/2) = ψ(t) + ω_cage h/2 and
    ψ(t + h) = ψ(t) + ω_cage h: the rotations depend on parameters only (compiled RK4
    blocks compute them once per call), so a step needs one sin/cos pair of ψ, not three.
    """

    def __init__(self, model, n_balls: int):
        self.model = model
        self.n_balls = int(n_balls)
        n_par = len(model.PARAMETERS)
        t, h = ca.SX.sym("t"), ca.SX.sym("h")
        z, p = ca.SX.sym("z", 4), ca.SX.sym("p", n_par)
        cage = model.cage_speed(p)
        c0, s0 = ca.cos(cage * t), ca.sin(cage * t)
        dz = ca.cse(self._derivative(t, z, p, c0, s0))
        names = ["t", "z", "p"]
        self.rhs = ca.Function("rhs", [t, z, p], [dz], names, ["dz"])
        self.jac = ca.Function("rhs_jac", [t, z, p], [ca.jacobian(dz, z)], names, ["dfdz"])
        ch, sh = ca.cos(cage * (h / 2)), ca.sin(cage * (h / 2))
        cf, sf = ca.cos(cage * h), ca.sin(cage * h)
        c_half, s_half = c0 * ch - s0 * sh, s0 * ch + c0 * sh
        k1 = self._derivative(t, z, p, c0, s0)
        k2 = self._derivative(t + h / 2, z + h / 2 * k1, p, c_half, s_half)
        k3 = self._derivative(t + h / 2, z + h / 2 * k2, p, c_half, s_half)
        k4 = self._derivative(t + h, z + h * k3, p, c0 * cf - s0 * sf, s0 * cf + c0 * sf)
        z_next = ca.cse(z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
        self.rk4_step = ca.Function("rk4_step", [t, z, p, h], [z_next], [*names, "h"], ["z_next"])
        zt = ca.vertcat(z, t)
        self._step_zt = ca.Function("rk4_step_zt", [zt, p, h],
                                    [ca.vertcat(z_next, t + h)], ["zt", "p", "h"], ["zt_next"])
        self._simulators = {}

    def _derivative(self, t, z, p, c0, s0):
        """dz/dt at time t, with (c0, s0) = (cos ψ, sin ψ) of the cage angle ψ(t)."""
        x, y, vx, vy = ca.vertsplit(z)
        fx, fy = self.model.rotor_force(x, y, vx, vy, t, p)
        for i in range(self.n_balls):
            phi = 2 * math.pi * i / self.n_balls
            cp, sp = math.cos(phi), math.sin(phi)
            c, s = cp * c0 - sp * s0, sp * c0 + cp * s0
            q = self.model.ball_load(c, s, x, y, vx, vy, t, p)
            fx, fy = fx - q * c, fy - q * s
        mass = self.model.rotor_mass(p)
        return ca.vertcat(vx, vy, fx / mass, fy / mass)

    def simulator(self, n_out: int, save_every: int = 1):
        """sim(z0, t0, p, h) -> (Z [4 x n_out], T [1 x n_out]) after each save_every steps."""
        key = (int(n_out), int(save_every))
        if key not in self._simulators:
            n_par = len(self.model.PARAMETERS)
            zt, p, h = ca.MX.sym("zt", 5), ca.MX.sym("p", n_par), ca.MX.sym("h")
            step = self._step_zt
            if save_every > 1:
                block = step.fold(save_every)
                step = ca.Function("rk4_block", [zt, p, h],
                                   [block(zt, ca.repmat(p, 1, save_every),
                                          ca.repmat(h, 1, save_every))])
            run = step.mapaccum("rk4_run", n_out)
            out = run(zt, ca.repmat(p, 1, n_out), ca.repmat(h, 1, n_out))
            z0, t0 = ca.MX.sym("z0", 4), ca.MX.sym("t0")
            zt0 = ca.vertcat(z0, t0)
            out = ca.substitute([out], [zt], [zt0])[0]
            self._simulators[key] = ca.Function(
                "sim", [z0, t0, p, h], [out[:4, :], out[4, :]], ["z0", "t0", "p", "h"],
                ["Z", "T"])
        return self._simulators[key]
