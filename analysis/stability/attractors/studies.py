"""The three attractor studies a user runs: basins on a grid, basin fractions in a box,
and global continuation in a parameter. Each returns a Dataset with provenance
(``analysis.stability.attractors.dataset``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.flow import Period
from analysis.model import System
from analysis.stability.attractors.continuation import MATCH_DISTANCE, continue_attractors
from analysis.stability.attractors.dataset import (
    basins_dataset,
    continuation_dataset,
    fractions_dataset,
)
from analysis.stability.attractors.label import LabelOptions
from analysis.stability.attractors.mapper import MapperOptions
from analysis.stability.attractors.sampling import Box, Range, grid_states
from analysis.stability.attractors.study import AttractorStudy, check_memory

Progress = Callable[[int, int], None]


def check_count(field: str, value: int) -> int:
    """``InputError`` unless ``value`` is a whole number >= 1."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"{field}: must be a whole number >= 1, got {value!r}")
    return int(value)


def basins(system: System, x: Range, y: Range, *, period: str | Period | None = None,
           dt: float | None = None, options: MapperOptions | None = None,
           label_options: LabelOptions | None = None,
           progress: Progress | None = None) -> xr.Dataset:
    """Basins of attraction on a grid of ``x.num`` × ``y.num`` initial states over two
    state coordinates (SI units; the others at ``system.state``): the attractor id of every
    grid cell and the attractors' table (``dataset.basins_dataset``). ``period``: the
    map's forcing period (None: the model's default); ``dt``: largest RK4 step, s."""
    check_count("x", x.num)
    check_count("y", y.num)
    states = grid_states(system, x, y)
    check_memory(len(states), system.n_state, options or MapperOptions())
    study = AttractorStudy(system, period, dt, options, label_options)
    return basins_dataset(study, study.find(states, progress), x, y)


def basin_fractions(system: System, box: Box, samples: int, *, seed: int = 0,
                    period: str | Period | None = None, dt: float | None = None,
                    options: MapperOptions | None = None,
                    label_options: LabelOptions | None = None,
                    progress: Progress | None = None) -> xr.Dataset:
    """Each attractor's basin fraction, with its standard error, among ``samples`` initial
    states drawn uniformly in ``box`` (``seed``: NumPy's ``default_rng`` seed)."""
    check_count("samples", samples)
    box.check(system)
    check_memory(samples, system.n_state, options or MapperOptions())
    study = AttractorStudy(system, period, dt, options, label_options)
    states = box.sample(system, samples, np.random.default_rng(seed))
    return fractions_dataset(study, study.find(states, progress), states, box, seed)


def global_continuation(system: System, parameter: str, values: Sequence[float], box: Box,
                        samples: int, *, seed: int = 0, period: str | Period | None = None,
                        dt: float | None = None, options: MapperOptions | None = None,
                        label_options: LabelOptions | None = None,
                        match_distance: float = MATCH_DISTANCE,
                        progress: Callable[[str], None] | None = None) -> xr.Dataset:
    """The attractors at each of ``values`` of ``parameter``, seeded from the previous
    value's and ``samples`` random states in ``box``, matched across values
    (``continuation.continue_attractors``)."""
    check_count("samples", samples)
    box.check(system)
    check_memory(samples + 16, system.n_state, options or MapperOptions())
    steps = continue_attractors(system, parameter, values, box, samples, seed=seed,
                                period=period, dt=dt, options=options,
                                label_options=label_options, match_distance=match_distance,
                                progress=progress)
    return continuation_dataset(steps[0].study, steps, parameter, box, samples, seed)
