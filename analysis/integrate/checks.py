"""Checks of a run's settings against the model, before any time is spent integrating.

``check_rk4_step``: classical RK4 is only stable while every eigenvalue λ of the linearised
equations, times the step, stays inside its stability region (|λ|·Δt up to 2.83 on the
imaginary axis, 2.785 on the negative real axis, at least 2.62 in between). A step above
that limit does not lose accuracy gracefully: the motion grows without bound and the run
ends in a blow-up long after the real mistake. The eigenvalues come from the model's own
Jacobian (CasADi AD, no SymPy), so every term counts, custom ones included.

The stiffness of a Hertz contact grows with its deflection (1.5·k·δ^½ per ball), so the
Jacobian is taken where the contact is stiffest in normal running: the rotor displaced by
the clearance plus the static deflection of one ball under the whole load
(δ_s = (P/k)^{2/3}, P = |P_r| + P_u), in directions all around the bearing. Every loaded ball
adds its stiffness there. A ball deflected twice as far is only 19 % stiffer in frequency
(ω ∝ δ^{1/4}), so the estimate holds through the overshoot of contact impacts.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from analysis.errors import InputError
from analysis.model import Model, System

PROBE_SECTORS = 8
"""Directions around the bearing in which the rotor is displaced..."""
PROBE_OFFSETS = 4
"""... each also at this many offsets within one ball spacing (ball on the line, between)."""


def check_seconds(name: str, value: float, *, zero: bool = False) -> None:
    """``InputError`` naming ``name`` unless ``value`` is a finite number of seconds > 0
    (>= 0 with ``zero``): the one check of every step, duration and transient."""
    if not (math.isfinite(value) and (value >= 0 if zero else value > 0)):
        raise InputError(f"{name}: must be a finite number {'>=' if zero else '>'} 0 s, "
                         f"got {value!r}")


def rk4_radius(angle: float) -> float:
    """Largest r with |R(r·e^{i·angle})| <= 1, R(z) = 1 + z + z²/2 + z³/6 + z⁴/24 the RK4
    amplification factor; ``angle`` in [π/2, π] (the stable half plane)."""
    direction = complex(math.cos(angle), math.sin(angle))
    low, high = 0.0, 4.0
    for _ in range(50):
        mid = (low + high) / 2
        z = mid * direction
        if abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1.0:
            low = mid
        else:
            high = mid
    return low


def probe_states(system: System) -> list[np.ndarray]:
    """States where the linearised model of ``system`` is at its stiffest: every body at
    rest at the centre and, with a Hertz contact, the first body displaced into the balls
    (see the module). The contact's stiffness k, clearance, radial load and unbalance are
    the parameters that play those roles (``Model.role``; the first bearing's)."""
    model, values = system.model, dict(system.parameters)
    states = [np.zeros(model.n_state)]
    n_balls = system.structure[0] if system.structure else 1
    (ix, iy), *_ = model.centre_indices()
    k = model.role_value("contact_stiffness", values)
    clearance = model.role_value("clearance", values)
    if k is None or clearance is None or k <= 0:
        return states
    load = abs(model.role_value("radial_load", values, 0.0)) + \
        abs(model.role_value("unbalance_force", values, 0.0))
    static = (load / k) ** (2 / 3)
    radius = clearance + abs(clearance) + static  # deflection |γ0| + δ_s of the nearest ball
    for sector in range(PROBE_SECTORS):
        for offset in range(PROBE_OFFSETS):
            phi = 2 * math.pi * (sector / PROBE_SECTORS + offset / (PROBE_OFFSETS * n_balls))
            z = np.zeros(model.n_state)
            z[ix] = radius * math.cos(phi)
            if iy is not None:
                z[iy] = radius * math.sin(phi)
            states.append(z)
    return states


def stable_step(system: System) -> tuple[float, float]:
    """(largest stable RK4 step in s, largest |λ| in 1/s) of ``system`` over the probe
    states; memoised per model, balls and parameter values (sweeps ask again and again)."""
    return _stable_step(system.model, system.structure,
                        tuple(sorted(system.parameters.items())))


@functools.lru_cache(maxsize=4096)
def _stable_step(model: Model, structure: tuple[int, ...], items: tuple) -> tuple[float, float]:
    system = System(model, structure, dict(items), model.initial_state)
    jac = system.functions.jac
    p = system.p
    limit, largest = math.inf, 0.0
    for z in probe_states(system):
        for lam in np.linalg.eigvals(np.asarray(jac(0.0, z, p), dtype=float)):
            size = abs(lam)
            if not math.isfinite(size):
                continue
            largest = max(largest, size)
            if lam.real <= 0 and size > 0:  # growing modes are the model's, not RK4's
                angle = max(math.pi / 2, math.atan2(abs(lam.imag), lam.real))
                limit = min(limit, rk4_radius(angle) / size)
    return limit, largest


def nice_step(limit: float) -> float:
    """A round step (1, 2 or 5 × 10^n s) at most half of ``limit``."""
    target = limit / 2
    scale = 10.0 ** math.floor(math.log10(target))
    return max(m * scale for m in (1, 2, 5) if m * scale <= target)


def check_rk4_step(system: System, dt: float, method: str = "rk4") -> None:
    """Raise ``InputError`` when the RK4 step ``dt`` (s) is above the stability limit of
    the stiffest linearisation of ``system`` (its model, balls and parameter values)."""
    if method != "rk4":
        return
    limit, largest = stable_step(system)
    if dt <= limit:
        return
    raise InputError(
        f"dt: must be in (0, {limit:.3g}] s for RK4 with these parameters, got {dt!r}: the "
        f"stiffest linearisation (contact and all terms) has |λ| = {largest:.4g} 1/s and RK4 "
        f"is stable only for |λ|·dt up to about 2.8; try dt = {nice_step(limit):g} s, or "
        "method cvodes")


RESOLUTION_WARN = 20
"""Fewer RK4 steps than this per period of the fastest forcing: a warning."""
RESOLUTION_REFUSE = 4
"""Fewer than this: refused (the forcing itself is not resolved)."""
MAX_STEPS = 10**10
"""Most RK4 steps one run may take (about an hour compiled at 4 states)."""


def fastest_forcing(system: System) -> tuple[str, float]:
    """(name, frequency in Hz) of the fastest periodic forcing of ``system``: the shaft (X),
    each bearing's varying compliance (VC, VC[name]) and each parameter that plays the
    ``forcing_period`` role (F = 1/period); ("", 0.0) for an autonomous model."""
    model, values = system.model, dict(system.parameters)
    freqs = system.frequencies()
    named = [("X", freqs.shaft_hz)]
    named += [(f"VC[{b}]" if len(freqs.vc) > 1 else "VC", f) for b, f in freqs.vc.items()]
    for name in model.role("forcing_period"):
        period = values.get(name, 0.0)
        if period > 0:
            named.append((f"F = 1/{name}", 1.0 / period))
    return max(named, key=lambda item: item[1], default=("", 0.0))


def check_resolution(system: System, dt: float, duration: float | None = None,
                     warn=None) -> float:
    """Steps per period of the fastest forcing of ``system`` at step ``dt`` (s): refused below
    ``RESOLUTION_REFUSE``, ``warn(message)`` below ``RESOLUTION_WARN`` (default: a Python
    warning). Also refuses runs of more than ``MAX_STEPS`` steps. Returns the steps per
    period (inf without forcing)."""
    if duration is not None and duration / dt > MAX_STEPS:
        raise InputError(f"duration / dt: {duration:g} s at dt = {dt:g} s is "
                         f"{duration / dt:.3g} RK4 steps; at most {MAX_STEPS:.0e} per run "
                         "(shorten the run or raise dt)")
    name, freq = fastest_forcing(system)
    if not freq > 0:
        return math.inf
    steps = 1.0 / (freq * dt)
    if steps < RESOLUTION_REFUSE:
        raise InputError(f"dt: must resolve the fastest forcing {name} = {freq:.4g} Hz with at "
                         f"least {RESOLUTION_REFUSE} steps per period (dt <= "
                         f"{1 / (RESOLUTION_REFUSE * freq):.3g} s), got dt = {dt:g} s: "
                         f"{steps:.3g} steps")
    if steps < RESOLUTION_WARN:
        import warnings

        message = (f"dt = {dt:g} s gives only {steps:.3g} steps per period of {name} = "
                   f"{freq:.4g} Hz (fewer than {RESOLUTION_WARN}): the spectrum near it and "
                   f"the sections are coarse; dt <= {1 / (RESOLUTION_WARN * freq):.3g} s "
                   "resolves it")
        (warn or (lambda m: warnings.warn(m, RuntimeWarning, stacklevel=3)))(message)
    return steps


BLOW_UP_FACTOR = 1000.0
"""A displacement beyond this many clearances is a blow-up (models without a clearance are
only checked for non-finite states)."""


BALL_FRACTION = 0.25
"""... or beyond this fraction of the largest ball diameter: Hertz contact describes
deflections far smaller than the ball, so a displacement of a quarter of it is no longer a
motion of the bearing the model describes (a static deflection under 1e5 N on the paper's
bearing is 0.12 of its ball diameter)."""


def blow_up_limit(model: Model, values: Mapping[str, float]) -> float:
    """Displacement (m) beyond which a run of ``model`` with parameter ``values`` has blown
    up: ``BLOW_UP_FACTOR`` times the largest radial clearance of its bearings, or
    ``BALL_FRACTION`` of the largest ball diameter, whichever is smaller (the parameters
    that play the ``clearance`` and ``ball_diameter`` roles, ``Model.role``; inf without
    either: non-finite values only)."""
    clearance = max((abs(v) for v in model.role_values("clearance", values)), default=0.0)
    ball = max((abs(v) for v in model.role_values("ball_diameter", values)), default=0.0)
    limits = [BLOW_UP_FACTOR * clearance] if clearance > 0 else []
    limits += [BALL_FRACTION * ball] if ball > 0 else []
    return min(limits, default=np.inf)



VELOCITY_MARGIN = 10.0
"""The velocity bound of an initial state is this many times the displacement limit times
the model's fastest rate (``start_limits``)."""
STATE_CAP = 1e100
"""Every component of an initial state, in any unit, is within ±this: beyond it a cubic
term overflows a double (1e300) in the first step. The bound of a model without a
blow-up limit (no clearance and no ball diameter: only non-finite states blow up)."""


@dataclass(frozen=True)
class StartLimits:
    """Where an initial state of a System may lie (SI units): each body's centre within
    ``displacement`` (m) of the origin, each velocity component (m/s) within ±``velocity``,
    every component within ±``STATE_CAP``.

    The rule: a motion that stays within the displacement limit L (``blow_up_limit``: 1000
    clearances or a quarter ball) at the fastest rate R of the model (1/s: the largest |λ|
    of its stiffest linearisation, ``stable_step``, or 2π times its fastest forcing,
    ``fastest_forcing``, whichever is larger) moves at most L·R; the bound is
    ``VELOCITY_MARGIN`` times that (the paper's model: L = 1.19 mm, R = 8.7e3 1/s, so
    ±103 m/s). Without L, or without a rate, velocities are bounded by ``STATE_CAP`` only."""

    displacement: float
    velocity: float
    rate: float

    def bound(self, unit: str) -> float:
        """The bound of a component in ``unit`` (m: the displacement limit; m/s: the
        velocity bound; any other: ``STATE_CAP``)."""
        found = {"m": self.displacement, "m/s": self.velocity}.get(unit, math.inf)
        return min(found, STATE_CAP)

    def why(self, unit: str) -> tuple[str, str]:
        """(name, reason) of the rule behind ``bound(unit)``, in words."""
        if unit == "m" and math.isfinite(self.displacement):
            return "the blow-up limit", "a state there has diverged before it starts"
        if unit == "m/s" and math.isfinite(self.velocity):
            return "the velocity bound", (
                f"{VELOCITY_MARGIN:g} x the blow-up limit {self.displacement:.3g} m x the "
                f"model's fastest rate {self.rate:.3g} 1/s: a motion that fast leaves the "
                "limit at once")
        return "the largest initial value", "beyond it a cubic term overflows at once"


def start_limits(system: System) -> StartLimits:
    """The ``StartLimits`` of ``system`` (its model, balls and parameter values)."""
    limit = blow_up_limit(system.model, dict(system.parameters))
    if not math.isfinite(limit):
        return StartLimits(limit, math.inf, 0.0)
    _, largest = stable_step(system)
    rate = max(largest, 2 * math.pi * fastest_forcing(system)[1])
    velocity = VELOCITY_MARGIN * limit * rate if rate > 0 else math.inf
    return StartLimits(limit, velocity, rate)


def check_start_range(system: System, coordinate: str, low: float, high: float,
                      field: str, limits: StartLimits | None = None) -> None:
    """``InputError`` naming ``field`` when initial values of state ``coordinate`` from
    ``low`` to ``high`` (its unit) reach beyond its bound (``StartLimits``: a body's centre
    beyond the blow-up limit, a velocity beyond the velocity bound, any value beyond
    ``STATE_CAP``): the one check of every side of a box or grid of initial states."""
    model = system.model
    unit = model.state_units[coordinate]
    centres = {model.state_names[i] for pair in model.centre_indices() for i in pair
               if i is not None}
    limits = limits or start_limits(system)
    bound = limits.bound(unit) if unit != "m" or coordinate in centres else STATE_CAP
    if max(abs(low), abs(high)) <= bound:
        return
    name, reason = limits.why(unit) if bound < STATE_CAP else limits.why("")
    what, give = (f"{coordinate} = {low:g} {unit}", "value") if low == high else \
        (f"{coordinate} from {low:g} to {high:g} {unit}", "side")
    raise InputError(f"{field}: {what} reaches beyond {name} of {bound:.3g} {unit} "
                     f"({reason}); give a {give} within ±{bound:.3g} {unit}")


def check_start(system: System, state=None, field: str = "initial_state") -> None:
    """``InputError`` naming ``field`` when the initial state ``state`` (default: the
    System's) of ``system`` lies beyond its ``StartLimits``: each body's centre
    displacement (``hypot(x, y)``, as the blow-up predicate ``bad_states`` measures it),
    each velocity component and every component. The one check of every path that takes an
    initial state (``simulate``, ensembles; the sides of boxes and grids:
    ``check_start_range``)."""
    model = system.model
    z = system.state if state is None else np.asarray(state, dtype=float)
    limits = start_limits(system)
    for name, value in zip(model.state_names, z, strict=True):
        if model.state_units[name] != "m":
            check_start_range(system, name, float(value), float(value), field, limits)
    names = model.state_names
    for i, j in model.centre_indices():
        shift = abs(z[i]) if j is None else math.hypot(z[i], z[j])
        bound = limits.bound("m")
        if shift > bound:
            what = names[i] if j is None else f"hypot({names[i]}, {names[j]})"
            name, reason = limits.why("m")
            raise InputError(f"{field}: the centre displacement {what} = {shift:.3g} m is "
                             f"beyond {name} of {bound:.3g} m ({reason}); give one within "
                             f"{bound:.3g} m")


DEFLECTION_RATIO = 10.0
"""A static ball deflection this many times the radial clearance draws a warning
(``check_deflection``): a contact stiffness in the wrong unit, most often."""


def static_deflection(system: System, bearing: str) -> float | None:
    """The most loaded ball's static deflection (m) under the radial load, by Stribeck's
    rule Q_max = 5 F_r / (N_b cos α) and Hertz's δ = (Q_max / k)^(2/3) (T. A. Harris,
    *Rolling Bearing Analysis*, Sec. 7.2: zero clearance, a first estimate); None where the
    model has no radial load or no contact stiffness for the bearing."""
    values = dict(system.parameters)

    def get(name: str) -> float | None:
        value = values.get(f"{name}_{bearing}", values.get(name))
        return None if value is None else float(value)

    load, k = get("radial_load"), get("contact_stiffness")
    if not load or not k or k <= 0:
        return None
    n_balls = dict(zip(system.model.bearing_names, system.structure, strict=True))[bearing]
    q_max = 5.0 * abs(load) / (n_balls * math.cos(get("contact_angle") or 0.0))
    return (q_max / k) ** (2.0 / 3.0)


def check_deflection(system: System, warn=None) -> None:
    """Warn (``warn(message)``, default a Python warning) when a bearing's static ball
    deflection is more than ``DEFLECTION_RATIO`` times its radial clearance: a contact
    stiffness typed in N/mm^1.5 (10^4.5 too small) put 0.6 mm of deflection in a 10 µm
    clearance without a word. Nothing is refused: a soft contact may be meant."""
    values = dict(system.parameters)
    for bearing in system.model.bearing_names:
        clearance = values.get(f"radial_clearance_{bearing}", values.get("radial_clearance"))
        delta = static_deflection(system, bearing)
        if delta is None or not clearance or delta <= DEFLECTION_RATIO * clearance:
            continue
        k = values.get(f"contact_stiffness_{bearing}", values.get("contact_stiffness"))
        where = "" if len(system.structure) == 1 else f" of bearing '{bearing}'"
        message = (f"contact_stiffness{where}: {k:.4g} N/m^1.5 gives a static ball "
                   f"deflection of about {delta:.3g} m under the radial load, "
                   f"{delta / clearance:.3g} times the radial clearance ({clearance:.3g} m); "
                   f"check its unit (N/m^1.5: 1 N/mm^1.5 = 3.162e4 N/m^1.5)")
        import warnings

        (warn or (lambda m: warnings.warn(m, RuntimeWarning, stacklevel=3)))(message)
