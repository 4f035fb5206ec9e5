"""Approximate Bayesian computation against a target table: a Sobol first round, then
SMC-ABC rounds of shrinking tolerance (Beaumont, Cornuet, Marin & Robert 2009, "Adaptive
approximate Bayesian computation", Biometrika 96, 983).

**Discrepancy.** A member (one parameter set) is run at every target row; a row's class
is missed or not (``targets.class_matches``), and so are its lines (every asked major
line and present line found). The discrepancy is lexicographic, classes first, lines
second: d = (class misses) + (line misses) / (rows + 1), so one more class matched
always wins over any number of lines. A row whose class would match but is doubtful (λ1's
interval reaching zero: ``doubtful``) is not matched and counts as half a miss.
``matched`` counts the rows whose class firmly matches; ``lines_matched`` the rows whose
lines match. A diverged member is the class ``diverged`` at that row (a miss unless the
row asks for it): never dropped, since dropping it would bias the posterior towards the
region that stays bounded.

**Rounds.** Round 0 is N points of a scrambled Sobol sequence (``scipy.stats.qmc``) in the
unit cube of the priors (log priors uniform in log). Its members have the prior's
distribution, so the share of them matching k rows is the share of the prior that does
(``share_of_prior``). After each round the tolerance ε is the ``quantile`` of the round's
discrepancies, and the population is the members with d <= ε. Round r > 0 draws N
particles from the population (by weight), moves each by a Gaussian kernel (diagonal,
twice the population's weighted variance per unit coordinate; a draw outside the cube is
drawn again), runs them all (one ensemble call per row and block of members), and weighs
the accepted ones by prior / proposal density, the proposal's truncation to the cube
included (exact for a diagonal kernel). The last population, with its weights, is the
posterior.

**Why not pyabc or sbi.** pyabc schedules one simulation per particle through its own
samplers (multicore, Redis, Dask) and stores its history in a database; a round here is
one ensemble call per target row (thousands of members in one compiled kernel, or on the
GPU) and must resume from the sweep store (``analysis.sweeps.store``) after an
interruption, which pyabc's per-particle sampler cannot be made to do without rewriting
its sampler. sbi trains neural density estimators (PyTorch) for continuous summaries; the
discrepancy here is a count of missed rows, and a calibration must run without PyTorch.
The sampler is ~100 lines, seeded and deterministic: a resumed round draws the same
particles.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import ndtr
from scipy.stats import qmc

from analysis.errors import InputError, check_count
from analysis.inference.priors import Prior, box, check_priors
from analysis.inference.simulate import (
    MemberRow,
    RunSettings,
    check_steps,
    classify_seconds,
    evaluate_row,
    member_steps,
    row_system,
)
from analysis.inference.targets import Target, TargetRow, class_matches, load_target
from analysis.integrate.cost import (
    FILE_SECONDS,
    KERNELS,
    CostEstimate,
    busiest_share,
    duration_text,
    estimate_cost,
    process_seconds,
)
from analysis.integrate.kernels.placement import Placement
from analysis.model import Model, load_model

MAX_SAMPLES = 200_000
"""Parameter sets per round at most."""
MAX_ROUNDS = 30
"""Rounds at most."""
MAX_CORE_HOURS = 100.0
"""A calibration estimated to take more CPU time than this is refused before any work."""
CPU_RATE = 1.0e6
"""Member RK4 steps (a tangent carried over the record counted as one more member) per
second per core of the member kernels' CPU build with the host's classification and
spectra, measured on the paper's model (docs/calibration.md): the basis of the refusal
above ``MAX_CORE_HOURS`` (the estimate printed before the work is ``calibrate_cost``'s,
from a timed probe)."""
MIN_SD = 1e-3
"""Least kernel standard deviation per unit coordinate (a population of one point)."""
DOUBTFUL_CREDIT = 0.5
"""A doubtful row counts as half a class miss in the discrepancy (the sampler still moves
towards it, the posterior between firm matches and misses), though never as matched."""
MIN_ESS = 100
"""A posterior worth fewer equally weighted sets than this is too small to conclude."""
MIN_BEST = 10
"""Fewer sets than this at the best count of rows matched: too few to conclude."""
NARROWED = 0.8
"""A calibration none of whose 90 % intervals is narrower than this share of the prior's
has not narrowed it: too small to conclude."""


@dataclass(frozen=True)
class Options:
    """A calibration's sampler options, gathered."""

    samples: int = 200
    """Parameter sets per round (N)."""
    rounds: int = 3
    """Rounds, the Sobol round included."""
    seed: int = 0
    quantile: float = 0.5
    """Each round's tolerance: this quantile of its discrepancies."""
    block: int = 64
    """Members per executor task (each task: one ensemble call per row)."""
    device: str = "cpu"
    settings: RunSettings = field(default_factory=RunSettings)

    def check(self) -> None:
        for name, value, low, high in (("samples", self.samples, 2, MAX_SAMPLES),
                                       ("rounds", self.rounds, 1, MAX_ROUNDS),
                                       ("block", self.block, 1, MAX_SAMPLES),
                                       ("seed", self.seed, 0, 2**32 - 1)):
            check_count(name, value, low, high)
        if not 0 < self.quantile < 1:
            raise InputError(f"quantile: must be in (0, 1), got {self.quantile!r}")
        if self.device not in ("cpu", "gpu", "auto"):
            raise InputError(f"device: must be cpu, gpu or auto, got {self.device!r}",
                             field="device")
        self.settings.check()


# --- scoring ------------------------------------------------------------------------------

LAMBDA_CLASSES = ("chaotic", "quasi-periodic")
"""The classes λ1 can decide (``classify_section``): where its interval reaches zero the
class is doubtful."""


def doubtful(result: MemberRow) -> bool:
    """Whether a member's class at a row is doubtful: chaotic or quasi-periodic with λ1's
    95 % interval reaching zero (λ1 − ci95 <= 0 <= λ1 + ci95), where a longer record or a
    halved step may give the other class (issue 41: 8–24 ± 13–39 1/s at N_b = 7 was called
    quasi-periodic; an independent twin-orbit classifier called 6 of 40 such sets chaotic).
    Also doubtful: a class that changes with the RK4 step halved (``halved``, set by
    ``recheck_halved`` on the best sets)."""
    if result.halved and result.halved != result.nature:
        return True
    lam, ci = result.lambda1, result.ci95
    return (result.nature in LAMBDA_CLASSES and math.isfinite(lam) and math.isfinite(ci)
            and lam - ci <= 0 <= lam + ci)


def row_marks(row: TargetRow, result: MemberRow) -> tuple[bool, bool]:
    """(class matches, lines match) of one member at one row (lines: every asked major
    line is the largest, every present line is among the peaks; True when none asked). A
    class that would match but is ``doubtful`` does not match (``doubtful_match``)."""
    klass = class_matches(row.classes, result.nature) and not (
        row.classes and doubtful(result))
    lines = all(result.major.get(c) == name for c, name in row.major) and all(
        name in result.lines.get(c, ()) for c, names in row.present for name in names)
    return klass, lines


def doubtful_match(row: TargetRow, result: MemberRow) -> bool:
    """The row asks for a class, the member's class is it, and that class is doubtful:
    reported as doubtful, not counted as matched."""
    return bool(row.classes) and class_matches(row.classes, result.nature) and \
        doubtful(result)


def discrepancy(class_missed: int, lines_missed: int, rows: int) -> float:
    """Classes first, lines second: class misses + line misses / (rows + 1)."""
    return class_missed + lines_missed / (rows + 1)


# --- the sampler --------------------------------------------------------------------------

def sobol_round(p: int, n: int, seed: int) -> np.ndarray:
    """N scrambled Sobol points in the unit cube (P dims), seeded."""
    sampler = qmc.Sobol(d=p, scramble=True, seed=seed)
    m = math.ceil(math.log2(n))
    return sampler.random_base2(m)[:n]


def kernel_sd(population: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The kernel's standard deviation per unit coordinate: sqrt(2 × weighted variance)."""
    mean = weights @ population
    var = weights @ (population - mean) ** 2
    return np.maximum(np.sqrt(2.0 * var), MIN_SD)


def propose(population: np.ndarray, weights: np.ndarray, n: int,
            rng: np.random.Generator) -> np.ndarray:
    """N particles: drawn from the population by weight, moved by the Gaussian kernel,
    each redrawn until inside the unit cube."""
    sd = kernel_sd(population, weights)
    out = np.empty((n, population.shape[1]))
    filled = 0
    while filled < n:
        need = n - filled
        pick = rng.choice(len(population), size=2 * need + 8, p=weights)
        moved = population[pick] + rng.normal(size=(len(pick), population.shape[1])) * sd
        inside = moved[np.all((moved >= 0) & (moved <= 1), axis=1)][:need]
        out[filled:filled + len(inside)] = inside
        filled += len(inside)
    return out


def smc_weights(particles: np.ndarray, population: np.ndarray,
                weights: np.ndarray) -> np.ndarray:
    """Importance weights of ``particles`` (uniform prior on the cube): 1 / the density of
    the truncated kernel mixture the particles were drawn from, normalised."""
    sd = kernel_sd(population, weights)
    # truncation mass of each population point's kernel (diagonal: a product of CDFs)
    mass = np.prod(ndtr((1 - population) / sd) - ndtr(-population / sd), axis=1)
    z = (particles[:, None, :] - population[None, :, :]) / sd
    dens = np.exp(-0.5 * np.sum(z * z, axis=2)) / mass[None, :]
    q = dens @ weights
    w = 1.0 / np.maximum(q, 1e-300)
    return w / w.sum()


def tolerance(d: np.ndarray, quantile: float) -> float:
    """The round's tolerance: the ``quantile`` of its discrepancies (at least one member
    lies at or below it)."""
    return float(np.quantile(d, quantile, method="lower"))


# --- a calibration -------------------------------------------------------------------------

@dataclass
class Round:
    """One round's members: unit coordinates, parameter values, per-row results."""

    index: int
    unit: np.ndarray
    values: np.ndarray
    rows: list[list[MemberRow]]
    """rows[member][row]."""
    discrepancy: np.ndarray
    matched: np.ndarray
    lines_matched: np.ndarray
    epsilon: float = math.inf
    weights: np.ndarray | None = None
    """Weights of the members in the population after this round (0 outside it)."""
    doubtful: np.ndarray | None = None
    """Per member: rows whose class would match but is doubtful (``doubtful_match``)."""


@dataclass
class Calibration:
    """A finished calibration: its target, priors, options and rounds."""

    model: Model
    target: Target
    priors: tuple[Prior, ...]
    options: Options
    rounds: list[Round]
    wall_s: float = 0.0
    device: str = "cpu"
    halved: tuple[int, int] | None = None
    """(rows rechecked, rows whose class changed) with the step halved
    (``recheck_halved``); None: not rechecked."""

    @property
    def posterior(self) -> Round:
        return self.rounds[-1]

    def share_of_prior(self) -> dict[int, float]:
        """The share of the prior (the Sobol round) whose members match k rows, per k."""
        first = self.rounds[0].matched
        return {k: float(np.mean(first == k)) for k in range(len(self.target.rows), -1, -1)}

    def doubtful_share(self) -> dict[int, float]:
        """Per k: the share of the prior (the Sobol round) that matches k rows only when its
        doubtful rows are counted (``matched`` < k <= ``matched`` + ``doubtful``)."""
        first = self.rounds[0]
        extra = first.doubtful if first.doubtful is not None else np.zeros_like(first.matched)
        return {k: float(np.mean((first.matched < k) & (first.matched + extra >= k)))
                for k in range(len(self.target.rows), -1, -1)}

    def best_matched(self) -> int:
        return int(max(r.matched.max() for r in self.rounds))

    def effective_sample_size(self) -> float:
        """Kish's effective sample size of the posterior weights, 1 / Σ w² (w normalised):
        how many equally weighted sets the posterior is worth."""
        w = self.posterior.weights
        w = w[w > 0] / w[w > 0].sum()
        return float(1.0 / np.sum(w * w))

    def narrowing(self, level: float = 0.9) -> dict[str, float]:
        """Per parameter: the width of its central ``level`` posterior interval over that of
        the prior, in the prior's own coordinate (log for a log prior): 1 is no narrowing,
        0.1 a tenfold one."""
        intervals = self.credible_interval(level)
        out = {}
        for prior in self.priors:
            lo, hi = intervals[prior.name]
            if prior.log:
                width = math.log(hi / lo) / math.log(prior.hi / prior.lo)
            else:
                width = (hi - lo) / (prior.hi - prior.lo)
            out[prior.name] = float(width / level)
        return out

    def verdict(self) -> str:
        """'' when the calibration can conclude, else why it is too small to: fewer than
        ``MIN_ESS`` effective sets, fewer than ``MIN_BEST`` sets at the best count of rows
        matched, no parameter's interval narrowed below ``NARROWED`` of the prior's, or a
        last tolerance more than a row above the best set's discrepancy (the posterior is
        then that of worse sets)."""
        why = []
        ess = self.effective_sample_size()
        if ess < MIN_ESS:
            why.append(f"effective sample size {ess:.0f} < {MIN_ESS}")
        best = self.best_matched()
        at_best = sum(int(np.sum(r.matched == best)) for r in self.rounds)
        if at_best < MIN_BEST:
            why.append(f"{at_best} set(s) match the best {best} rows (< {MIN_BEST})")
        narrow = self.narrowing()
        if narrow and min(narrow.values()) > NARROWED:
            why.append(f"no 90 % interval is narrower than {NARROWED:.0%} of the prior's")
        least = min(float(r.discrepancy.min()) for r in self.rounds)
        if self.posterior.epsilon > least + 1:
            why.append(f"the posterior's tolerance ({self.posterior.epsilon:.3g} rows missed) "
                       f"is more than a row above the best set's ({least:.3g}): it describes "
                       "worse sets than the best; more --rounds")
        return "; ".join(why)

    def credible_interval(self, level: float = 0.9) -> dict[str, tuple[float, float]]:
        """Per parameter: the central ``level`` interval of the weighted posterior marginal
        (SI units)."""
        post = self.posterior
        w = post.weights
        keep = w > 0
        out = {}
        for j, prior in enumerate(self.priors):
            v, ww = post.values[keep, j], w[keep]
            order = np.argsort(v)
            cdf = np.cumsum(ww[order]) / ww.sum()
            lo = v[order][np.searchsorted(cdf, (1 - level) / 2)]
            hi = v[order][min(np.searchsorted(cdf, 1 - (1 - level) / 2), len(v) - 1)]
            out[prior.name] = (float(lo), float(hi))
        return out


def estimate(model: Model, target: Target, options: Options) -> dict[str, float]:
    """The cost of a calibration before any work: member RK4 steps, core-seconds at
    ``CPU_RATE``, and the simulations (sets × rows × rounds)."""
    steps = member_steps(target, options.settings, model) * options.samples * options.rounds
    sims = options.samples * options.rounds * len(target.rows)
    return {"simulations": float(sims), "member_steps": float(steps),
            "core_seconds": steps / CPU_RATE}


def _evaluate_task(task: tuple, progress: Callable[[int, int], None] | None = None
                   ) -> list[list[dict]]:
    """An executor task: a block of parameter sets at every row (one ensemble call per
    row); per row, per member, the ``MemberRow`` as a dict. ``progress(done, total)``
    counts the block's sets × rows run so far."""
    model, rows, names, thetas, settings, coordinates, device = task
    m, out = len(thetas), []
    for r, row in enumerate(rows):
        report = None if progress is None else \
            (lambda k, _, before=r * m: progress(before + k, len(rows) * m))
        out.append([res.as_dict() for res in evaluate_row(model, row, names, thetas,
                                                          settings, coordinates, device,
                                                          report)])
    return out


def _pack(results: list[list[dict]], coordinates: Sequence[str]) -> dict[str, np.ndarray]:
    """A block's results (rows × members) as arrays for the store: (members, rows)."""
    def grid(fn):
        return np.array([[fn(results[r][i]) for r in range(len(results))]
                         for i in range(len(results[0]))])
    out = {"nature": grid(lambda d: d["nature"]), "lambda1": grid(lambda d: d["lambda1"]),
           "ci95": grid(lambda d: d["ci95"]), "diverged_at": grid(lambda d: d["diverged_at"])}
    for c in coordinates:
        out[f"major_{c}"] = grid(lambda d, c=c: d["major"].get(c, ""))
        out[f"lines_{c}"] = grid(lambda d, c=c: ",".join(d["lines"].get(c, [])))
    return out


def _unpack(data: dict[str, np.ndarray], coordinates: Sequence[str]) -> list[list[MemberRow]]:
    """The store's arrays back as MemberRow per member and row."""
    members, rows = data["nature"].shape
    return [[MemberRow(str(data["nature"][i, r]), float(data["lambda1"][i, r]),
                       float(data["ci95"][i, r]),
                       {c: str(data[f"major_{c}"][i, r]) for c in coordinates
                        if str(data[f"major_{c}"][i, r])},
                       {c: [s for s in str(data[f"lines_{c}"][i, r]).split(",") if s]
                        for c in coordinates if str(data["nature"][i, r]) != "diverged"},
                       float(data["diverged_at"][i, r]))
             for r in range(rows)] for i in range(members)]


@dataclass(frozen=True)
class Problem:
    """A checked calibration, before any work: the model, target, priors and options."""

    model: Model
    target: Target
    priors: tuple[Prior, ...]
    options: Options
    placement: Placement | None = None
    """Where every ensemble call runs (``check_row_kernels``: judged once); None: each call
    places ``options.device`` itself."""

    @property
    def device(self) -> str | Placement:
        """What the ensemble calls take: the placement, else the device's name."""
        return self.placement if self.placement is not None else self.options.device

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.priors]

    def estimate(self) -> dict[str, float]:
        return estimate(self.model, self.target, self.options)

    def cost(self, workers: int | None = None, host_workers: int = 1) -> CalibrationCost:
        """The cost said before any work, from timed probes (``problem_cost``)."""
        return problem_cost(self, workers, host_workers)

    def definition(self) -> dict[str, Any]:
        """What a stored (resumable) calibration must agree on."""
        from dataclasses import asdict

        return {"analysis": "calibrate", "model": self.model.name,
                "spec_sha256": self.model.spec_sha256, "target": self.target.as_dict(),
                "priors": [p.text() for p in self.priors],
                "options": {**asdict(self.options), "settings": asdict(self.options.settings)}}


def prepare(
    model: str | Model,
    target: str | Target,
    priors: Sequence[Prior | str],
    *,
    samples: int = 200,
    rounds: int = 3,
    seed: int = 0,
    quantile: float = 0.5,
    settings: RunSettings | None = None,
    device: str = "cpu",
    block: int | None = None,
) -> Problem:
    """Check every input of a calibration before any work (``InputError``, one line naming
    the field): the model, the target (``Target``, a built-in name, a TOML path), the
    priors (``Prior`` or ``NAME:LO:HI[:log]``), the options, the cost (refused above
    ``MAX_CORE_HOURS``) and the RK4 step at every corner of the priors. ``block``: sets per
    executor task (None: 64 on the CPU, a whole round on the GPU: one kernel call per row)."""
    from analysis.inference.priors import parse_prior

    mdl = load_model(model) if not isinstance(model, Model) else model
    pri = check_priors([p if isinstance(p, Prior) else parse_prior(p) for p in priors], mdl)
    if block is None:
        block = 64 if device == "cpu" else samples
    options = Options(samples, rounds, seed, quantile, block, device,
                      settings or RunSettings())
    options.check()
    tgt = target if isinstance(target, Target) else load_target(target, mdl)
    check_fixed(pri, tgt)
    cost = estimate(mdl, tgt, options)
    if cost["core_seconds"] > MAX_CORE_HOURS * 3600:
        raise InputError(f"samples: {samples} sets × {rounds} rounds × {len(tgt.rows)} "
                         f"rows is estimated at {cost['core_seconds'] / 3600:.3g} "
                         f"core-hours, above {MAX_CORE_HOURS:g}; give fewer samples or "
                         "rounds", field="samples")
    check_steps(mdl, tgt, prior_corners(pri), options.settings)
    placement = check_row_kernels(mdl, tgt, options)
    return Problem(mdl, tgt, pri, options, placement)


def prior_corners(priors: Sequence[Prior]) -> list[dict[str, float]]:
    """Every corner of the priors' box (SI units), as parameter values."""
    return [dict(zip([p.name for p in priors], c, strict=True))
            for c in box(priors, np.array(np.meshgrid(*[[0.0, 1.0]] * len(priors)))
                         .reshape(len(priors), -1).T)]


def accepted_dt(problem: Problem, largest: float | None) -> float | None:
    """The largest step of the form 1, 2, 5 × 10^k, at most ``largest`` s and coarser than
    the calibration's own, that ``check_steps`` accepts at every row and corner of the
    priors, as the user would type it (``%.3g``: 0.0002 makes a per-revolution step of
    0.00015000000000000001 at 5000 rpm, checked as such); None when there is none."""
    from analysis.integrate.cost import nice_down

    if largest is None or not largest > 0:
        return None
    settings = problem.options.settings
    now = float(settings.dt or problem.model.simulation_defaults["dt"])
    corners = prior_corners(problem.priors)
    value = nice_down(largest)
    while value > 1.5 * now:
        typed = float(f"{value:.3g}")
        try:
            check_steps(problem.model, problem.target, corners,
                        dataclasses.replace(settings, dt=typed))
            return typed
        except InputError:
            value = nice_down(value * (1 - 1e-9))
    return None


def check_fixed(priors: Sequence[Prior], target: Target) -> None:
    """A prior on a parameter that the target fixes (its conditions or a row's values, e.g.
    ``speed_rpm``) is an ``InputError``: the row's value would silently override it."""
    for prior in priors:
        fixing = [row.name() for row in target.rows if prior.name in dict(row.parameters)]
        if fixing:
            raise InputError(f"prior {prior.name}: the target fixes {prior.name} "
                             f"({', '.join(fixing[:3])}{', …' if len(fixing) > 3 else ''}); "
                             "calibrate a parameter the target leaves free", field="prior")


def check_row_kernels(model: Model, target: Target, options: Options) -> Placement:
    """Before the estimate: the calibration's device judged once (``placement.place``: the
    name, its availability, ``auto``'s choice for an ensemble call of ``block`` sets of the
    longest row's RK4 steps) and the member kernels (tangent variant) of every row's balls
    built, or loaded and self-tested, on it, so that a kernel or a cache that cannot be
    built or written is one ``InputError`` before any work. Every ensemble call of the
    calibration runs on the ``Placement`` returned (not judged again)."""
    from analysis.integrate.kernels.placement import place

    settings = options.settings
    systems = [row_system(model, row) for row in target.rows]
    steps = max(settings.samples_per_revolution * settings.steps(system)[1]
                * (settings.transient_revolutions + settings.revolutions) for system in systems)
    return place(options.device, min(options.block, options.samples), systems, "tangent",
                 steps)


@dataclass(frozen=True)
class CalibrationCost:
    """A calibration's cost said before any work: the member kernels' RK4 steps
    (``kernels``, ``analysis.integrate.cost``) and the host's classification and spectra of
    each run (a parameter set at a row), ``host_seconds`` each (probed) on ``host_workers``
    processes."""

    kernels: CostEstimate
    runs: int
    host_seconds: float
    host_workers: int = 1
    notes: tuple[str, ...] = ()
    """Lines said after the advice (the GPU's: the probe times the CPU's RK4)."""

    @property
    def host_total(self) -> float:
        """Seconds of classification and spectra, wall time."""
        return self.runs * self.host_seconds / max(1, min(self.host_workers, self.runs))

    @property
    def seconds(self) -> float:
        """Expected wall time, s: the kernels' and the host's."""
        return self.kernels.seconds + self.host_total

    @property
    def whole_seconds(self) -> float:
        """The whole command, s: the start-up and probes already spent (``kernels.spent``),
        the kernels, the host and the result file."""
        return self.kernels.spent + self.seconds + FILE_SECONDS

    def lines(self) -> list[str]:
        """The kernels' estimate line, the host's line with the whole command's total, the
        advice, then the ``notes``."""
        head = self.kernels.lines()[0]
        host = (f"estimate: {self.runs:,} runs x {self.host_seconds:.3g} s of classification "
                f"and spectra on the host (probed) on {min(self.host_workers, self.runs)} "
                f"worker(s) = {duration_text(self.host_total)}; in all "
                f"{duration_text(self.whole_seconds)} with the start-up and probes "
                f"({self.kernels.spent:.2g} s so far) and the file")
        return [head, host, *self.kernels.load_lines(), *self.kernels.advice(), *self.notes]


def kernel_steps(target: Target, settings: RunSettings, model: Model) -> tuple[int, int]:
    """(RK4 steps, those of them with λ1's tangent) one parameter set takes over every row
    of ``target``: each row's transient (state only), then its record (with the tangent,
    ``simulate.run_engine``)."""
    steps = tangent = 0
    for row in target.rows:
        _, every = settings.steps(row_system(model, row))
        per = settings.samples_per_revolution * every
        steps += per * (settings.transient_revolutions + settings.revolutions)
        tangent += per * settings.revolutions
    return steps, tangent


def problem_cost(problem: Problem, workers: int | None = None,
                 host_workers: int = 1) -> CalibrationCost:
    """The cost of a prepared calibration, from two timed probes at the first target row
    and the centre of the priors. The member kernels (``analysis.integrate.cost``): its
    parameter sets over every round (samples × rounds) are the members, each taking
    ``kernel_steps`` RK4 steps (every row's transient and record, the record's steps with
    the tangent counted by its measured cost), with that row's step, timed on the member
    kernels that run them (``estimate_cost`` on ``KERNELS``), on ``workers`` cores (None:
    every core, ``kernels.cpu.cores``; a pool of ``host_workers`` processes runs blocks of
    ``block`` sets, each on cores / ``host_workers`` threads, and a round's blocks that do
    not deal evenly to them leave a worker idle: ``cost.busiest_share``). The host: each
    run (a set at a row) classified and its lines named (``simulate.classify_seconds``) on
    ``host_workers`` processes (1 for the serial executor, the workers of a pool). On a
    GPU the kernels run faster than this."""
    from analysis.integrate.kernels.cpu import cores

    opts = problem.options
    centre = box(problem.priors, np.full((1, len(problem.priors)), 0.5))[0]
    values = dict(zip(problem.names, map(float, centre), strict=True))
    row = problem.target.rows[0]
    system = row_system(problem.model, row).replace(**values)
    h, _ = opts.settings.steps(system)
    steps, tangent = kernel_steps(problem.target, opts.settings, problem.model)
    balance = 1.0
    if workers is None and host_workers > 1:
        threads = max(1, cores() // host_workers)
        workers = threads * min(host_workers, -(-opts.samples // opts.block))
        balance = busiest_share(opts.samples, opts.block, host_workers)
    kernels = estimate_cost(system, opts.samples * opts.rounds, steps, dt=h,
                            workers=workers or cores(), what="parameter sets", path=KERNELS,
                            tangent_steps=tangent)
    kernels = dataclasses.replace(kernels, balance=balance)
    kernels = dataclasses.replace(kernels, coarsest_dt=accepted_dt(problem,
                                                                   kernels.coarsest_dt))
    host = classify_seconds(problem.model, row, values, opts.settings,
                            problem.target.coordinates or ("x",))
    kernels = dataclasses.replace(kernels, spent=process_seconds())  # after both probes
    return CalibrationCost(kernels, opts.samples * opts.rounds * len(problem.target.rows),
                           host, host_workers)


def calibrate_cost(model: str | Model, target: str | Target,
                   priors: Sequence[Prior | str], *, workers: int | None = None,
                   host_workers: int = 1, **options: Any) -> CalibrationCost:
    """What ``calibrate`` with the same arguments would cost, said before any work (every
    input checked as ``prepare`` checks it; ``problem_cost``): ``.lines()`` are the
    estimate and its advice, ``.seconds`` the expected wall time.

    >>> calibrate_cost("vakharia2015", "paper-table2", ["damping:10:3162:log"],
    ...                samples=8, rounds=1).kernels.members  # doctest: +SKIP
    8
    """
    return problem_cost(prepare(model, target, priors, **options), workers, host_workers)


def calibrate(model: str | Model, target: str | Target, priors: Sequence[Prior | str], *,
              executor=None, store=None, progress: Callable[[int, int], None] | None = None,
              log: Callable[[str], None] | None = None, **options: Any) -> Calibration:
    """Calibrate ``priors`` (``Prior`` or ``NAME:LO:HI[:log]``, SI units) of ``model``
    against ``target`` (a ``Target``, a built-in name such as ``paper-table2``, or a TOML
    path): ``rounds`` rounds of ``samples`` parameter sets (a Sobol round, then SMC-ABC),
    each set run at every target row for ``settings`` (``RunSettings``). ``options``: those
    of ``prepare`` (samples, rounds, seed, quantile, settings, device, block), all checked
    before any work. See ``run``.

    >>> cal = calibrate("vakharia2015", "paper-table2",
    ...                 ["damping:10:3162:log"], samples=8, rounds=1)  # doctest: +SKIP
    """
    return run(prepare(model, target, priors, **options), executor=executor, store=store,
               progress=progress, log=log)


def run(problem: Problem, *, executor=None, store=None,
        progress: Callable[[int, int], None] | None = None,
        log: Callable[[str], None] | None = None) -> Calibration:
    """Run a prepared calibration. ``executor``: an ``analysis.sweeps.executors`` executor
    running blocks of ``block`` members (None: in this process); ``store``: a
    ``PointStore`` whose stored blocks are reused (resuming) and to which each finished
    block is saved. ``progress(done, total)`` counts members × rows, moving as the member
    kernels finish sets within a block (on the CPU every ~0.5 s of work; from worker
    processes too, ``worker_counts.WorkerCounts``); ``log(line)`` reports each round."""
    import time

    start = time.perf_counter()
    mdl, tgt, pri, options = problem.model, problem.target, problem.priors, problem.options
    samples, rounds = options.samples, options.rounds
    names = problem.names
    coordinates = tgt.coordinates or ("x",)
    model_ref = model_reference(mdl)
    rng = np.random.default_rng(options.seed)
    done_count = [0]
    total = samples * rounds * len(tgt.rows)
    out: list[Round] = []
    population = weights = None
    for r in range(rounds):
        u = sobol_round(len(pri), samples, options.seed) if r == 0 else \
            propose(population, weights, samples, rng)
        values = box(pri, u)
        rows = _run_round(r, values, tgt, names, options, problem.device, coordinates,
                          model_ref, executor, store, progress, done_count, total)
        marks = [[row_marks(row, res) for row, res in zip(tgt.rows, member, strict=True)]
                 for member in rows]
        unsure = np.array([sum(doubtful_match(row, res) for row, res in
                               zip(tgt.rows, member, strict=True)) for member in rows])
        matched = np.array([sum(k for k, _ in m) for m in marks])
        lines = np.array([sum(ln for _, ln in m) for m in marks])
        d = np.array([discrepancy(len(tgt.rows) - k - DOUBTFUL_CREDIT * q,
                                  len(tgt.rows) - ln, len(tgt.rows))
                      for k, ln, q in zip(matched, lines, unsure, strict=True)])
        eps = tolerance(d, options.quantile)
        keep = d <= eps
        w = np.zeros(samples)
        w[keep] = 1.0 if r == 0 else smc_weights(u[keep], population, weights)
        w /= w.sum()
        out.append(Round(r, u, values, rows, d, matched, lines, eps, w, unsure))
        population, weights = u[keep], w[keep] / w[keep].sum()
        if log:
            log(f"round {r + 1}/{rounds}: tolerance {eps:.3g} (rows missed), "
                f"{int(keep.sum())} of {samples} sets kept, best {int(matched.max())} of "
                f"{len(tgt.rows)} rows; {int(np.sum(unsure > 0))} sets with a doubtful "
                "row (not counted)")
    return Calibration(mdl, tgt, pri, options, out, time.perf_counter() - start,
                       options.device)


RECHECK_SETS = 10
"""The best sets whose matched rows ``recheck_halved`` runs again with the step halved."""


def recheck_halved(cal: Calibration, sets: int = RECHECK_SETS, *,
                   device: str | Placement | None = None) -> tuple[int, int]:
    """Run the ``sets`` best distinct sets (fewest rows missed over every round) again at
    each row whose class they firmly match, with the RK4 step halved (the same record, in
    twice the steps), and keep that class as ``MemberRow.halved``: a row whose class changes
    becomes doubtful and leaves its member's ``matched`` (``doubtful`` gains it). The
    rounds' discrepancies and weights are left as they were. Returns (rows rechecked, rows
    whose class changed). ``device``: where they run (a ``Placement`` judged once by
    ``prepare``; None: ``cal.options.device``)."""
    tgt, names = cal.target, [p.name for p in cal.priors]
    everyone = sorted(((r, i) for r in cal.rounds for i in range(len(r.values))),
                      key=lambda ri: (ri[0].discrepancy[ri[1]], -ri[0].index))
    chosen, seen = [], set()
    for r, i in everyone:
        key = tuple(np.round(r.values[i], 12))
        if key not in seen and r.matched[i] > 0:
            seen.add(key)
            chosen.append((r, i))
        if len(chosen) == sets:
            break
    checked = changed = 0
    coordinates = tgt.coordinates or ("x",)
    for j, row in enumerate(tgt.rows):
        members = [(r, i) for r, i in chosen if row_marks(row, r.rows[i][j])[0]]
        if not members:
            continue
        settings = cal.options.settings
        h, _ = settings.steps(row_system(cal.model, row))
        halved = dataclasses.replace(settings, dt=h / 2)
        thetas = np.array([r.values[i] for r, i in members])
        again = evaluate_row(cal.model, row, names, thetas, halved, coordinates,
                             cal.options.device if device is None else device)
        for (r, i), res in zip(members, again, strict=True):
            r.rows[i][j] = dataclasses.replace(r.rows[i][j], halved=res.nature)
            checked += 1
            if res.nature != r.rows[i][j].nature:
                changed += 1
                r.matched[i] -= 1
                r.doubtful[i] += 1
    cal.halved = (checked, changed)
    return checked, changed


def model_reference(model: Model) -> str:
    """What a worker loads the model by: its name when that finds this very model (a
    shipped one, or one in a ``BEARINGDYN_MODELS`` folder), else its spec's path."""
    try:
        if load_model(model.name).spec_sha256 == model.spec_sha256:
            return model.name
    except InputError:
        pass
    return model.spec_file


def _run_round(r: int, values: np.ndarray, target: Target, names: list[str],
               options: Options, device: str | Placement, coordinates: Sequence[str],
               model_ref: str, executor, store, progress, done_count: list[int],
               total: int) -> list[list[MemberRow]]:
    """Run one round's sets in blocks (resuming stored blocks) on ``device`` (the
    problem's placement); rows[member][row]."""
    from analysis.sweeps.executors import SerialExecutor, run_with_progress
    from analysis.sweeps.worker_counts import WorkerCounts

    blocks = list(range(0, len(values), options.block))
    found: dict[int, list[list[MemberRow]]] = {}
    stored = store.done() if store is not None else set()
    for b in blocks:
        key = f"r{r}-b{b}"
        if key in stored:
            found[b] = _unpack(store.load(key), coordinates)
            done_count[0] += len(found[b]) * len(target.rows)
    tasks = [(b, (model_ref, target.rows, names, values[b:b + options.block],
                  options.settings, coordinates, device))
             for b in blocks if b not in found]

    def on_result(item, result):
        packed = _pack(result, coordinates)
        if store is not None:
            store.save(f"r{r}-b{item[0]}", packed)
        found[item[0]] = _unpack(packed, coordinates)
        done_count[0] += len(found[item[0]]) * len(target.rows)

    if tasks:
        slot = {b: i for i, (b, _) in enumerate(tasks)}
        with WorkerCounts(store.folder if store is not None else None, len(tasks),
                          total) as counts:
            def stored(item, result):
                with counts.lock:
                    on_result(item, result)
                    counts.finish(slot[item[0]])

            items = [(b, task, *(counts.where(slot[b]) if progress else ()))
                     for b, task in tasks]
            run_with_progress(executor or SerialExecutor(), _block_task, items,
                              lambda: counts.count(lambda: done_count[0]), total, progress,
                              stored)
    return [member for b in blocks for member in found[b]]


def _block_task(item: tuple) -> list[list[dict]]:
    """A picklable executor task: (block start, evaluation task[, counts file, slot]);
    with a counts file (``WorkerCounts``) the block's sets × rows run so far are written to
    its slot as the kernels go."""
    from analysis.sweeps.worker_counts import WorkerCounts

    _, task, *where = item
    return _evaluate_task(task, WorkerCounts.writer(*where) if where else None)
