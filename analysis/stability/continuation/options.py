"""The settings of a continuation run, gathered in one object that checks itself.

``ContinuationOptions`` (in the manner of BifurcationKit.jl's ``ContinuationPar``) holds the
scaled arclength steps ``ds``, ``ds_min``, ``ds_max``, the point budget ``max_points``, the
Newton tolerance ``tol`` and the ``StepGuards`` every branch step must pass. It refuses a bad
field on construction (``InputError``, before any orbit is computed). The keyword arguments of
``continue_orbits``, ``continue_from_orbit``, ``continue_from_branch`` and
``curves.continue_curve`` build one (``options_with``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from analysis.errors import InputError, check_count

MAX_BRANCH_POINTS = 100_000
"""Most points one branch or curve may have."""

TANGENTS = ("svd", "bordered")
"""How a step's tangent may be found (``ContinuationOptions.tangent``)."""

DEFAULT_DS = 0.01
"""First scaled arclength step of a new branch or curve (``ContinuationOptions.ds`` None)."""


def _is_positive(value: object) -> bool:
    """A finite real number > 0."""
    return isinstance(value, (int, float)) and math.isfinite(value) and value > 0


@dataclass(frozen=True)
class StepGuards:
    """Tests every continuation step must pass; a refused step is retried with half the
    arclength step ds, and the run stops (status ``refused …``) when even ``ds_min`` is
    refused. They keep the corrector on the branch it started from: a step that lands on
    another branch (a period-1 orbit next to a period-3 one, say) fails at least one.

    * ``max_contraction``: the largest Newton contraction ratio |Δw_{k+1}| / |Δw_k| of the
      corrector (quadratic convergence from a good predictor gives ≪ 0.1);
    * ``max_correction``: the largest distance of the corrected point from the predictor,
      in units of ds;
    * ``max_angle``: the largest angle (deg) between the tangents at the two ends of the
      step, and between the secant (the chord from one end to the other) and either tangent;
    * the parameter must move the way both tangents point unless their parameter components
      differ in sign, and when they do, a fold (LP) must be located between the ends (a
      corrected point where λ is extreme), else the step is refused.

    ``active = False`` turns every test off (the behaviour before the guards). Each
    threshold must be a finite number > 0 (``InputError`` otherwise).
    """

    max_contraction: float = 0.5
    max_correction: float = 0.5
    max_angle: float = 30.0
    active: bool = True

    def __post_init__(self) -> None:
        for name in ("max_contraction", "max_correction", "max_angle"):
            value = getattr(self, name)
            if not _is_positive(value):
                raise InputError(f"guards.{name}: must be a finite number > 0, got {value!r}")


@dataclass(frozen=True)
class ContinuationOptions:
    """How a branch (or a curve) is stepped; every field is checked on construction.

    * ``ds``: the first scaled arclength step, kept within [``ds_min``, ``ds_max``] (the
      unknowns are scaled: states by ``periodic.state_scale``, parameters by their range);
      None: ``DEFAULT_DS`` for a new branch, the stored step of the point a restart
      (``continue_from_branch``) starts from;
    * ``ds_min``, ``ds_max``: the smallest and largest step (0 < ds_min <= ds_max);
    * ``max_points``: most points on the branch, in [2, ``MAX_BRANCH_POINTS``];
    * ``tol``: Newton tolerance on the scaled step and residual, in (0, 1);
    * ``guards``: the ``StepGuards`` every branch step must pass (curves do not use them);
    * ``tangent``: how a step's tangent is found, ``"svd"`` (the null vector of the
      Jacobian) or ``"bordered"`` (one solve of [∂G/∂w; τ_prev] τ = e_last: the same
      vector, a tenth of the work at a few hundred unknowns); None: the problem's own
      (``BranchProblem.tangent_method``).

    Raises ``InputError`` naming the first bad field, e.g. ``ds_max: must be a finite number
    > 0, got 0.0``.
    """

    ds: float | None = None
    ds_min: float = 1e-6
    ds_max: float = 0.05
    max_points: int = 200
    tol: float = 1e-9
    guards: StepGuards = field(default_factory=StepGuards)
    tangent: str | None = None

    def __post_init__(self) -> None:
        for name in ("ds_min", "ds_max", "tol"):
            value = getattr(self, name)
            if not _is_positive(value):
                raise InputError(f"{name}: must be a finite number > 0, got {value!r}")
        if self.ds_min > self.ds_max:
            raise InputError(f"ds_min: must be <= ds_max = {self.ds_max:g}, "
                             f"got {self.ds_min:g}")
        if self.ds is not None and not _is_positive(self.ds):
            raise InputError(f"ds: must be a finite number > 0 (kept within [ds_min, ds_max]), "
                             f"got {self.ds!r}")
        if not self.tol < 1:
            raise InputError(f"tol: must be in (0, 1), got {self.tol!r}")
        check_count("max_points", self.max_points, 2, MAX_BRANCH_POINTS)
        if not isinstance(self.guards, StepGuards):
            raise InputError(f"guards: must be a StepGuards, got {self.guards!r}")
        if self.tangent is not None and self.tangent not in TANGENTS:
            raise InputError(f"tangent: must be one of {', '.join(TANGENTS)} or None, got "
                             f"{self.tangent!r}")

    @property
    def first_ds(self) -> float:
        """The first step of a new branch or curve: ``ds``, else ``DEFAULT_DS``."""
        return DEFAULT_DS if self.ds is None else self.ds


def options_with(options: ContinuationOptions | None, base: ContinuationOptions | None = None,
                 **given: object) -> ContinuationOptions:
    """``options`` (None: ``base``, else ``ContinuationOptions()``) with each keyword of
    ``given`` that is not None put in its field (and checked): what the keyword arguments
    of the ``continue_*`` functions build."""
    start = options if options is not None else base if base is not None else \
        ContinuationOptions()
    changes = {name: value for name, value in given.items() if value is not None}
    return dataclasses.replace(start, **changes) if changes else start
