"""Flow maps over a forcing period, built in CasADi so that AD gives their derivatives.

``Period`` names the period of a periodic orbit as an expression of the parameters:
``vc`` (1/VC, the balanced rotor), ``shaft`` (1/X), ``vc:k`` / ``shaft:k`` (k of them), or
``ratio:p/q`` (p VC periods = q shaft revolutions; the caller makes the ratio exact, see
``analysis.stability.periodic.commensurate``). ``flow_map`` integrates N fixed RK4 steps of
h = T(p)/N from (z0, t0) and returns the end state, the monodromy matrix ∂z_T/∂z0 and
∂z_T/∂p, all by algorithmic differentiation through the integrator (the derivative of the
discrete RK4 map, not finite differences).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cache

import casadi as ca
import numpy as np

from analysis.errors import InputError
from analysis.forcing import PERIOD
from analysis.integrate.checks import check_seconds
from analysis.integrate.tangent import (
    Carry,
    block_tree,
    chain_blocks,
    model_tag,
    tangent_step,
)
from analysis.model import Model, System

PERIOD_KINDS = PERIOD.kinds
PERIOD_SYNTAX = PERIOD.syntax


@dataclass(frozen=True)
class Period:
    """A forcing period: ``count`` periods of ``kind`` (``vc`` of a bearing, or ``shaft``),
    the common period of a ratio VC/X = p/q (``kind = "ratio"``, p VC periods = q
    revolutions), or ``count`` times the value of a parameter in s (``kind = "param"``:
    models forced at a period of their own, e.g. the Mathieu equation)."""

    kind: str
    count: int = 1
    ratio: Fraction | None = None
    divisor: int = 1
    """Segments per period (multiple shooting integrates T/divisor at a time)."""
    name: str | None = None
    """The bearing of ``vc`` (None: the model's only one) or the parameter of ``param``."""

    @classmethod
    def parse(cls, text: str) -> Period:
        """``"vc"``, ``"shaft"``, ``"vc:2"``, ``"shaft:3"``, ``"ratio:37/15"``,
        ``"vc[left]"``, ``"vc[left]:2"`` or ``"param:forcing_period"`` (the grammar of
        ``analysis.forcing.PERIOD``)."""
        forcing = PERIOD.parse(text)
        return cls(forcing.kind, forcing.count, forcing.ratio, name=forcing.name)

    def __str__(self) -> str:
        if self.kind == "ratio":
            return f"ratio:{self.ratio}"
        if self.kind == "param":
            return f"param:{self.name}" + (f"×{self.count}" if self.count > 1 else "")
        head = f"{self.kind}[{self.name}]" if self.name else self.kind
        return head if self.count == 1 else f"{head}:{self.count}"

    def doubled(self) -> Period:
        """Twice this period (the period-2 orbit after a period doubling)."""
        return Period(self.kind, 2 * self.count, self.ratio, self.divisor, self.name)

    def segment(self, segments: int) -> Period:
        """One of ``segments`` equal parts of this period."""
        return Period(self.kind, self.count, self.ratio, self.divisor * segments, self.name)

    def check(self, model: Model) -> None:
        """Raise ``InputError`` when the period does not exist in ``model``."""
        bearings = model.bearing_names
        if self.kind == "param" and self.name not in model.parameter_names:
            raise InputError(f"period: param:{self.name}: not a parameter of model "
                             f"'{model.name}'; parameters: {', '.join(model.parameter_names)}")
        if self.kind in ("vc", "ratio") and not bearings:
            raise InputError(f"period: model '{model.name}' has no bearings, so no VC "
                             "frequency; use shaft or param:NAME")
        if self.kind == "vc" and self.name is None and len(bearings) > 1:
            raise InputError(f"period: model '{model.name}' has bearings "
                             f"{', '.join(bearings)}; name one, e.g. vc[{bearings[0]}]")
        if self.kind == "vc" and self.name is not None and self.name not in bearings:
            raise InputError(f"period: no bearing '{self.name}' in model '{model.name}'; "
                             f"bearings: {', '.join(bearings)}")

    def seconds_in(self, system: System) -> float:
        """The period in s of ``system`` (its balls and parameter values); ``InputError``
        when it is not defined there (a speed of zero, no balls)."""
        try:
            value = float(self.seconds(system.model, system.structure, system.p))
        except ZeroDivisionError:  # a numeric speed of 0: no period, as T = inf below
            value = math.inf
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"period: {self} is not defined for these parameters "
                             f"(got T = {value!r} s; is the speed zero, or are there no "
                             "balls?)")
        return value

    def steps_in(self, system: System, dt: float) -> int:
        """RK4 steps of one period of ``system`` so that the step is at most ``dt`` (s);
        ``InputError`` beyond ``MAX_PERIOD_STEPS`` (the flow map and its derivatives would
        not fit in memory)."""
        check_seconds("dt", dt)
        seconds = self.seconds_in(system)
        steps = seconds / dt
        if steps > MAX_PERIOD_STEPS:
            raise InputError(f"period {self}: {seconds:.4g} s is {steps:.3g} RK4 steps of "
                             f"{dt:g} s; at most {MAX_PERIOD_STEPS:.0e} per period (a "
                             "shorter period, or a larger dt)")
        return max(1, math.ceil(steps - 1e-9))

    def seconds(self, model: Model, structure: tuple[int, ...], p):
        """The period in s, as a CasADi expression of ``p`` (or a float for numeric p)."""
        self.check(model)
        structure = model.structure(structure)
        if self.kind == "param":
            return p[model.parameter_names.index(self.name)] * self.count / self.divisor
        omega = model.module.shaft_speed(p)
        if self.kind == "shaft":
            base = 2 * math.pi / omega
        elif self.kind == "vc":
            index = model.bearing_names.index(self.name) if self.name else 0
            cage = model.cage_speed(model.bearing_names[index], p)
            base = 2 * math.pi / (structure[index] * cage)
        else:
            base = self.ratio.denominator * 2 * math.pi / omega
        return base * self.count / self.divisor


def period_seconds(model: Model, n_balls: tuple[int, ...], period: Period, values: dict) -> float:
    """``period.seconds_in(system)`` of the System of ``model``, ``n_balls`` and ``values``
    (for callers that hold those three)."""
    return period.seconds_in(System(model, model.structure(n_balls), values,
                                    model.initial_state))


SENSITIVITY_BLOCK_SIZES = (100, 10, 1)
"""RK4 steps per block of the flow maps' step-with-derivatives, largest first; each is ten
of the next, so N steps take N // 100 + at most 18 calls."""


FLOW_NAMES = (("s", "p", "h", "t0", "g"), ("s_next",))
"""Input and output names of the flow maps' step and blocks."""


@cache
def sensitivity_blocks(model: Model, structure: tuple[int, ...],
                       compiled: bool) -> dict[int, ca.Function]:
    """The blocks of ``SENSITIVITY_BLOCK_SIZES`` RK4 steps carrying the derivatives of the
    flow, ``flow_<model>_nb<balls>_steps<size>(s, p, h, t0, g) -> s'``.

    ``s = [z; k; vec(M); vec(D)]``: the state z after step k (time ``t0 + k·h``, as in
    ``compiled.rk4_blocks``), M = ∂z/∂z0 (n × n) and D = dz/dp (n × n_par, column-major),
    the step h's own dependence on p included through ``g = dh/dp`` (1 × n_par):
    M' = A·M and D' = A·D + ∂z'/∂p + ∂z'/∂h·g with A = ∂z'/∂z, the exact derivatives of
    the discrete RK4 map (``tangent.tangent_step``; ∂z'/∂h through the step's time too).
    Each block is ten calls of the next smaller (``tangent.block_tree``: the C code holds
    one step, not 100), compiled into one library of the cache
    (``compiled.compiled_functions``: keyed by the C source, so by the model and its balls,
    never by a period or a step count) or, with ``compiled=False`` or no compiler, the same
    Functions in the VM."""
    from analysis.integrate.compiled import compiled_functions, test_state

    tag = model_tag(model, structure)
    n, n_par = model.n_state, len(model.parameter_names)
    step = tangent_step(model.functions(structure).rk4_step,
                        Carry(directions=n, product="jacobian", parameters=True),
                        f"flow_{tag}_steps1", names=FLOW_NAMES).step
    inner = block_tree(step, SENSITIVITY_BLOCK_SIZES, lambda size: f"flow_{tag}_steps{size}",
                       keep_states=False, names=FLOW_NAMES)
    fns = [inner[size] for size in SENSITIVITY_BLOCK_SIZES]
    s_test = np.concatenate([test_state(n), [3.0], np.eye(n).ravel(),
                             np.linspace(-1.0, 1.0, n * n_par)])
    p_test = model.parameter_vector(model.defaults)
    h_test = float(model.simulation_defaults["dt"])
    args = (s_test, p_test, h_test, 0.1, np.linspace(0.5, 1.5, n_par)[None, :] * h_test)
    built = compiled_functions(fns, [args if size <= 10 else None
                                     for size in SENSITIVITY_BLOCK_SIZES], compiled)
    return dict(zip(SENSITIVITY_BLOCK_SIZES, built, strict=True))


def _period_step(model: Model, structure: tuple[int, ...], period: Period, n_steps: int,
                 p: ca.MX) -> ca.MX:
    return period.seconds(model, structure, p) / n_steps


@cache
def flow_map(model: Model, n_balls: tuple[int, ...], period: Period, n_steps: int,
             compiled: bool = True) -> ca.Function:
    """``flow(z0, t0, p) -> (zT, dzT/dz0, dzT/dp)`` over one period with n_steps RK4 steps
    of h = T(p)/n_steps (step k from ``t0 + k·h``), the derivatives by AD through the
    steps (dzT/dp includes the period's own dependence on p).

    The steps run in blocks of 100, 10 and 1 steps that carry the derivatives
    (``sensitivity_blocks``): compiled C from the cache of ``analysis.integrate.compiled``
    when a compiler works (one library per model and balls, whatever the period or step
    count; one warning and the VM otherwise), the same Functions in the CasADi VM with
    ``compiled=False``. The returned Function chains them: at most N // 100 + 18 calls.
    """
    structure = model.structure(n_balls)
    blocks = sensitivity_blocks(model, structure, compiled)
    n, n_par = model.n_state, len(model.parameter_names)
    z0, t0, p = ca.MX.sym("z0", n), ca.MX.sym("t0"), ca.MX.sym("p", n_par)
    h = _period_step(model, structure, period, n_steps, p)
    g = ca.jacobian(h, p)
    s0 = ca.vertcat(z0, ca.MX.zeros(1), ca.vec(ca.MX.eye(n)), ca.MX.zeros(n * n_par))
    s_end, _ = chain_blocks(blocks, n_steps, s0, [p, h, t0, g])
    mono = ca.reshape(s_end[n + 1:n + 1 + n * n], n, n)
    dp = ca.reshape(s_end[n + 1 + n * n:], n, n_par)
    return ca.Function("flow", [z0, t0, p], [s_end[:n], mono, dp],
                       ["z0", "t0", "p"], ["zT", "monodromy", "dzT_dp"])


def steps_per_period(model: Model, n_balls: tuple[int, ...], period: Period, values: dict,
                     dt: float) -> int:
    """``period.steps_in(system, dt)`` of the System of ``model``, ``n_balls`` and
    ``values`` (for callers that hold those three)."""
    return period.steps_in(System(model, model.structure(n_balls), values,
                                  model.initial_state), dt)


MAX_PERIOD_STEPS = 2_000_000
"""Most RK4 steps in one period of a flow map (shooting, Floquet, continuation)."""


def evaluate(flow: ca.Function, z0, t0: float, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    z_end, mono, dp = flow(z0, t0, p)
    return np.asarray(z_end).ravel(), np.asarray(mono), np.asarray(dp)


@cache
def orbit_states(model: Model, n_balls: tuple[int, ...], period: Period,
                 n_steps: int, compiled: bool = True) -> ca.Function:
    """``orbit(z0, t0, p) -> Z`` (n × n_steps): the states after each RK4 step of one period
    (the steps of ``flow_map``: its zT is the last column). The model's RK4 blocks
    (``compiled.library``: compiled C when a compiler works, else or with
    ``compiled=False`` the VM) chained as in ``flow_map``."""
    from analysis.integrate.compiled import library

    structure = model.structure(n_balls)
    lib = library(model, structure, compiled)
    n, n_par = model.n_state, len(model.parameter_names)
    z0, t0, p = ca.MX.sym("z0", n), ca.MX.sym("t0"), ca.MX.sym("p", n_par)
    h = _period_step(model, structure, period, n_steps, p)
    blocks = {}
    for size in sorted(lib.blocks, reverse=True):  # Z of a block, its last column first
        zn, pm, hm, tm = (ca.MX.sym(a, lib.blocks[size].sparsity_in(i))
                          for i, a in enumerate(("zn", "p", "h", "t0")))
        states = lib.blocks[size](zn, pm, hm, tm)
        blocks[size] = ca.Function(f"orbit_block{size}", [zn, pm, hm, tm],
                                   [states[:, -1], states])
    _, outputs = chain_blocks(blocks, n_steps, ca.vertcat(z0, ca.MX.zeros(1)), [p, h, t0],
                              keep_states=True)
    return ca.Function("orbit", [z0, t0, p], [ca.horzcat(*outputs)[:n, :]],
                       ["z0", "t0", "p"], ["Z"])
