"""The three attractor studies a user runs: basins on a grid, basin fractions in a box,
and global continuation in a parameter. Each returns a Dataset with provenance
(``analysis.stability.attractors.dataset``).

Each cuts its initial states into blocks of ``block`` states (``study.Blocks``; at each
parameter value for a continuation, the values one after the other since each is seeded
from the previous one) and maps them with ``runner`` (default: in this process); the
result does not depend on the runner (``analysis.sweeps.attractor_blocks`` runs the blocks
on an executor and stores them). The Dataset also has ``label_periods`` (basins and
fractions: the forcing periods each initial state took to be labelled), the attrs ``block``
and, when a block failed, ``failed_blocks``."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict

import numpy as np
import xarray as xr

from analysis.errors import check_count
from analysis.integrate.flow import Period
from analysis.model import System
from analysis.stability.attractors.continuation import (
    MATCH_DISTANCE,
    continue_attractors,
)
from analysis.stability.attractors.dataset import (
    basins_dataset,
    continuation_dataset,
    fractions_dataset,
)
from analysis.stability.attractors.featurizing import FeatureOptions
from analysis.stability.attractors.label import LabelOptions
from analysis.stability.attractors.mapper import MapperOptions
from analysis.stability.attractors.sampling import Box, Range, check_pair, grid_states
from analysis.stability.attractors.study import (
    AttractorStudy,
    Blocks,
    Result,
    Runner,
    make_study,
)

Progress = Callable[[int, int], None]


LABEL_PERIODS = {"units": "forcing periods",
                 "long_name": "periods integrated before the initial state was labelled"}


def blocks_attrs(ds: xr.Dataset, block: int, results: Sequence[Result],
                 study: AttractorStudy) -> xr.Dataset:
    """``ds`` with the attrs ``block``, ``mapper`` and ``device`` (the featurizing
    mapper's run settings too) and (when any) ``failed_blocks``."""
    ds.attrs["block"] = block
    ds.attrs["mapper"] = study.mapper_kind
    if study.mapper_kind == "features":
        ds.attrs["device"] = study.device
        ds.attrs.update({f"features_{k}": v for k, v in asdict(study.feature_options).items()})
    failed = [f"{k}: {message}" for r in results for k, message in r.failed.items()]
    if failed:
        ds.attrs["failed_blocks"] = "; ".join(failed)
    return ds


def basins(system: System, x: Range, y: Range, *, period: str | Period | None = None,
           dt: float | None = None, options: MapperOptions | None = None,
           label_options: LabelOptions | None = None,
           progress: Progress | None = None, block: int | None = None,
           runner: Runner | None = None, mapper: str = "auto", device: str = "auto",
           feature_options: FeatureOptions | None = None,
           study: AttractorStudy | None = None) -> xr.Dataset:
    """Basins of attraction on a grid of ``x.num`` × ``y.num`` initial states over two
    state coordinates (SI units; the others at ``system.state``): the attractor id of every
    grid cell and the attractors' table (``dataset.basins_dataset``). ``period``: the
    map's forcing period (None: the model's default); ``dt``: largest RK4 step, s;
    ``block``, ``runner``: see the module; ``mapper``, ``device``, ``feature_options``: the
    mapper and where it runs (``study.make_study``). ``study``: the study a plan checked
    and made with these settings (``analysis.sweeps.attractor_blocks.plan_basins``): used
    as it is, its checks not run again."""
    if study is None:
        check_count("x", x.num)
        check_count("y", y.num)
        check_pair(system, x, y)
        study = make_study(system, x.num * y.num, period=period, dt=dt, options=options,
                           label_options=label_options, mapper=mapper, device=device,
                           feature_options=feature_options, block=block)  # before the grid
    block = block or study.default_block
    states = grid_states(system, x, y)
    result = study.find(states, progress, Blocks(block, runner))
    ds = basins_dataset(study, result, x, y)
    ds["label_periods"] = (ds.basin.dims, result.spent.reshape(y.num, x.num).astype(np.int32),
                           LABEL_PERIODS)
    return blocks_attrs(ds, block, [result], study)


def basin_fractions(system: System, box: Box, samples: int, *, seed: int = 0,
                    period: str | Period | None = None, dt: float | None = None,
                    options: MapperOptions | None = None,
                    label_options: LabelOptions | None = None,
                    progress: Progress | None = None, block: int | None = None,
                    runner: Runner | None = None, mapper: str = "auto",
                    device: str = "auto",
                    feature_options: FeatureOptions | None = None,
                    study: AttractorStudy | None = None) -> xr.Dataset:
    """Each attractor's basin fraction, with its standard error, among ``samples`` initial
    states drawn uniformly in ``box`` (``seed``: NumPy's ``default_rng`` seed); ``study``:
    as ``basins``."""
    if study is None:
        check_count("samples", samples)
        box.check(system)
        study = make_study(system, samples, period=period, dt=dt, options=options,
                           label_options=label_options, mapper=mapper, device=device,
                           feature_options=feature_options, block=block)
    block = block or study.default_block
    states = box.sample(system, samples, np.random.default_rng(seed))
    result = study.find(states, progress, Blocks(block, runner))
    ds = fractions_dataset(study, result, states, box, seed)
    ds["label_periods"] = ("sample", result.spent.astype(np.int32), LABEL_PERIODS)
    return blocks_attrs(ds, block, [result], study)


def global_continuation(system: System, parameter: str, values: Sequence[float], box: Box,
                        samples: int, *, seed: int = 0, period: str | Period | None = None,
                        dt: float | None = None, options: MapperOptions | None = None,
                        label_options: LabelOptions | None = None,
                        match_distance: float = MATCH_DISTANCE,
                        progress: Callable[[str], None] | None = None,
                        block: int | None = None, runner: Runner | None = None,
                        mapper: str = "auto", device: str = "auto",
                        feature_options: FeatureOptions | None = None,
                        studies: Sequence[AttractorStudy] | None = None) -> xr.Dataset:
    """The attractors at each of ``values`` of ``parameter``, seeded from the previous
    value's and ``samples`` random states in ``box``, matched across values
    (``continuation.continue_attractors``; ``match_distance``: the matching threshold,
    orbit sizes). ``studies``: the study at each value, checked and made by a plan
    (``analysis.sweeps.attractor_blocks.plan_continuation``), used as they are."""
    if studies is None:  # the threshold: continue_attractors checks it, before any work
        check_count("samples", samples)
        box.check(system)
        study = make_study(system, samples + 16, period=period, dt=dt, options=options,
                           label_options=label_options, mapper=mapper, device=device,
                           feature_options=feature_options, block=block)
    else:
        study = studies[0]
    block = block or study.default_block
    steps = continue_attractors(system, parameter, values, box, samples, seed=seed,
                                period=period, dt=dt, options=options,
                                label_options=label_options, match_distance=match_distance,
                                progress=progress, blocks=Blocks(block, runner),
                                mapper=mapper, device=study.placement,  # judged once
                                feature_options=feature_options, studies=studies)
    ds = continuation_dataset(steps[0].study, steps, parameter, box, samples, seed,
                              match_distance)
    return blocks_attrs(ds, block, [s.result for s in steps], steps[0].study)
