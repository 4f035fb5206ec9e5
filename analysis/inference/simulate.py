"""One round of a calibration on the ensemble engine: every parameter set at every target
row, each row one ensemble call, each member classified and its spectrum lines named.

A member is one parameter set at one row (its balls and conditions). Its run is fixed-step
RK4 with a step h that divides the shaft period T into ``samples_per_revolution``·j steps,
so the samples the engine returns every j steps are a time record (for the spectrum, on
the host) and every ``samples_per_revolution``-th sample is a shaft Poincaré point (for
the class). The record is classified as every chart point is
(``stability.classify.classify_section``, with λ1 and its 95 % interval from a tangent
carried over the record), and its lines named as ``signal.spectrum.find_peaks`` names
them. A member that blows up (``integrate.ensemble.bad_points``: not finite, or beyond the
blow-up limit) is given the class ``diverged``: it stays in the round, never dropped.

The engine: the member kernels of ``analysis.integrate.kernels`` (``run_members`` with a
``Schedule`` and one tangent vector; the C build on every core with OpenMP, or the CUDA
build on the GPU: ``device``). A row's members are one call.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np
import xarray as xr

from analysis.errors import InputError, check_count
from analysis.inference.targets import Target, TargetRow
from analysis.integrate.kernels import Schedule, run_members
from analysis.integrate.kernels.placement import CPU, Placement
from analysis.integrate.plan import RunPlan
from analysis.model import Model, System, as_system, load_model
from analysis.provenance import completed_attrs, state_names, to_dataset
from analysis.signal.poincare import poincare_section
from analysis.signal.spectrum import Peak, find_peaks
from analysis.stability.classify import classify_section, verdict_points
from analysis.stability.lyapunov import BLOCKS, batch_ci95


@dataclass(frozen=True)
class RunSettings:
    """How long each member runs and how its record is sampled."""

    transient_revolutions: int = 50
    """Shaft revolutions dropped before the record."""
    revolutions: int = 100
    """Shaft revolutions recorded: the Poincaré points and the spectrum's record. A
    multiple of ``BLOCKS`` (λ1's batches) and at least ``verdict_points()``."""
    samples_per_revolution: int = 40
    """Record samples per revolution (the spectrum's Nyquist frequency is half that many
    times X)."""
    dt: float | None = None
    """Largest RK4 step, s (None: the spec's)."""
    max_peaks: int = 8
    """Peaks per coordinate among which lines are looked for (``find_peaks``)."""

    def check(self) -> None:
        least = verdict_points() + 1
        for name, value, low in (("transient_revolutions", self.transient_revolutions, 0),
                                 ("revolutions", self.revolutions, least),
                                 ("samples_per_revolution", self.samples_per_revolution, 8),
                                 ("max_peaks", self.max_peaks, 1)):
            check_count(name, value, low, 100_000)
        if self.revolutions % BLOCKS:
            raise InputError(f"revolutions: must be a multiple of {BLOCKS} (λ1's batches), "
                             f"got {self.revolutions}")
        if self.dt is not None and not (math.isfinite(self.dt) and self.dt > 0):
            raise InputError(f"dt: must be a finite number > 0 s, got {self.dt!r}")

    def steps(self, system: System) -> tuple[float, int]:
        """(h in s, RK4 steps per record sample) for ``system``: h divides the shaft period
        into ``samples_per_revolution``·j steps, h <= ``dt``."""
        shaft_hz = system.frequencies().shaft_hz
        if not shaft_hz > 0:
            raise InputError("speed_rpm: calibration samples shaft revolutions; the shaft "
                             "must turn (speed_rpm > 0)")
        dt = float(self.dt or system.model.simulation_defaults["dt"])
        period = 1.0 / shaft_hz
        every = max(1, math.ceil(period / (self.samples_per_revolution * dt) - 1e-9))
        return period / (self.samples_per_revolution * every), every


@dataclass(frozen=True)
class EngineResult:
    """What the engine returns for M members."""

    samples: np.ndarray
    """(M, K, n): the state after every sampled step of the record (SI units)."""
    lambda1: np.ndarray
    """(M,): λ1 over the record, 1/s (NaN for a diverged member)."""
    ci95: np.ndarray
    """(M,): its 95 % half-width, 1/s."""
    diverged_at: np.ndarray
    """(M,) the RK4 step of a member's first state beyond the blow-up bound
    (``simulate.blow_up_limit``; not finite), -1 if never."""
    device: str


def run_engine(system: System, states: np.ndarray, parameters: np.ndarray, h: float,
               every: int, transient_samples: int, n_samples: int, per_revolution: int,
               device: str | Placement = CPU,
               progress: Callable[[int, int], None] | None = None) -> EngineResult:
    """Run M members of ``system``'s model and balls in one call of the member kernels
    (``analysis.integrate.kernels.run_members``): ``states`` (M × n), ``parameters``
    (M × n_par), step ``h`` s; ``transient_samples`` · ``every`` steps dropped, then
    ``n_samples`` samples every ``every`` steps kept, with one tangent vector renormalised
    at each sample; λ1 is the mean growth over the record, its 95 % interval from batch
    means of the revolutions' growths (``per_revolution`` samples each). ``device``: a
    ``Placement`` judged once by the study, or a name placed here (default: the cores,
    ``placement.CPU``, nothing judged). ``progress(done, M)``: members run so far (on the
    CPU every ~0.5 s of work)."""
    schedule = Schedule(transient_samples * every, every, n_samples, tangent=True,
                        lyapunov_skip=0, keep_sections=True)
    out = run_members(system, states, parameters, h, schedule, device=device,
                      progress=progress)
    logs = np.asarray(out.logs, dtype=float)
    per = logs.reshape(len(logs), -1, per_revolution).sum(axis=2)
    with np.errstate(invalid="ignore"):
        ci = batch_ci95(per, per_revolution * every * h)
    return EngineResult(np.asarray(out.sections), np.asarray(out.lambda1), ci,
                        np.asarray(out.diverged_at), str(out.device))


def row_system(model: Model, row: TargetRow) -> System:
    """The System of a target row: its balls and conditions, the model's defaults else."""
    return as_system(model, row.balls, **dict(row.parameters))


@dataclass(frozen=True)
class MemberRow:
    """One member's result at one row."""

    nature: str
    lambda1: float
    ci95: float
    major: dict[str, str]
    lines: dict[str, list[str]]
    diverged_at: float
    halved: str = ""
    """The class of the same run with the RK4 step halved ('' where not checked:
    ``abc.recheck_halved`` checks the best sets' matched rows)."""

    def as_dict(self) -> dict:
        return asdict(self)


def peak_names(peaks: Sequence[Peak]) -> list[str]:
    """Every name of the peaks, largest first: each label and its ambiguous ``also``
    names (a line at a frequency two names share counts as either)."""
    names: list[str] = []
    for peak in peaks:
        for name in (peak.name, *peak.also):
            if name not in names:
                names.append(name)
    return names


def member_record(system: System, samples: np.ndarray, h: float, every: int,
                  start_step: int) -> xr.Dataset:
    """One member's kept samples (K × n, every ``every`` steps of ``h`` s after step
    ``start_step``) as a run Dataset with ``system``'s provenance."""
    times = (start_step + every * np.arange(1, len(samples) + 1)) * h
    attrs = completed_attrs(system, method="rk4", dt=h, save_every=every,
                            duration=float(times[-1]), transient=float(times[0]))
    return to_dataset(times, samples.T, attrs, system.model)


def classify_member(run: xr.Dataset, samples: np.ndarray, lam: float,
                    ci: float) -> tuple[str, dict[str, float]]:
    """(class, peak-to-peak range by state) of a member's record (``member_record``): its
    shaft Poincaré points classified with λ1 and its 95 % interval (``classify_section``),
    as calibrate and the uncertainty study classify every member."""
    ptp = {v: float(np.ptp(samples[:, i])) for i, v in enumerate(state_names(run))}
    verdict = classify_section(poincare_section(run, "shaft"), ptp, lambda: (lam, ci))
    return verdict.nature, ptp


def _member_row(system: System, samples: np.ndarray, lam: float, ci: float, h: float,
                every: int, start_step: int, diverged_at: int, settings: RunSettings,
                coordinates: Sequence[str]) -> MemberRow:
    """Classify one member's record and name its lines (``diverged`` when it blew up:
    ``diverged_at`` >= 0, the step of its first bad state)."""
    if diverged_at >= 0 or not math.isfinite(lam) or not np.all(np.isfinite(samples)):
        step = diverged_at if diverged_at >= 0 else start_step + every * len(samples)
        return MemberRow("diverged", math.nan, math.nan, {}, {}, float(step * h))
    run = member_record(system, samples, h, every, start_step)
    nature, _ = classify_member(run, samples, lam, ci)
    major, lines = {}, {}
    for var in coordinates:
        names = peak_names(find_peaks(run, var, settings.max_peaks))
        major[var] = names[0] if names else "-"
        lines[var] = names
    return MemberRow(nature, float(lam), float(ci), major, lines, math.nan)


def evaluate_row(model: Model | str, row: TargetRow, names: Sequence[str],
                 thetas: np.ndarray, settings: RunSettings, coordinates: Sequence[str],
                 device: str | Placement = CPU,
                 progress: Callable[[int, int], None] | None = None) -> list[MemberRow]:
    """Every parameter set ``thetas`` (M × P, SI units, in the order of ``names``) at one
    target ``row``: one ensemble call, each member classified and its lines named, on
    ``device`` (``run_engine``). ``progress(done, M)``: the sets whose run is done."""
    model = load_model(model) if not isinstance(model, Model) else model
    base = row_system(model, row)
    members = [base.replace(**dict(zip(names, map(float, theta), strict=True)))
               for theta in thetas]
    steps = [settings.steps(m) for m in members]
    h, every = steps[0]
    if any(abs(s[0] - h) > 1e-15 * h or s[1] != every for s in steps):
        # a calibrated speed changes h per member: one call per distinct step
        out: list[MemberRow] = [None] * len(members)  # type: ignore[list-item]
        done = 0
        for key in dict.fromkeys(steps):
            idx = [i for i, s in enumerate(steps) if s == key]
            part = None if progress is None else \
                (lambda k, _, before=done: progress(before + k, len(members)))
            for i, res in zip(idx, evaluate_row(model, row, names, thetas[idx], settings,
                                                coordinates, device, part), strict=True):
                out[i] = res
            done += len(idx)
        return out
    per = settings.samples_per_revolution
    result = run_engine(base, np.array([m.state for m in members]),
                        np.array([m.p for m in members]), h, every,
                        settings.transient_revolutions * per, settings.revolutions * per,
                        per, device, progress)
    start = settings.transient_revolutions * per * every
    return [_member_row(m, result.samples[i], float(result.lambda1[i]),
                        float(result.ci95[i]), h, every, start, int(result.diverged_at[i]),
                        settings, coordinates)
            for i, m in enumerate(members)]


def classify_seconds(model: Model, row: TargetRow, values: dict[str, float],
                     settings: RunSettings, coordinates: Sequence[str]) -> float:
    """Seconds the host takes to classify one member's record at ``row`` and name its lines
    (the parameter set ``values``, SI units): the best of two classifications of one record
    run alone (no transient; one member on the CPU build). The up-front estimate's second
    part: the member kernels' RK4 steps are timed by ``analysis.integrate.cost``."""
    system = row_system(model, row).replace(**values)
    h, every = settings.steps(system)
    per = settings.samples_per_revolution
    result = run_engine(system, system.state[None, :], system.p[None, :], h, every, 0,
                        settings.revolutions * per, per)
    best = math.inf
    for _ in range(2):  # the first also imports and warms what classifying needs
        start = time.perf_counter()
        _member_row(system, result.samples[0], float(result.lambda1[0]),
                    float(result.ci95[0]), h, every, 0, int(result.diverged_at[0]), settings,
                    coordinates)
        best = min(best, time.perf_counter() - start)
    return best


def check_steps(model: Model, target: Target, corners: Sequence[dict[str, float]],
                settings: RunSettings) -> None:
    """Before any work: every row at every given corner of the priors has an RK4 step that
    ``RunPlan.step`` accepts (resolving the forcing, RK4-stable), else ``InputError``
    naming the corner."""
    for row in target.rows:
        base = row_system(model, row)
        h, _ = settings.steps(base)
        try:  # at the target's own values first: then a refusal is not the prior's
            RunPlan.step(base, h, warn=lambda message: None)
        except InputError as exc:
            if settings.dt is not None:
                raise InputError(f"dt: at {row.name()}: {exc}", field="dt") from None
            raise InputError(f"model '{model.name}': at {row.name()}: {exc}") from None
        for corner in corners:
            check_corner_step(base, corner, settings, "prior", row.name())


def check_corner_step(base: System, corner: dict[str, float], settings: RunSettings,
                      field: str, where: str) -> None:
    """``InputError`` naming ``field`` (a parameter: ``prior``, ``dist``; the error's
    ``field``), the corner and ``where`` unless ``base`` with the ``corner``'s values has
    an RK4 step (``settings.steps``) that ``RunPlan.step`` accepts: a calibration's priors
    and an uncertainty study's distributions are judged at their corners before any
    work."""
    system = base.replace(**corner)
    h, _ = settings.steps(system)
    try:
        RunPlan.step(system, h, warn=lambda message: None)
    except InputError as exc:
        shown = ", ".join(f"{k} = {v:g}" for k, v in corner.items())
        raise InputError(f"{field}: at {shown} ({where}): {exc}", field=field) from None


def member_steps(target: Target, settings: RunSettings, model: Model) -> int:
    """RK4 steps one parameter set takes over every row (shadows or tangents counted as
    one more member over the record)."""
    total = 0
    for row in target.rows:
        system = row_system(model, row)
        _, every = settings.steps(system)
        per = settings.samples_per_revolution * every
        total += per * (settings.transient_revolutions + 2 * settings.revolutions)
    return total

