"""Global continuation: the attractors at each value of a parameter, matched across values.

The method of Datseris, Rossi & Wagemakers (Chaos 33, 073151, 2023; Attractors.jl's
``RecurrencesFindAndMatch``), made safe against its known trap (close attractors matched by
distance alone): at each value the attractors are found from the previous value's
attractors (one seed each: a state on it) and ``samples`` new random initial states in a
box; the random states give each attractor's basin fraction. An attractor at the new value
takes the id of a previous one when

1. **basin overlap**: the previous attractor's seed landed on it (the new attractor lies in
   the old one's basin, followed continuously), the pairs taken in order of the distance
   between their section sets, each id used once (when an attractor vanishes at a fold its
   seed falls onto another one that already has a closer predecessor: it does not steal
   that id);
2. **distance**: else, the distance between the section sets (``set_distance``) is below
   ``match_distance`` and the previous attractor is still unmatched.

Anything else is a new attractor with a new id. A matched attractor keeps its id from value
to value, so its existence range and its fraction along the parameter can be read off.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from analysis.errors import InputError
from analysis.integrate.flow import Period
from analysis.model import System
from analysis.stability.attractors.featurizing import FeatureOptions
from analysis.stability.attractors.label import Attractor, LabelOptions
from analysis.stability.attractors.mapper import MapperOptions, Scale
from analysis.stability.attractors.sampling import Box
from analysis.stability.attractors.study import AttractorStudy, Blocks, Result, make_study

MATCH_DISTANCE = 0.25
"""Largest ``set_distance`` (in orbit sizes) at which an attractor reached by no seed still
continues an unmatched previous one."""


def set_distance(a: np.ndarray, b: np.ndarray, scale: Scale) -> float:
    """Hausdorff distance between two sets of section points (rows, SI units), each
    coordinate divided by ``scale.size`` (so in orbit sizes)."""
    a, b = np.asarray(a) / scale.size, np.asarray(b) / scale.size
    if not len(a) or not len(b):
        return float("inf")
    return float(max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()))


@dataclass
class Step:
    """The attractors at one value of the parameter, with their global ids."""

    value: float
    result: Result
    ids: dict[int, int]
    """The result's attractor id -> global id."""
    random: slice
    """The random initial states among the result's labels (the rest are seeds)."""
    study: AttractorStudy
    """The study at this value (its System, map and scale)."""

    def attractors(self) -> list[tuple[int, Attractor]]:
        """(global id, attractor) pairs."""
        return [(self.ids[a.id], a) for a in self.result.attractors]

    def fractions(self) -> dict[int, tuple[float, float]]:
        """Global id (or DIVERGED/UNDECIDED) -> basin fraction among the random states and
        its standard error. An attractor reached by seeds only has fraction 0."""
        mask = np.zeros(len(self.result.labels), dtype=bool)
        mask[self.random] = True
        out = {self.ids.get(k, k): v for k, v in self.result.fractions(mask).items()}
        return out


def match(previous: list[tuple[int, Attractor]], seeded: dict[int, int],
          found: list[Attractor], scale: Scale, next_id: int,
          match_distance: float = MATCH_DISTANCE) -> tuple[dict[int, int], int]:
    """Global ids of the attractors ``found`` at a new value (see the module).

    ``previous``: (global id, attractor) at the last value; ``seeded``: global id of a
    previous attractor -> the new attractor id its seed landed on (or a label <= 0);
    ``next_id``: the first unused global id. Returns (found id -> global id, next unused
    id)."""
    old = dict(previous)
    distance = {(g, a.id): set_distance(old[g].points, a.points, scale)
                for g in old for a in found}
    ids: dict[int, int] = {}
    used: set[int] = set()
    overlap = sorted((distance[g, j], g, j) for g, j in seeded.items() if j > 0)
    loose = sorted((d, g, j) for (g, j), d in distance.items() if d <= match_distance)
    for _, g, j in [*overlap, *loose]:
        if j not in ids and g not in used:
            ids[j] = g
            used.add(g)
    for a in found:
        if a.id not in ids:
            ids[a.id], next_id = next_id, next_id + 1
    return ids, next_id


def continue_attractors(
    system: System,
    parameter: str,
    values: Sequence[float],
    box: Box,
    samples: int,
    *,
    seed: int = 0,
    period: str | Period | None = None,
    dt: float | None = None,
    options: MapperOptions | None = None,
    label_options: LabelOptions | None = None,
    match_distance: float = MATCH_DISTANCE,
    progress: Callable[[str], None] | None = None,
    blocks: Blocks | None = None,
    mapper: str = "auto",
    device: str = "auto",
    feature_options: FeatureOptions | None = None,
) -> list[Step]:
    """The attractors of ``system`` at each of ``values`` of ``parameter`` (its own unit:
    rpm for ``speed_rpm``), found from the previous value's attractors plus ``samples``
    random initial states in ``box`` (``seed``: the random generator's seed; the states
    at value i are drawn from the stream ``(seed, i)``), matched across values (see the
    module). ``period``, ``dt``, ``options``, ``label_options``: as ``AttractorStudy``;
    ``blocks``: how each value's states are cut and mapped (``study.Blocks``; default: the
    study's own block size, in this process); ``mapper``, ``device``, ``feature_options``:
    as ``study.make_study``, resolved at each value."""
    if parameter not in system.model.parameter_names:
        raise InputError(f"param: '{parameter}' is not a parameter of model "
                         f"'{system.model.name}'; parameters: "
                         f"{', '.join(system.model.parameter_names)}")
    steps: list[Step] = []
    next_id = 1
    for i, value in enumerate(values):
        here = system.replace(**{parameter: float(value)})
        previous = steps[-1].attractors() if steps else []
        study = make_study(here, samples + len(previous), period=period, dt=dt,
                           options=options, label_options=label_options, mapper=mapper,
                           device=device, feature_options=feature_options,
                           block=None if blocks is None else blocks.size)
        seeds = np.array([a.representative for _, a in previous]).reshape(-1, here.n_state)
        random = box.sample(here, samples, np.random.default_rng([seed, i]))
        result = study.find(np.concatenate([seeds, random]), blocks=blocks)
        seeded = {g: int(result.labels[k]) for k, (g, _) in enumerate(previous)}
        ids, next_id = match(previous, seeded, result.attractors, study.scale, next_id,
                             match_distance)
        steps.append(Step(float(value), result, ids, slice(len(seeds), None), study))
        if progress is not None:
            found = ", ".join(f"{ids[a.id]}: {a.nature}" for a in result.attractors)
            progress(f"{parameter} = {value:g}: {found or 'no attractor'}")
    return steps
