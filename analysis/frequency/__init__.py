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
  ``HarmonicBranchProblem``, ``harmonic_branch_dataset``).

Every public name is importable from here: ``from analysis.frequency import
harmonic_balance, continue_harmonic``.
"""

from analysis.frequency.continuation import (
    HarmonicBranchProblem,
    continue_harmonic,
    harmonic_branch_dataset,
    trace_harmonic_branch,
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
from analysis.frequency.solve import (
    PeriodicResponse,
    harmonic_balance,
    harmonic_convergence,
    hill_of,
)

__all__ = [
    "MAX_UNKNOWNS", "MEMORY_BUDGET", "SORTS", "Basis", "HarmonicBranchProblem",
    "HarmonicSystem", "HillResult", "PeriodicResponse", "check_forced", "check_harmonics",
    "continue_harmonic", "fast_samples", "harmonic_balance", "harmonic_branch_dataset",
    "harmonic_convergence", "hill_of", "hill_stability", "trace_harmonic_branch",
]
