"""bearingdyn analysis layer: simulate generated models and analyse their motion.

Typical use::

    from analysis import load_model, simulate, find_peaks, poincare_section
    ds = simulate("vakharia2015", n_balls=6, speed_rpm=5000)
    find_peaks(ds, "x")

Names are imported on first use (PEP 562), so ``import analysis`` and the CLI start fast.
"""

from __future__ import annotations

import importlib
from typing import Any

_API = {
    "BearingdynError": "analysis.errors", "InputError": "analysis.errors",
    "SimulationError": "analysis.errors", "StaleModelError": "analysis.errors",
    "load_dataset": "analysis.io", "save_dataset": "analysis.io",
    "Model": "analysis.model", "available_models": "analysis.model",
    "load_model": "analysis.model",
    "poincare_section": "analysis.poincare",
    "run_paper_case": "analysis.report",
    "amplitude_spectrum": "analysis.spectrum", "find_peaks": "analysis.spectrum",
    "peak_table": "analysis.spectrum",
}
__all__ = [*sorted(_API), "simulate"]

# Imported eagerly: the function shares its name with its module, and a lazy lookup would
# hand out the module once anything had imported ``analysis.simulate``.
from analysis.simulate import simulate  # noqa: E402


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'analysis' has no attribute {name!r}")
    return getattr(importlib.import_module(_API[name]), name)


def __dir__() -> list[str]:
    return __all__
