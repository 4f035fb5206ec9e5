"""On the paper's target, the sets a calibration reports, run again one by one with
``simulate`` + ``lyapunov`` + ``classify`` + ``find_peaks`` (the tool's single-run path,
not the member kernels), match the same rows the calibration says they match."""

from __future__ import annotations

import numpy as np

from analysis.inference.abc import calibrate, row_marks
from analysis.inference.simulate import MemberRow, RunSettings, peak_names, row_system
from analysis.integrate.simulate import simulate
from analysis.provenance import state_at
from analysis.stability.classify import classify
from analysis.stability.lyapunov import lyapunov

SETTINGS = RunSettings(transient_revolutions=20, revolutions=40)
PRIORS = ["rotor_mass:0.1:10:log", "damping:10:3162:log"]


def _single_run(system, settings: RunSettings, coordinates) -> MemberRow:
    h, every = settings.steps(system)
    per = settings.samples_per_revolution * every
    transient = settings.transient_revolutions * per * h
    duration = transient + settings.revolutions * per * h
    ds = simulate(system, duration=duration, transient=transient, dt=h, save_every=every)
    exps = lyapunov(system.replace(state=state_at(ds, 0)), duration=duration - transient,
                    transient=0.0, tangent_transient=0.0, dt=h, n_exponents=1,
                    renorm_every=every)
    record = ds.isel(t=slice(1, None))  # the kernels' record starts one sample later
    verdict = classify(record, "shaft", exponents=exps)
    from analysis.signal.spectrum import find_peaks

    lines = {c: peak_names(find_peaks(record, c, settings.max_peaks)) for c in coordinates}
    return MemberRow(verdict.nature, float(exps.exponents[0]), float(exps.ci95[0]),
                     {c: v[0] for c, v in lines.items() if v}, lines, np.nan)


def test_reported_sets_reproduce_their_rows_when_run_alone():
    cal = calibrate("vakharia2015", "paper-table2", PRIORS, samples=4, rounds=1,
                    settings=SETTINGS)
    post = cal.posterior
    target = cal.target
    for i in np.flatnonzero(post.weights > 0)[:2]:
        params = dict(zip([p.name for p in cal.priors], post.values[i], strict=True))
        singles = [_single_run(row_system(cal.model, row).replace(**params), SETTINGS,
                               target.coordinates) for row in target.rows]
        marks = [row_marks(row, res) for row, res in zip(target.rows, singles, strict=True)]
        assert sum(k for k, _ in marks) == post.matched[i]
        assert sum(ln for _, ln in marks) == post.lines_matched[i]
        for single, ours in zip(singles, post.rows[i], strict=True):
            assert single.nature == ours.nature
