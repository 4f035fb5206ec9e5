"""bearingdyn analysis layer: simulate generated models and analyse their motion.

Typical use::

    from analysis import load_model, simulate, find_peaks, poincare_section
    ds = simulate("vakharia2015", n_balls=6, speed_rpm=5000)
    find_peaks(ds, "x")
"""

from analysis.errors import BearingdynError, InputError, SimulationError, StaleModelError
from analysis.io import load_dataset, save_dataset
from analysis.model import Model, available_models, load_model
from analysis.poincare import poincare_section
from analysis.report import run_paper_case
from analysis.simulate import simulate
from analysis.spectrum import amplitude_spectrum, find_peaks, peak_table

__all__ = [
    "BearingdynError", "InputError", "Model", "SimulationError", "StaleModelError",
    "amplitude_spectrum", "available_models", "find_peaks", "load_dataset", "load_model",
    "peak_table", "poincare_section", "run_paper_case", "save_dataset", "simulate",
]
