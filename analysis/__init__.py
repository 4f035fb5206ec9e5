"""bearingdyn analysis layer: simulate generated models and analyse their motion.

Typical use::

    from analysis import as_system, load_model, simulate, find_peaks, poincare_section
    ds = simulate("vakharia2015", n_balls=6, speed_rpm=5000)
    find_peaks(ds, "x")
    system = as_system("two-bearing-rotor", n_balls={"left": 7, "right": 11})
    simulate(system, duration=1.0)

    from analysis import diagnose, read_record   # a measured record and its bearing's faults
    record = read_record("12k_Drive_End_IR007_0_105.mat")
    diagnose(record, channel="DE", bearing="6205-cwru").verdict   # 'inner-race'

Names are imported on first use (PEP 562), so ``import analysis`` and the CLI start fast.

The package is layered: ``model`` (the generated models), ``integrate`` (RK4/CVODES, compiled
blocks, flow maps), ``signal`` (spectra, Poincaré sections), ``stability`` (Lyapunov
exponents, periodic orbits, continuation, classification), ``sweeps`` (parameter grids and
their executors) and ``reports`` (figures, the paper's job and report, progress display);
``errors``, ``io`` (files) and ``provenance`` (result attributes: what a result says about
its system, read and written in one place) are shared by all, and ``cli`` is the
``bearingdyn`` command on top.
"""

from __future__ import annotations

import importlib
from typing import Any

_API = {
    "BearingdynError": "analysis.errors", "InputError": "analysis.errors",
    "SimulationError": "analysis.errors", "StaleModelError": "analysis.errors",
    "load_dataset": "analysis.provenance", "save_dataset": "analysis.io",
    "Model": "analysis.model", "available_models": "analysis.model",
    "load_model": "analysis.model", "System": "analysis.model", "as_system": "analysis.model",
    "poincare_section": "analysis.signal.poincare",
    "run_paper_case": "analysis.reports.report",
    "amplitude_spectrum": "analysis.signal.spectrum", "find_peaks": "analysis.signal.spectrum",
    "peak_table": "analysis.signal.spectrum",
    "simulate": "analysis.integrate.simulate",
    "SpeedProfile": "analysis.integrate.speed_profile",
    "waterfall": "analysis.signal.waterfall", "order_spectrum": "analysis.signal.orders",
    "angle_resample": "analysis.signal.orders",
    "calibrate": "analysis.inference.abc",
    "read_record": "analysis.measured.records", "diagnose": "analysis.measured.diagnose",
    "lookup_bearing": "analysis.measured.bearings", "compare": "analysis.measured.compare",
    "load_rotor": "analysis.linear.rotor", "campbell": "analysis.linear.campbell",
    "unbalance_response": "analysis.linear.unbalance",
    "uncertainty": "analysis.uncertainty.study",
}
_ALIASES = {"lookup_bearing": "lookup"}
"""Names the package exports under another name than their module's."""
__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'analysis' has no attribute {name!r}")
    return getattr(importlib.import_module(_API[name]), _ALIASES.get(name, name))


def __dir__() -> list[str]:
    return __all__
