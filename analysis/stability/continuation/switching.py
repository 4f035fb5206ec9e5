"""Branch switching: the new branch born at a period doubling (PD) or a branch point (BP).

``switch_branch`` solves the orbit born at a labelled point of a branch: the period-2 orbit
at a PD (``switch_period_doubling``), the asymmetric orbit at a symmetry-breaking pitchfork
BP (``switch_branch_point``); ``switch_and_continue`` does it at the first (or a chosen) PD
or BP point and continues the new branch, in one call.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.flow import Period, evaluate, flow_map, period_seconds
from analysis.provenance import system_of_attrs
from analysis.stability.continuation.dataset import first_point
from analysis.stability.continuation.options import ContinuationOptions
from analysis.stability.continuation.shooting import continue_from_orbit
from analysis.stability.continuation.trace import Progress
from analysis.stability.periodic import (
    PeriodicOrbit,
    as_period,
    shoot,
    state_scale,
)


@dataclass(frozen=True)
class _Switch:
    """What branch switching at a special point looks for: the critical multiplier (the
    smallest real part at a PD, the largest at a BP) must be beyond ``bound`` on the
    unstable side; the new orbit has the period ``period(base)`` and must not be the old
    orbit (``fallen_back``)."""

    kind: str
    critical: Callable[[np.ndarray], int]
    beyond: Callable[[float], bool]
    bound: str
    period: Callable[[Period], Period]
    orbit: str
    fallen_back: Callable[[PeriodicOrbit, PeriodicOrbit, np.ndarray], bool]


def _repeats_after_base_period(one: PeriodicOrbit, new: PeriodicOrbit,
                               size: np.ndarray) -> bool:
    """The period-2 orbit ``new`` is an orbit of ``one``'s period: Φ_T(z) = z."""
    model = one.system.model
    half = evaluate(flow_map(model, one.structure, as_period(model, one.period), one.n_steps),
                    new.z0, new.t0, one.system.p)[0]
    return bool(np.max(np.abs((half - new.z0) / size)) < 1e-6)


def _same_orbit(one: PeriodicOrbit, new: PeriodicOrbit, size: np.ndarray) -> bool:
    """``new`` is the orbit ``one`` again (same state at the section)."""
    return bool(np.max(np.abs((new.z0 - one.z0) / size)) < 1e-6)


SWITCHES = {
    "PD": _Switch("PD", lambda mu: int(np.argmin(mu.real)), lambda r: r < -1, "below −1",
                  Period.doubled, "period-1", _repeats_after_base_period),
    "BP": _Switch("BP", lambda mu: int(np.argmax(mu.real)), lambda r: r > 1, "above +1",
                  lambda per: per, "symmetric", _same_orbit),
}


def switch_branch(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                  kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The orbit born at the special point ``branch.point[point]``: the period-2 orbit at a
    period doubling (label PD), the asymmetric orbit at a symmetry-breaking pitchfork (BP).

    Steps ``offset`` × |range| into the side where the branch's orbit is unstable, solves
    that orbit there, kicks it along the eigenvector of its critical multiplier (below −1 at
    a PD, above +1 at a BP: the direction of the kernel of M ∓ I at the point) by ``kick`` ×
    the orbit size, and shoots for a fixed point of the doubled (PD) or the same (BP)
    period. The result is checked not to be the old orbit (``converged = False`` with the
    reason otherwise). ``dt`` (s): the RK4 step, default the branch's own.
    """
    kind = str(branch.special.values[point])
    if kind not in SWITCHES:
        raise InputError(f"point: {point} is not a PD or BP point (label '{kind}')")
    rule = SWITCHES[kind]
    attrs = branch.attrs
    param = attrs["param"]
    lam = float(branch[param][point])
    base = system_of_attrs({**attrs, param: lam})
    model = base.model
    unstable_side = [i for i in (point + 1, point - 1)
                     if 0 <= i < branch.sizes["point"] and not branch.stable.values[i]]
    if not unstable_side:
        raise InputError(f"point: no unstable {rule.orbit} orbit next to point {point}")
    step = float(branch[param][unstable_side[0]]) - lam
    lam += math.copysign(offset * _range(branch, param), step)
    system = base.replace(**{param: lam})
    period = Period.parse(attrs["period"])
    dt = dt or period_seconds(model, system.structure, period, dict(system.parameters)) / int(
        attrs["steps_per_period"])
    one = shoot(system, None, period, branch.z0.values[point], float(attrs["t0"]), dt=dt)
    mu, vectors = np.linalg.eig(one.monodromy)
    k = rule.critical(mu)
    if not (one.converged and rule.beyond(mu[k].real)):
        raise InputError(f"point: no {rule.orbit} orbit with a multiplier {rule.bound} at "
                         f"{param} = {lam:g} ({one.message}; multipliers {np.round(mu, 4)})")
    v = np.real(vectors[:, k])
    size = state_scale(one.z0, one.period_s, model.module.STATE_UNITS)
    guess = one.z0 + kick * size * v / np.max(np.abs(v / size))
    new = shoot(one.system, None, rule.period(period), guess, one.t0, dt=dt)
    if new.converged and rule.fallen_back(one, new, size):
        new.converged = False
        new.message = f"Newton fell back onto the {rule.orbit} orbit; try a larger kick"
    return new


def switch_period_doubling(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                           kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The period-2 orbit born at the period doubling ``branch.point[point]`` (label PD):
    ``switch_branch`` at a PD point. The result is checked to be a genuine period-2 orbit
    (Φ_T(z) ≠ z)."""
    if str(branch.special.values[point]) != "PD":
        raise InputError(f"point: {point} is not a period-doubling point (label "
                         f"'{branch.special.values[point]}')")
    return switch_branch(branch, point, offset=offset, kick=kick, dt=dt)


def switch_branch_point(branch: xr.Dataset, point: int, *, offset: float = 0.02,
                        kick: float = 0.05, dt: float | None = None) -> PeriodicOrbit:
    """The asymmetric orbit born at the branch point ``branch.point[point]`` (label BP, a
    real multiplier through +1 without a fold: a symmetry-breaking pitchfork):
    ``switch_branch`` at a BP point. The result is checked not to be the symmetric orbit."""
    if str(branch.special.values[point]) != "BP":
        raise InputError(f"point: {point} is not a branch point (label "
                         f"'{branch.special.values[point]}')")
    return switch_branch(branch, point, offset=offset, kick=kick, dt=dt)


def _range(branch: xr.Dataset, param: str) -> float:
    values = branch[param].values
    return float(np.ptp(values)) or abs(float(values[0])) or 1.0


@dataclass(frozen=True)
class Switched:
    """What ``switch_and_continue`` gives: the new ``branch`` (attr ``switched_at``: PD or
    BP) and the ``point`` of the old branch it was born at, or ``branch`` None and the
    reason in ``message`` (no such point on the branch, or switching failed)."""

    branch: xr.Dataset | None
    point: int | None
    message: str = ""

    @property
    def ok(self) -> bool:
        """A new branch was found and continued."""
        return self.branch is not None


def switch_and_continue(branch: xr.Dataset, kind: str = "PD", *, stop: float,
                        point: int | None = None,
                        options: ContinuationOptions | None = None, dt: float | None = None,
                        progress: Progress = None, offset: float = 0.02,
                        kick: float = 0.05) -> Switched:
    """Switch to the branch born at a PD (the period-2 branch) or BP (the asymmetric
    branch) point of ``branch`` and continue it towards ``stop`` (the parameter's unit).

    ``point``: the index of the point (default the first labelled ``kind``); ``offset`` and
    ``kick`` as in ``switch_branch`` (which uses the branch's own RK4 step). The new
    branch is continued by ``continue_from_orbit`` with ``options`` (default
    ``ContinuationOptions()``), ``dt`` (s; default the spec's) and ``progress``; it is
    named ``period 2·…`` (PD) or ``asymmetric, period …`` (BP) and has the attr
    ``switched_at`` = ``kind``. When the branch has no ``kind`` point or the Newton solve
    of the new orbit fails, the result has no branch and says why in ``message``
    (``no PD point on the branch: nothing to switch to``, ``branch switching at PD (point
    k) failed: …``). ``InputError`` for a bad ``kind`` or ``point``, or when there is no
    unstable orbit to switch from next to the point.
    """
    if kind not in SWITCHES:
        raise InputError(f"kind: must be PD or BP, got {kind!r}")
    if point is None:
        k = first_point(branch, kind)
        if k is None:
            return Switched(None, None, f"no {kind} point on the branch: nothing to switch to")
    else:
        size = branch.sizes["point"]
        if isinstance(point, bool) or not isinstance(point, (int, np.integer)) or \
                not -size <= point < size:
            raise InputError(f"point: must be in [{-size}, {size - 1}] (the branch has "
                             f"{size} points), got {point}")
        k = int(point) % size
    switch = switch_period_doubling if kind == "PD" else switch_branch_point
    orbit = switch(branch, k, offset=offset, kick=kick)
    if not orbit.converged:
        return Switched(None, k, f"branch switching at {kind} (point {k}) failed: "
                                 f"{orbit.message}")
    what = "period " + orbit.period if kind == "PD" else f"asymmetric, period {orbit.period}"
    new = continue_from_orbit(orbit, param=branch.attrs["param"], stop=stop, dt=dt,
                              progress=progress, label=what, options=options)
    new.attrs["switched_at"] = kind
    return Switched(new, k)
