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
from analysis.model import Model

PERIOD_KINDS = ("vc", "shaft", "ratio", "param")
PERIOD_SYNTAX = ("vc, shaft, vc:k, shaft:k, ratio:p/q, vc[bearing] (a model with several "
                 "bearings) or param:NAME (the period in s held by parameter NAME)")


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
        ``"vc[left]"``, ``"vc[left]:2"`` or ``"param:forcing_period"``."""
        head, _, arg = text.strip().partition(":")
        kind, _, bracket = head.partition("[")
        name = bracket.removesuffix("]") or None
        if kind not in PERIOD_KINDS or (bracket and (kind != "vc" or not bracket.endswith("]"))):
            raise InputError(f"period: must be {PERIOD_SYNTAX}, got {text!r}")
        if kind == "param":
            if not arg.isidentifier():
                raise InputError(f"period: param:NAME needs a parameter name, got {text!r}")
            return cls("param", 1, name=arg)
        try:
            if kind == "ratio":
                ratio = Fraction(arg)
                if ratio <= 0:
                    raise ValueError
                return cls("ratio", 1, ratio)
            count = int(arg) if arg else 1
            if count < 1:
                raise ValueError
        except (ValueError, ZeroDivisionError):
            raise InputError(f"period: the number in {text!r} must be a positive integer "
                             "(or p/q with p, q > 0 for ratio)") from None
        return cls(kind, count, name=name)

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
    value = float(period.seconds(model, n_balls, model.parameter_vector(values)))
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"period: {period} is not defined for these parameters "
                         f"(got T = {value!r} s; is the speed zero, or are there no balls?)")
    return value


def _advance(model: Model, n_balls: tuple[int, ...]) -> tuple[ca.Function, ca.MX]:
    """One RK4 step on [z; t] as a Function of (zt, p, h), and a parameter symbol."""
    step = model.functions(n_balls).rk4_step
    n = model.n_state
    zt, p, h = ca.MX.sym("zt", n + 1), ca.MX.sym("p", len(model.parameter_names)), ca.MX.sym("h")
    advance = ca.Function("advance", [zt, p, h],
                          [ca.vertcat(step(zt[n], zt[:n], p, h), zt[n] + h)])
    return advance, p


@cache
def flow_map(model: Model, n_balls: tuple[int, ...], period: Period, n_steps: int) -> ca.Function:
    """``flow(z0, t0, p) -> (zT, dzT/dz0, dzT/dp)`` over one period with n_steps RK4 steps."""
    advance, p = _advance(model, n_balls)
    run = advance.fold(n_steps)
    n = model.n_state
    z0, t0 = ca.MX.sym("z0", n), ca.MX.sym("t0")
    h_value = period.seconds(model, n_balls, p) / n_steps
    z_end = run(ca.vertcat(z0, t0), ca.repmat(p, 1, n_steps),
                ca.repmat(h_value, 1, n_steps))[:n]
    return ca.Function("flow", [z0, t0, p],
                       [z_end, ca.jacobian(z_end, z0), ca.jacobian(z_end, p)],
                       ["z0", "t0", "p"], ["zT", "monodromy", "dzT_dp"])


def steps_per_period(model: Model, n_balls: tuple[int, ...], period: Period, values: dict,
                     dt: float) -> int:
    """Number of RK4 steps so that the step is at most ``dt`` (s)."""
    return max(1, math.ceil(period_seconds(model, n_balls, period, values) / dt - 1e-9))


def evaluate(flow: ca.Function, z0, t0: float, p) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    z_end, mono, dp = flow(z0, t0, p)
    return np.asarray(z_end).ravel(), np.asarray(mono), np.asarray(dp)


@cache
def orbit_states(model: Model, n_balls: tuple[int, ...], period: Period,
                 n_steps: int) -> ca.Function:
    """``orbit(z0, t0, p) -> Z`` (n × n_steps): the states after each RK4 step of one period."""
    advance, p = _advance(model, n_balls)
    n = model.n_state
    z0, t0 = ca.MX.sym("z0", n), ca.MX.sym("t0")
    h_value = period.seconds(model, n_balls, p) / n_steps
    states = advance.mapaccum(n_steps)(ca.vertcat(z0, t0), ca.repmat(p, 1, n_steps),
                                       ca.repmat(h_value, 1, n_steps))
    return ca.Function("orbit", [z0, t0, p], [states[:n, :]], ["z0", "t0", "p"], ["Z"])
