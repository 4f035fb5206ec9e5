"""Frequency-domain methods by family: periodic responses by harmonic balance with Hill's
stability, quasi-periodic tori by 2-D harmonic balance, and the same tori as invariant
circles of the shaft map; each continued as a branch family of the one continuation engine
(``analysis.stability.continuation.trace``).

* ``periodic/``: ``harmonic`` (the harmonic-balance equations of any forced System by AFT in
  CasADi: ``HarmonicSystem``, the Fourier ``Basis``, ``check_harmonics``,
  ``check_forced``), ``hill`` (Hill's multipliers with eigenvalue sorting:
  ``hill_stability``, ``SORTS``), ``solve`` (one response by Newton: ``harmonic_balance``
  -> ``PeriodicResponse``; ``harmonic_convergence``), ``continuation`` (the HB family:
  ``HarmonicBranchProblem``, ``continue_harmonic``, ``harmonic_branch_dataset``; the
  ``FourierBranchProblem`` shared with tori);
* ``torus/``: ``equations`` (the 2-torus equations by a 2-D AFT: ``TorusSystem``,
  ``TorusBasis``, ``parse_frequencies``, the checks), ``solve`` (one torus by Newton, its
  truncation measures and λ1: ``solve_torus`` -> ``TorusResponse``), ``dataset`` (tori as
  Datasets with named lines, runs sampled from them: ``torus_dataset``, ``torus_run``,
  ``torus_of``), ``continuation`` (the torus family and its stop report:
  ``continue_torus``);
* ``circle/``: quasi-periodic shooting, ``solve`` (the invariant circle of the shaft-period
  map: ``ShaftMap``, ``solve_circle`` -> ``CircleResponse``, ``circle_dataset``) and
  ``continuation`` (the circle family: ``continue_circle``);
* ``methods``: the methods as data, what ``bearingdyn hb`` and ``bearingdyn torus`` look up.

Every public name is importable from here: ``from analysis.frequency import
harmonic_balance, continue_harmonic``.
"""

from analysis.budgets import DENSE_MEMORY
from analysis.frequency.circle.continuation import continue_circle
from analysis.frequency.circle.solve import CircleResponse, circle_dataset, solve_circle
from analysis.frequency.periodic.continuation import (
    HarmonicBranchProblem,
    continue_harmonic,
    harmonic_branch_dataset,
)
from analysis.frequency.periodic.harmonic import (
    MAX_UNKNOWNS,
    Basis,
    HarmonicSystem,
    check_forced,
    check_harmonics,
    fast_samples,
)
from analysis.frequency.periodic.hill import SORTS, HillResult, hill_stability
from analysis.frequency.periodic.solve import (
    PeriodicResponse,
    harmonic_balance,
    harmonic_convergence,
    hill_of,
)
from analysis.frequency.torus.continuation import continue_torus
from analysis.frequency.torus.dataset import torus_dataset, torus_of, torus_run
from analysis.frequency.torus.equations import TorusBasis, TorusSystem, parse_frequencies
from analysis.frequency.torus.solve import TorusResponse, solve_torus

__all__ = [
    "DENSE_MEMORY", "MAX_UNKNOWNS", "SORTS", "Basis", "CircleResponse",
    "HarmonicBranchProblem", "HarmonicSystem", "HillResult", "PeriodicResponse", "TorusBasis",
    "TorusResponse", "TorusSystem", "check_forced", "check_harmonics", "circle_dataset",
    "continue_circle", "continue_harmonic", "continue_torus", "fast_samples", "harmonic_balance",
    "harmonic_branch_dataset", "harmonic_convergence", "hill_of", "hill_stability",
    "parse_frequencies", "solve_circle", "solve_torus", "torus_dataset", "torus_of",
    "torus_run",
]
