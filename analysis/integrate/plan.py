"""A run plan: a run's system, times and step, checked once before any step is taken.

Every path that integrates a System makes one (``simulate`` and ``simulate_to_file``, the
sweep's and the chart's records, ``lyapunov``, ``shoot`` and continuation): the same checks
in the same order, whatever asks, and the defaults are the spec's own (``[simulation]``
``dt``, ``duration``, ``transient``). A plan either holds a whole run (``RunPlan.make``:
duration, transient, saved samples) or only a step (``RunPlan.step``: the largest RK4 step
of a flow map, whose length the period sets).

Checks, in this order (the first that fails is the one reported):

1. the times: duration and dt finite and > 0 s, transient in [0, duration), dt <= duration;
2. the method (``rk4`` or ``cvodes``) and CVODES' tolerances;
3. ``save_every`` a whole number >= 1 that keeps at least two samples after the transient;
4. the resolution: at most ``MAX_STEPS`` steps, and at least ``RESOLUTION_REFUSE`` steps per
   period of the fastest forcing (a warning below ``RESOLUTION_WARN``:
   ``analysis.integrate.checks.check_resolution``);
5. the memory of the samples a run keeps (``in_memory`` runs only);
6. the RK4 stability of the step at the model's stiffest linearisation
   (``analysis.integrate.checks.check_rk4_step``);
7. a speed profile, the run's own field (``RunPlan.profile``): the model follows it, a table
   covers the run, and 4 and 6 hold at each of its speeds (``check_profile``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from analysis.budgets import RUN_MEMORY
from analysis.errors import InputError, check_count
from analysis.integrate.checks import check_resolution, check_rk4_step, check_seconds
from analysis.integrate.speed_profile import SpeedProfile
from analysis.model import System

Method = Literal["rk4", "cvodes"]
METHODS = ("rk4", "cvodes")
"""The integration methods: fixed-step RK4 (the paper's) and adaptive CVODES (BDF)."""
"""Most bytes the states a run keeps in memory may take (their float64 values, twice: the
blocks and the assembled array)."""


def check_times(duration: float, transient: float, dt: float) -> None:
    """``InputError`` unless duration and dt are finite and > 0 s, the transient is in
    [0, duration) and the step fits in the duration."""
    check_seconds("duration", duration)
    check_seconds("dt", dt)
    if not (math.isfinite(transient) and 0 <= transient < duration):
        raise InputError(f"transient: must be in [0, duration) = [0, {duration:g}) s, "
                         f"got {transient!r}")
    if dt > duration:
        raise InputError(f"dt: must be <= duration ({duration:g} s), got {dt!r}")


def check_memory(n_state: int, n_saved: int, save_every: int) -> None:
    """``InputError`` when the samples of a run held in memory exceed ``RUN_MEMORY``."""
    need = 2 * 8 * (n_state + 1) * (n_saved + 1)
    if need > RUN_MEMORY:
        raise InputError(f"save_every: the run would keep {n_saved + 1:.3g} samples "
                         f"({need / 2**30:.3g} GiB); at most {RUN_MEMORY / 2**30:g} GiB: "
                         f"keep one sample every {math.ceil(save_every * need / RUN_MEMORY)} "
                         "steps or more (--save-every), or shorten the run")


def first_kept(threshold: float, step: float) -> int:
    """Smallest k with k·step >= threshold, computed as ``np.arange(…) * step`` computes the
    times (so the first kept sample is the same whichever way the run is stored)."""
    k = max(0, math.ceil(threshold / step))
    while k > 0 and float(np.float64(k - 1) * step) >= threshold:
        k -= 1
    while float(np.float64(k) * step) < threshold:
        k += 1
    return k



def steps_for_rate(rate_hz: float, dt_max: float) -> tuple[float, int]:
    """The RK4 step ``dt`` (s) and ``save_every`` of a run saved at ``rate_hz`` (Hz): the
    fewest steps per sample with ``dt <= dt_max`` (s) and ``dt`` = 1/(rate_hz · save_every)
    to a few ulps, chosen so that ``save_every * dt``, the spacing of the saved times
    (``RunPlan.times``), is the float 1/rate_hz exactly (one more step per sample where no
    float step of the fewest does that). A record's rate for a simulated result
    (``bearingdyn simulate --sample-rate 12000``: 42 steps of 1.984 µs per sample below the
    6205 models' 2 µs).

    >>> dt, n = steps_for_rate(12000.0, 2e-6)
    >>> n, n * dt == 1 / 12000.0, dt <= 2e-6
    (42, True, True)
    """
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"sample_rate: must be a rate in Hz > 0, got {rate_hz!r}")
    check_seconds("dt", dt_max)
    spacing = 1.0 / rate_hz
    fewest = max(1, math.ceil(spacing / dt_max - 1e-9))
    for save_every in range(fewest, fewest + 8):  # the first n with an exact float step
        dt = spacing / save_every
        for _ in range(8):  # dt, then one ulp down and up, two ulps …
            if dt <= dt_max and float(save_every * dt) == spacing:
                return dt, save_every
            dt = float(np.nextafter(dt, 0.0 if save_every * dt > spacing else np.inf))
    save_every = fewest  # no float step hits 1/rate exactly: within one ulp of it
    dt = min(spacing / save_every, dt_max)
    return dt, save_every

@dataclass(frozen=True)
class RunPlan:
    """A checked run of ``system``: step ``dt`` (s), ``duration`` and ``transient`` (s; the
    duration is None for a step-only plan), ``method``, ``save_every`` (keep every n-th
    step), the start time ``t0`` (s; None: a run from t = 0, recorded without ``t_start``)
    and CVODES' ``rtol``/``atol``. Make it with ``make`` or ``step``; the constructor checks
    nothing."""

    system: System
    dt: float
    duration: float | None = None
    transient: float = 0.0
    method: Method = "rk4"
    save_every: int = 1
    t0: float | None = None
    rtol: float = 1e-10
    atol: float = 1e-16
    profile: SpeedProfile | None = None
    """The run's speed profile (a run-up or coast-down; ``system`` is at its speed at
    t = 0), None at the constant speed of ``system``."""

    @classmethod
    def make(cls, system: System, *, duration: float | None = None,
             transient: float | None = None, dt: float | None = None, method: Method = "rk4",
             save_every: int = 1, rtol: float = 1e-10, atol: float = 1e-16, t0: float | None = None,
             in_memory: bool = False, warn: Callable[[str], None] | None = None,
             profile: SpeedProfile | None = None) -> RunPlan:
        """The plan of a whole run: every check of the module's list, in its order. None
        times are the spec's. ``in_memory``: the run keeps its samples in memory (checked
        against ``RUN_MEMORY``). ``warn(message)``: how a coarse step is reported
        (default: a Python warning). ``profile``: the speed the run follows (``system``
        taken at its speed at t = 0; a constant profile is that speed, no profile), checked
        last (``check_profile``)."""
        if profile is not None:
            system = system.replace(**{_speed(system): profile.start_rpm})
            profile = None if profile.is_constant else profile
        sim = system.model.simulation_defaults
        duration = float(sim["duration"] if duration is None else duration)
        transient = float(sim["transient"] if transient is None else transient)
        dt = float(sim["dt"] if dt is None else dt)
        check_times(duration, transient, dt)
        if method not in METHODS:
            raise InputError(f"method: must be 'rk4' or 'cvodes', got {method!r}")
        if method == "cvodes":
            if not (math.isfinite(rtol) and 0 < rtol < 1):
                raise InputError(f"rtol: must be in (0, 1), got {rtol!r}")
            if not (math.isfinite(atol) and 0 <= atol < 1):
                raise InputError(f"atol: must be in [0, 1), got {atol!r}")
        check_count("save_every", save_every, 1)
        check_resolution(system, dt, duration, warn=warn)
        plan = cls(system, dt, duration, transient, method, save_every,
                   None if t0 is None else float(t0), rtol, atol, profile)
        plan.check_kept()
        if in_memory:
            check_memory(system.n_state, plan.n_saved, save_every)
        check_rk4_step(system, dt, method)
        if profile is not None:
            check_profile(plan)
        return plan

    @classmethod
    def step(cls, system: System, dt: float | None = None, *,
             warn: Callable[[str], None] | None = None) -> RunPlan:
        """The plan of a step only (s; None: the spec's): the largest RK4 step of a flow
        map over a period (shooting, Floquet, continuation), checked as a run's step is:
        finite and > 0, resolving the fastest forcing, RK4-stable."""
        dt = float(system.model.simulation_defaults["dt"] if dt is None else dt)
        check_seconds("dt", dt)
        check_resolution(system, dt, warn=warn)
        check_rk4_step(system, dt)
        return cls(system, dt)

    @property
    def n_steps(self) -> int:
        """RK4 steps of the whole run (transient included)."""
        return round(self._duration / self.dt)

    @property
    def n_saved(self) -> int:
        """Index of the last saved sample (samples 0 … n_saved are saved)."""
        return self.n_steps // self.save_every

    @property
    def first(self) -> int:
        """Index of the first saved sample after the transient."""
        threshold = self.transient - 1e-12 * self._duration
        return max(0, first_kept(threshold, self.save_every * self.dt))

    @property
    def n_kept(self) -> int:
        """Samples the run keeps after the transient (``first`` … ``n_saved``)."""
        return self.n_saved - self.first + 1

    def check_kept(self) -> None:
        """``InputError`` when the run would keep fewer than two samples after the transient
        (``save_every`` beyond the run's steps): nothing to analyse, not even a spectrum."""
        if self.n_kept >= 2:
            return
        after = self.n_steps - math.ceil(self.transient / self.dt - 1e-9)  # steps kept from
        top = max(1, min(self.save_every - 1, after))
        most = next((n for n in range(top, max(1, top - 10_000), -1)
                     if replace(self, save_every=n).n_kept >= 2), max(1, after // 2))
        raise InputError(f"save_every: must be in [1, {most}] to keep at least 2 samples "
                         f"after the transient ({self.n_steps} steps of {self.dt:g} s, "
                         f"transient {self.transient:g} s), got {self.save_every}: "
                         f"{max(self.n_kept, 0)} sample(s) kept")

    def times(self, start: int = 0, stop: int | None = None) -> np.ndarray:
        """Times (s, from ``t0``) of the saved samples ``start … stop − 1`` (all: 0 …
        n_saved)."""
        stop = self.n_saved + 1 if stop is None else stop
        elapsed = np.arange(start, stop) * (self.save_every * self.dt)
        return elapsed if self.t0 is None else self.t0 + elapsed

    def settings(self) -> dict[str, float | int | str]:
        """The run's settings as result attributes, in the order results write them."""
        out: dict[str, float | int | str] = {
            "method": self.method, "dt": self.dt, "save_every": self.save_every,
            "duration": self._duration, "transient": self.transient}
        if self.t0 is not None:
            out["t_start"] = self.t0
        return out

    @property
    def _duration(self) -> float:
        if self.duration is None:
            raise InputError("duration: a step-only plan has no duration")
        return self.duration


def _speed(system: System) -> str:
    """The parameter that sets the shaft speed (its ``speed`` role); ``InputError`` for a
    model without one: a speed profile needs a rotor."""
    speed = system.model.role("speed")
    if not speed:
        raise InputError(f"speed_rpm: model '{system.model.name}' has no parameter "
                         "speed_rpm; a speed profile needs a rotor", field="speed_rpm")
    return speed[0]


def check_profile(plan: RunPlan) -> None:
    """The checks of a run's speed profile, on its ``plan``: the model can follow it
    (``speed_profile.check_model``), a table reaches the end of the run, and the plan's
    checks of the speed (its range, the resolution of the fastest forcing, the RK4
    stability of the step) hold at every speed of the profile's rows."""
    from analysis.integrate.speed_profile import check_model

    system, profile = plan.system, plan.profile
    check_model(system.model, system.structure, dict(system.parameters))
    profile.check_covers(plan.duration)
    for speed in sorted(set(profile.rpm)):
        at_speed = system.replace(**{_speed(system): speed})
        check_resolution(at_speed, plan.dt)
        check_rk4_step(at_speed, plan.dt, plan.method)
