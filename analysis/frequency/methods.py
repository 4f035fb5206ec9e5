"""The frequency-domain methods as data: what ``bearingdyn hb`` and ``bearingdyn torus`` look
up, so that a command only parses, looks up and prints.

A ``Method`` is one way to compute a response: its name, the field that sets its resolution
(``harmonics`` H or H1,H2; ``points`` N) and three functions of a System and a ``Request``:
``check`` (every input, before any work: nothing is written after a refusal), ``solve`` (one
response, as a Dataset) and ``follow`` (a branch in a runtime parameter, as a Dataset); and
``estimate``, its cost from a short timed probe (``frequency.cost``), said before the work.

* ``PERIODIC["hb"]``: harmonic balance of a T-periodic response with Hill's stability
  (``harmonic_balance``, ``continue_harmonic``);
* ``TORUS["hb"]``: the 2-torus of two base frequencies by 2-D harmonic balance and its λ1
  (``solve_torus``, ``continue_torus``);
* ``TORUS["shooting"]``: the same torus as the invariant circle of the F1-period map
  (``solve_circle``, ``continue_circle``; λ1 of one circle only).

Adding a method is one entry: its three functions and its resolution.

A command runs a method as a study plan (``analysis.integrate.study.StudyPlan``):
``plan_branch(method, system, request, end, output)`` checks every input once and returns
a ``BranchPlan`` (no store: a branch is not resumable), which the one runner
(``analysis.sweeps.runner.run_study``) costs, runs and writes. ``Method.run`` and
``Method.measured`` are the same plan run in memory.

>>> sorted(TORUS), TORUS["shooting"].resolution
(['hb', 'shooting'], 'points')
>>> method_of(TORUS, "fourier", "method")
Traceback (most recent call last):
...
analysis.errors.InputError: method: must be hb or shooting, got 'fourier'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.frequency.circle.solve import DEFAULT_POINTS
from analysis.frequency.cost import circle_cost, hb_cost, torus_hb_cost
from analysis.integrate.cost import CostEstimate
from analysis.model import System

Progress = Callable[[str], None] | None


@dataclass(frozen=True)
class Request:
    """What a command asks of a method (None: the method's default).

    ``resolution``: H (periodic HB), (H1, H2) or ``"H1,H2"`` (torus HB), N circle points
    (shooting); ``period``: the forcing period of a periodic response (``forcing`` names);
    ``frequencies``: F1,F2 of a torus; ``param``, ``start``, ``stop``: the continued runtime
    parameter and its ends (its unit; all None for one response); ``max_points``,
    ``ds_max``: the branch's size and largest scaled step; ``lyapunov_duration``: the
    averaging time of a torus's λ1, s (0: none); ``stability_every``: λ1 at every k-th torus
    of a branch; ``options``: ``dt``, ``settle`` (s) and ``samples`` given by the user;
    ``progress``: one line per message."""

    resolution: object = None
    period: str | None = None
    frequencies: str = "shaft,vc"
    param: str | None = None
    start: float | None = None
    stop: float | None = None
    max_points: int = 200
    ds_max: float = 0.05
    lyapunov_duration: float = 2.0
    stability_every: int = 1
    options: Mapping = field(default_factory=dict)
    progress: Progress = None
    figure: float | None = None
    """With a figure, the simulated seconds of its time run (0: none); None: no figure.
    Counted in the cost."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lyapunov_duration) and self.lyapunov_duration >= 0):
            raise InputError(f"lyapunov_duration: must be a finite number >= 0 s, got "
                             f"{self.lyapunov_duration!r}", field="lyapunov_duration")
        from analysis.errors import check_count

        check_count("stability_every", self.stability_every)

    @property
    def branch(self) -> dict:
        """The keywords every ``continue_*`` takes."""
        return dict(param=self.param, start=self.start, stop=self.stop,
                    max_points=self.max_points, ds_max=self.ds_max, progress=self.progress,
                    **self.options)

    @property
    def stability(self) -> dict:
        """λ1 of a torus: whether, and over how long (s)."""
        return dict(stability=self.lyapunov_duration > 0,
                    lyapunov_duration=self.lyapunov_duration or 2.0)


@dataclass(frozen=True)
class Method:
    """One method of a family: ``check(system, end, request)`` (``end``: the System at the
    far end of a branch, or None), ``solve(system, request)`` and ``follow(system,
    request)``, each a Dataset; ``resolution`` names the field that sizes it, ``default``
    is its value when none is given, and ``resolved`` says so in words."""

    name: str
    resolution: str
    default: object
    resolved: str
    check: Callable[[System, System | None, Request], None]
    solve: Callable[[System, Request], xr.Dataset]
    follow: Callable[[System, Request], xr.Dataset]
    estimate: Callable[[System, Request], CostEstimate] | None = None
    """The cost of a checked request, from a short timed probe (``frequency.cost``)."""
    error: Callable[[Method, System, Request, xr.Dataset], xr.Dataset] | None = None
    """``data`` with the method's own error estimate in its attrs (``accuracy.hb_error``;
    the invariant circle's ``circle_run.with_between_error``)."""
    resize: Callable[[System, Request], None] | None = None
    """The checks of ``check`` that depend on the resolution and the samples alone: what a
    re-solve of a checked study at another size (the error estimate's, ``resized``) checks
    again; None: ``check`` whole."""
    unit: str = "points"
    """What the points of a branch are (``responses``, ``tori``, ``circles``)."""

    def measured(self, system: System, request: Request, end: System | None = None,
                 cost: Callable[[CostEstimate], None] | None = None) -> xr.Dataset:
        """``run``, then the method's own error estimate (``error``) in the attrs."""
        plan = plan_branch(self, system, request, end)
        if cost is not None and self.estimate is not None:
            cost(plan.cost(1))
        return plan.run(None, None, None, None)

    def run(self, system: System, request: Request, end: System | None = None,
            cost: Callable[[CostEstimate], None] | None = None) -> xr.Dataset:
        """Check, then one response (no ``request.param``) or its branch; a request without
        a resolution gets the method's default. ``cost``: given the estimate after the
        checks, before the work."""
        plan = plan_branch(self, system, request, end)
        if cost is not None and self.estimate is not None:
            cost(plan.cost(1))
        return plan.response()

    def resized(self, system: System, request: Request) -> xr.Dataset:
        """One response of a study already checked whole (``check``), at the resolution
        and samples of ``request`` (the error estimate's re-solves at 2H and at twice the
        samples): only ``resize`` checks again (what the size changes), then ``solve``."""
        if self.resize is None:
            self.check(system, None, request)
        else:
            self.resize(system, request)
        return self.solve(system, request)


@dataclass(frozen=True)
class BranchPlan:
    """A frequency-domain study as a ``StudyPlan`` (``analysis.integrate.study``): one
    response of ``method`` or its branch in ``request.param``, checked whole by
    ``plan_branch`` (``method.check`` once). No store (``definition`` None: a branch is not
    resumable) and no member kernel (``placement`` None); ``total``: the responses at most
    (``max_points`` of a branch, else 1), counted in ``unit``. ``run`` solves or follows
    and adds the method's own error estimate; the runner writes ``output``
    (``analysis.sweeps.runner.run_study``). The progress of a branch goes to
    ``request.progress``, one line per message."""

    kind: str
    method: Method
    system: System
    request: Request
    end: System | None
    output: Path | None
    """The netCDF file the runner writes; None: a plan run in memory (``Method.run``)."""
    total: int
    unit: str
    definition: None = None
    placement: None = None

    def cost(self, workers: int) -> CostEstimate:
        """The method's estimate (a short timed probe: ``frequency.cost``); the work runs
        on one worker whatever ``workers`` are."""
        if self.method.estimate is None:
            raise TypeError(f"method {self.method.name!r} has no cost estimate")
        return self.method.estimate(self.system, self.request)

    def response(self) -> xr.Dataset:
        """The response (no ``request.param``) or its branch, without the error
        estimate."""
        method = self.method
        return (method.follow if self.request.param is not None else method.solve)(
            self.system, self.request)

    def run(self, store: object, executor: object, progress: object,
            say: object) -> xr.Dataset:
        """``response``, then the method's own error estimate in the attrs (``store``,
        ``executor``, ``progress`` and ``say`` are not used: the work is one serial solve
        or branch, its lines to ``request.progress``)."""
        data = self.response()
        error = self.method.error
        return data if error is None else error(self.method, self.system, self.request, data)


def plan_branch(method: Method, system: System, request: Request, end: System | None = None,
                output: Path | None = None, kind: str | None = None) -> BranchPlan:
    """The study of ``request`` by ``method`` on ``system`` (``end``: the System at the far
    end of a branch, or None), every input checked once (``method.check``; a request
    without a resolution gets the method's default first), before any work; ``output``:
    the file ``run_study`` writes; ``kind``: the plan's name (default the method's).
    ``InputError`` naming its field otherwise."""
    if request.resolution is None:
        request = replace(request, resolution=method.default)
    method.check(system, end, request)
    return BranchPlan(kind or method.name, method, system, request, end, output,
                      request.max_points if request.param is not None else 1, method.unit)


def method_of(table: Mapping[str, Method], name: str, field: str = "method") -> Method:
    """The method called ``name`` in ``table``; ``InputError`` naming the choices."""
    if name not in table:
        raise InputError(f"{field}: must be {' or '.join(table)}, got {name!r}", field=field)
    return table[name]


def default_torus_method(frequencies: str, harmonics: object = None) -> str:
    """The method ``torus`` uses when none is named: ``hb`` when ``harmonics`` are given
    or the frequencies do not suit the shaft map (F1 a VC, or F2 not one), else
    ``shooting``. The rule is measured (docs/frequency.md): on every shipped contact model
    2-D harmonic balance is 20–38 % of the amplitude away from a long simulation while
    its residual reads 1e-10, and the invariant circle is within 1e-3.

    >>> default_torus_method("shaft,vc"), default_torus_method("shaft,vc", "8,4")
    ('shooting', 'hb')
    >>> default_torus_method("vc[left],vc[right]")
    'hb'
    """
    if harmonics is not None:
        return "hb"
    parts = [p.strip() for p in str(frequencies).split(",")]
    suits = (len(parts) == 2 and not parts[0].startswith("vc")
             and parts[1].startswith("vc"))
    return "shooting" if suits else "hb"


def _converged(result, what: str):
    if not result.converged:
        raise InputError(f"{what} ({result.message})")
    return result


def _check_periodic(system: System, end: System | None, request: Request) -> None:
    from analysis.frequency.periodic.harmonic import check_forced, check_harmonics, fast_samples
    from analysis.frequency.periodic.solve import prepare

    check_harmonics(request.resolution, system.n_state)
    check_forced(system)
    prepare(system, request.period)  # the period exists and lasts a finite time here
    fast_samples(request.resolution, request.options.get("samples"))


def _resize_periodic(system: System, request: Request) -> None:
    from analysis.frequency.periodic.harmonic import check_harmonics, fast_samples

    check_harmonics(request.resolution, system.n_state)
    fast_samples(request.resolution, request.options.get("samples"))


def _solve_periodic(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.periodic.solve import harmonic_balance, response_dataset

    response = harmonic_balance(system, None, request.period, request.resolution,
                                **request.options)
    return response_dataset(_converged(response, "hb: no periodic response found"))


def _follow_periodic(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.periodic.continuation import continue_harmonic

    return continue_harmonic(system, None, period=request.period,
                             harmonics=request.resolution, **request.branch)


def _torus_frequencies(system: System, end: System | None, request: Request,
                       harmonics: object = (8, 4)):
    """F1, F2 parsed, and not commensurate within ``harmonics`` at either end."""
    from analysis.frequency.torus.equations import check_frequencies, parse_frequencies

    freqs = parse_frequencies(request.frequencies, system.model)
    for s in (system, end) if end is not None else (system,):
        check_frequencies(s, freqs, harmonics)
    return freqs


FORCING_PERIODS = 20
"""Periods of F1 of the short run on which ``_check_forcing`` compares the torus forcing
with the model's (the solve compares them again on its settled run)..."""
FORCING_SECONDS = 0.5
"""... and at most this many seconds of it."""


def _check_forcing(system: System, freqs, dt: float | None) -> None:
    """The torus forcing of ``freqs`` is the model's (``torus.check_phases``) on a short run
    from the initial state (``FORCING_PERIODS`` periods of F1, at most ``FORCING_SECONDS``;
    RK4 steps of ``dt`` s, the spec's when None), before the cost is said and any work
    done: 'do not carry' in one line, not after the estimate."""
    from analysis.frequency.torus.equations import check_phases, omegas_of, torus_function
    from analysis.integrate.plan import RunPlan
    from analysis.integrate.simulate import simulate

    period = 2 * math.pi / omegas_of(system, freqs)[0]
    dt = RunPlan.step(system, dt, warn=lambda message: None).dt
    run = simulate(system, duration=min(FORCING_PERIODS * period, FORCING_SECONDS),
                   transient=0.0, dt=dt)
    t = run.t.values[::max(1, run.sizes["t"] // 50)]
    z = np.column_stack([run[name].values[::max(1, run.sizes["t"] // 50)]
                         for name in system.state_names])
    check_phases(system, freqs, torus_function(system, freqs), t, z)


def _check_torus(system: System, end: System | None, request: Request) -> None:
    from analysis.frequency.periodic.harmonic import check_forced
    from analysis.frequency.torus.equations import check_torus_harmonics

    check_forced(system)
    pair = check_torus_harmonics(request.resolution, system.n_state)
    _check_forcing(system, _torus_frequencies(system, end, request, pair),
                   request.options.get("dt"))


def _resize_torus(system: System, request: Request) -> None:
    from analysis.frequency.torus.equations import check_torus_harmonics

    pair = check_torus_harmonics(request.resolution, system.n_state)
    _torus_frequencies(system, None, request, pair)


def _solve_torus(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.torus.dataset import torus_dataset
    from analysis.frequency.torus.solve import solve_torus

    response = solve_torus(system, None, request.frequencies, request.resolution,
                           **request.stability, **request.options)
    return torus_dataset(_converged(response, "torus: no torus found"))


def _follow_torus(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.torus.continuation import continue_torus

    return continue_torus(system, None, frequencies=request.frequencies,
                          harmonics=request.resolution, **request.stability,
                          stability_every=request.stability_every, **request.branch)


def _check_circle(system: System, end: System | None, request: Request) -> None:
    from analysis.frequency.circle.solve import check_points
    from analysis.frequency.periodic.harmonic import check_forced

    check_forced(system)
    check_points(request.resolution, system.n_state)
    freqs = _torus_frequencies(system, end, request)
    if freqs[0].kind == "vc" or freqs[1].kind != "vc":
        raise InputError(f"frequencies: --method shooting needs F1 shaft or param:NAME and "
                         f"F2 a vc, got {request.frequencies}", field="frequencies")
    _check_forcing(system, freqs, request.options.get("dt"))


def _solve_circle(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.circle.solve import circle_dataset, solve_circle

    circle = solve_circle(system, None, request.frequencies, request.resolution,
                          **request.stability, **request.options)
    return circle_dataset(_converged(circle, "torus: no invariant circle found; the response "
                                     "here may not be quasi-periodic (check a run with "
                                     "bearingdyn classify)"))


def _follow_circle(system: System, request: Request) -> xr.Dataset:
    from analysis.frequency.circle.continuation import continue_circle

    return continue_circle(system, None, frequencies=request.frequencies,
                           points=request.resolution, **request.branch)


def _hb_error(method: Method, system: System, request: Request,
              data: xr.Dataset) -> xr.Dataset:
    from analysis.frequency.accuracy import hb_error

    return hb_error(method, system, request, data)


def _circle_error(method: Method, system: System, request: Request,
                  data: xr.Dataset) -> xr.Dataset:
    from analysis.frequency.circle_run import with_between_error

    return with_between_error(data)


PERIODIC: dict[str, Method] = {
    "hb": Method("hb", "harmonics", 10, "harmonic balance is resolved by --harmonics",
                 _check_periodic, _solve_periodic, _follow_periodic, hb_cost, _hb_error,
                 _resize_periodic, "responses"),
}
"""The methods of a periodic response (``bearingdyn hb``)."""

TORUS: dict[str, Method] = {
    "hb": Method("hb", "harmonics", "8,4", "harmonic balance is resolved by --harmonics",
                 _check_torus, _solve_torus, _follow_torus, torus_hb_cost, _hb_error,
                 _resize_torus, "tori"),
    "shooting": Method("shooting", "points", DEFAULT_POINTS,
                       "the shooting torus is resolved by --points",
                       _check_circle, _solve_circle, _follow_circle, circle_cost,
                       _circle_error, unit="circles"),
}
"""The methods of a 2-torus (``bearingdyn torus --method``)."""
