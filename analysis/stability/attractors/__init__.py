"""Every attractor, not one: coexisting attractors of a System, their basins, and their
continuation in a parameter.

Built on the stroboscopic map of an ensemble of initial states
(``analysis.integrate.ensemble.StroboscopicMap``):

* ``mapper``: attractors found by recurrences on a sparse grid of cells (Datseris &
  Wagemakers 2022), with early stopping, ``DIVERGED`` and ``UNDECIDED`` labels;
* ``label``: each attractor described (class, period, λ1 with its interval, amplitudes);
* ``study``: ``AttractorStudy``, a System's map, scale and mapper together;
* ``sampling``: boxes and grids of initial states;
* ``continuation``: global continuation, attractors matched across parameter values by
  basin overlap and section-set distance (Datseris, Rossi & Wagemakers 2023);
* ``dataset``: the results as Datasets and JSON;
* ``boundary``: how uncertain a basin picture is (basin entropy, boundary basin entropy,
  uncertainty exponent);
* ``studies``: ``basins``, ``basin_fractions`` and ``global_continuation``, the three studies
  of the command line.
"""

from analysis.stability.attractors.boundary import Boundary, boundary_measures
from analysis.stability.attractors.dataset import existence, study_json
from analysis.stability.attractors.label import Attractor, LabelOptions
from analysis.stability.attractors.mapper import (
    DIVERGED,
    UNDECIDED,
    MapperOptions,
    RecurrenceMapper,
    Scale,
)
from analysis.stability.attractors.sampling import Box, Range, grid_states
from analysis.stability.attractors.studies import basin_fractions, basins, global_continuation
from analysis.stability.attractors.study import AttractorStudy, Result

__all__ = [
    "DIVERGED", "UNDECIDED", "Attractor", "AttractorStudy", "Boundary", "Box", "LabelOptions",
    "MapperOptions", "Range", "RecurrenceMapper", "Result", "Scale", "basin_fractions",
    "basins", "boundary_measures", "existence", "global_continuation", "grid_states", "study_json",
]
