"""Global continuation: the attractors at each value of a parameter, matched across values.

The method of Datseris, Rossi & Wagemakers (Chaos 33, 073151, 2023; Attractors.jl's
``RecurrencesFindAndMatch``), made safe against its known trap (close attractors matched by
distance alone): at each value the attractors are found from the previous value's
attractors (one seed each: a state on it) and ``samples`` new random initial states in a
box; the random states give each attractor's basin fraction. An attractor at the new value
takes the id of a previous one when

1. **basin overlap**: the previous attractor's seed landed on it (the new attractor lies in
   the old one's basin, followed continuously) and their periods are equal or one period
   doubling apart (``related``: a period-1 orbit whose state lands on a period-3 orbit
   after a coarse step is not that orbit; said in the notes), the pairs taken in order of
   the distance
   between their section sets, each id used once (when an attractor vanishes at a fold its
   seed falls onto another one that already has a closer predecessor: it does not steal
   that id);
2. **distance**: else, the distance between the section sets (``set_distance``) is below
   ``match_distance`` and the previous attractor is still unmatched.

Anything else is a new attractor with a new id. A matched attractor keeps its id from value
to value, so its existence range and its fraction along the parameter can be read off.

**Saying how sure a match is.** ``match_distance`` is the matching threshold (the API
keyword; ``--match-threshold`` on the command line). Every match is checked against it and
each doubt is a note of the step (``Step.notes``), stored and printed:

- a seed-matched pair farther apart than the threshold (the parameter step is coarse for
  this attractor: its ids may be swapped; take a finer step or a larger threshold);
- a match between attractors of different periods (kept as one id because the previous
  attractor's seed landed on it and the periods are one doubling apart, or one side is not
  periodic: a bifurcation, or a swap; said, never silent), and a seed landing refused
  because the periods are not so related;
- a previous attractor that vanished while a new one appeared within ten thresholds of it
  (perhaps the same attractor moved farther than the threshold: raise it, or refine).

**Transitions.** The random initial states are the same at every value (the stream
``(seed, 0)``: common random numbers), so where the states of each attractor's basin go at
the next value is counted exactly: ``transitions`` gives, for consecutive values, the
fraction of the states of each basin (and of the diverged and undecided states) that reach
each attractor at the next value (the tipping probabilities of Kaszás, Feudel & Tél 2019,
Attractors.jl's ``tipping_probabilities``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

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


def check_threshold(match_distance: float) -> float:
    """``match_distance`` as a float, or ``InputError`` (field ``match_distance``) unless
    the matching threshold is a finite number > 0 (orbit sizes)."""
    if (isinstance(match_distance, bool) or not isinstance(match_distance, (int, float))
            or not np.isfinite(match_distance) or match_distance <= 0):
        raise InputError(f"match_distance: must be a number > 0 (orbit sizes), got "
                         f"{match_distance!r}", field="match_distance")
    return float(match_distance)


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
    notes: list[str] = field(default_factory=list)
    """Doubts about this value's matches (see the module), one sentence each."""

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

    def random_labels(self) -> np.ndarray:
        """The global id (or DIVERGED/UNDECIDED/FAILED) of each random initial state."""
        labels = self.result.labels[self.random]
        return np.array([self.ids.get(int(k), int(k)) for k in labels], dtype=np.int64)


def transitions(before: np.ndarray, after: np.ndarray) -> dict[int, dict[int, float]]:
    """The tipping probabilities between two labellings of the same initial states: for
    each label ``a`` of ``before``, label ``b`` -> the fraction of the states labelled ``a``
    that ``after`` labels ``b`` (each row sums to 1)."""
    before, after = np.asarray(before), np.asarray(after)
    if before.shape != after.shape:
        raise ValueError("the two labellings must be of the same states")
    out: dict[int, dict[int, float]] = {}
    for a in np.unique(before):
        mine = after[before == a]
        targets, counts = np.unique(mine, return_counts=True)
        out[int(a)] = {int(b): float(c) / len(mine) for b, c in zip(targets, counts,
                                                                    strict=True)}
    return out


def match(previous: list[tuple[int, Attractor]], seeded: dict[int, int],
          found: list[Attractor], scale: Scale, next_id: int,
          match_distance: float = MATCH_DISTANCE,
          notes: list[str] | None = None) -> tuple[dict[int, int], int]:
    """Global ids of the attractors ``found`` at a new value (see the module).

    ``previous``: (global id, attractor) at the last value; ``seeded``: global id of a
    previous attractor -> the new attractor id its seed landed on (or a label <= 0);
    ``next_id``: the first unused global id; ``notes``: a list that receives the doubts
    about the matches (see the module). Returns (found id -> global id, next unused
    id)."""
    old = dict(previous)
    distance = {(g, a.id): set_distance(old[g].points, a.points, scale)
                for g in old for a in found}
    ids: dict[int, int] = {}
    used: set[int] = set()
    new = {a.id: a for a in found}
    overlap = sorted((distance[g, j], g, j) for g, j in seeded.items()
                     if j > 0 and related(old[g], new[j]))
    if notes is not None:
        notes.extend(f"attractor {g}'s state landed on a {new[j].nature} attractor: not "
                     f"taken as the same ({old[g].nature} and {new[j].nature} are not one "
                     "period doubling apart); matched by distance instead"
                     for g, j in sorted(seeded.items())
                     if j > 0 and not related(old[g], new[j]))
    loose = sorted((d, g, j) for (g, j), d in distance.items()
                   if d <= match_distance and related(old[g], new[j]))
    for _, g, j in [*overlap, *loose]:
        if j not in ids and g not in used:
            ids[j] = g
            used.add(g)
    for a in found:
        if a.id not in ids:
            ids[a.id], next_id = next_id, next_id + 1
    if notes is not None:
        notes.extend(doubts(old, new, ids, distance, match_distance, seeded))
    return ids, next_id


def related(a: Attractor, b: Attractor) -> bool:
    """Whether a seed landing from ``a`` on ``b`` may make them one id: their periods equal
    or one period doubling apart (a non-periodic side: allowed, and noted)."""
    if a.period is None or b.period is None:
        return True
    return b.period in (a.period, 2 * a.period) or a.period == 2 * b.period


def doubts(old: dict[int, Attractor], found: dict[int, Attractor], ids: dict[int, int],
           distance: dict[tuple[int, int], float], match_distance: float,
           seeded: dict[int, int]) -> list[str]:
    """The sentences ``match`` adds to a step's notes (see the module)."""
    out = []
    for j, g in sorted(ids.items(), key=lambda item: item[1]):
        if g not in old:
            continue
        d, a, b = distance[g, j], old[g], found[j]
        why = ("the previous one's state landed on it" if seeded.get(g) == j else
               f"their section points lie within the matching threshold ({d:.3g} orbit "
               "sizes)")
        if d > match_distance:
            out.append(f"attractor {g} moved {d:.3g} orbit sizes, more than the matching "
                       f"threshold {match_distance:g}: it kept its id because the previous "
                       "one's state landed on it; the ids may be swapped (take a finer "
                       "parameter step or a larger --match-threshold)")
        if a.nature != b.nature and (a.period or b.period):
            out.append(f"attractor {g} changed from {a.nature} to {b.nature}: kept as one "
                       f"id because {why} (a bifurcation, or a swap; check with a finer "
                       "step)")
    lost = [g for g in old if g not in ids.values()]
    new = [j for j, g in ids.items() if g not in old]
    for g in lost:
        near = [(distance[g, j], j) for j in new
                if distance[g, j] <= 10 * match_distance and related(old[g], found[j])]
        if near:
            d, j = min(near)
            out.append(f"attractor {g} vanished and attractor {ids[j]} appeared "
                       f"{d:.3g} orbit sizes from it, beyond the matching threshold "
                       f"{match_distance:g}: perhaps one attractor (take a finer step or "
                       "a larger --match-threshold)")
    return out


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
    studies: Sequence[AttractorStudy] | None = None,
) -> list[Step]:
    """The attractors of ``system`` at each of ``values`` of ``parameter`` (its own unit:
    rpm for ``speed_rpm``), found from the previous value's attractors plus ``samples``
    random initial states in ``box`` (``seed``: the random generator's seed; the same
    states, from the stream ``(seed, 0)``, at every value), matched across values (see the
    module) with the threshold ``match_distance`` (orbit sizes, > 0). ``period``, ``dt``,
    ``options``, ``label_options``: as ``AttractorStudy``;
    ``blocks``: how each value's states are cut and mapped (``study.Blocks``; default: the
    study's own block size, in this process); ``mapper``, ``device``, ``feature_options``:
    as ``study.make_study``, resolved at each value; ``studies``: the study at each value,
    made (and checked, with ``match_distance``) before, by a plan: used instead of making
    them here."""
    if parameter not in system.model.parameter_names:
        raise InputError(f"param: '{parameter}' is not a parameter of model "
                         f"'{system.model.name}'; parameters: "
                         f"{', '.join(system.model.parameter_names)}")
    if studies is None:  # a plan's studies come with the threshold checked
        check_threshold(match_distance)
    steps: list[Step] = []
    next_id = 1
    for value in values:
        here = system.replace(**{parameter: float(value)})
        previous = steps[-1].attractors() if steps else []
        study = studies[len(steps)] if studies is not None else make_study(
            here, samples + len(previous), period=period, dt=dt, options=options,
            label_options=label_options, mapper=mapper, device=device,
            feature_options=feature_options, block=None if blocks is None else blocks.size)
        seeds = np.array([a.representative for _, a in previous]).reshape(-1, here.n_state)
        random = box.sample(here, samples, np.random.default_rng([seed, 0]))
        result = study.find(np.concatenate([seeds, random]), blocks=blocks)
        seeded = {g: int(result.labels[k]) for k, (g, _) in enumerate(previous)}
        notes: list[str] = []
        ids, next_id = match(previous, seeded, result.attractors, study.scale, next_id,
                             match_distance, notes)
        steps.append(Step(float(value), result, ids, slice(len(seeds), None), study, notes))
        if progress is not None:
            found = ", ".join(f"{ids[a.id]}: {a.nature}" for a in result.attractors)
            progress(f"{parameter} = {value:g}: {found or 'no attractor'}")
            for note in notes:
                progress(f"  warning: {note}")
    return steps
