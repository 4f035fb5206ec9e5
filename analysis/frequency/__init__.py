"""Frequency-domain methods: periodic responses by harmonic balance, Hill's stability, and
their continuation.

* ``harmonic``: the harmonic-balance equations of any forced System by AFT in CasADi
  (``HarmonicSystem``: the residual, its exact Jacobian and parameter derivative; the
  Fourier ``Basis``; the size checks ``check_harmonics``, ``check_forced``);
* ``hill``: Floquet exponents and multipliers by Hill's method with eigenvalue sorting
  (``hill_stability``, ``SORTS``);
* ``solve``: one response by Newton (``harmonic_balance`` -> ``PeriodicResponse``) and its
  convergence in the number of harmonics (``harmonic_convergence``);
* ``continuation``: a branch in any runtime parameter on the pseudo-arclength corrector and
  the special-point tests of ``analysis.stability.continuation`` (``continue_harmonic``,
  ``HarmonicBranchProblem``, ``harmonic_branch_dataset``);
* ``torus``: the quasi-periodic (2-torus) equations of two base frequencies by a 2-D AFT
  (``TorusSystem``, ``TorusBasis``, ``parse_frequencies``, the checks);
* ``torus_solve``: one torus by Newton, its truncation measures and λ1 (``solve_torus`` ->
  ``TorusResponse``);
* ``torus_dataset``: tori as Datasets with named spectrum lines, and runs sampled from them
  (``torus_dataset``, ``torus_run``, ``torus_of``);
* ``torus_continuation``: tori continued in a runtime parameter, with the report of where
  and why the branch stops (``continue_torus``);
* ``invariant_circle``: the same torus as the invariant circle of the shaft-period map
  (quasi-periodic shooting: ``solve_circle`` -> ``CircleResponse``, ``circle_dataset``);
* ``circle_continuation``: that circle continued in a runtime parameter
  (``continue_circle``).

Every public name is importable from here: ``from analysis.frequency import
harmonic_balance, continue_harmonic``.
"""

from analysis.frequency.circle_continuation import continue_circle
from analysis.frequency.continuation import (
    HarmonicBranchProblem,
    continue_harmonic,
    harmonic_branch_dataset,
)
from analysis.frequency.harmonic import (
    MAX_UNKNOWNS,
    MEMORY_BUDGET,
    Basis,
    HarmonicSystem,
    check_forced,
    check_harmonics,
    fast_samples,
)
from analysis.frequency.hill import SORTS, HillResult, hill_stability
from analysis.frequency.invariant_circle import CircleResponse, circle_dataset, solve_circle
from analysis.frequency.solve import (
    PeriodicResponse,
    harmonic_balance,
    harmonic_convergence,
    hill_of,
)
from analysis.frequency.torus import TorusBasis, TorusSystem, parse_frequencies
from analysis.frequency.torus_continuation import continue_torus
from analysis.frequency.torus_dataset import torus_dataset, torus_of, torus_run
from analysis.frequency.torus_solve import TorusResponse, solve_torus

__all__ = [
    "MAX_UNKNOWNS", "MEMORY_BUDGET", "SORTS", "Basis", "CircleResponse",
    "HarmonicBranchProblem", "HarmonicSystem", "HillResult", "PeriodicResponse", "TorusBasis",
    "TorusResponse", "TorusSystem", "check_forced", "check_harmonics", "circle_dataset",
    "continue_circle", "continue_harmonic", "continue_torus", "fast_samples", "harmonic_balance",
    "harmonic_branch_dataset", "harmonic_convergence", "hill_of", "hill_stability",
    "parse_frequencies", "solve_circle", "solve_torus", "torus_dataset", "torus_of",
    "torus_run",
]
