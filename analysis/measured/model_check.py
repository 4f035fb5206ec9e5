"""Does the model produce what was measured? The defect model of a diagnosis, simulated at
the record's speed, sample rate and bearing, and compared with the record
(``analysis.measured.compare``): what ``bearingdyn diagnose --model`` runs.

The run is matched to the record where the shipped 6205 defect models let it be:

- the model: the one of the verdict (``DEFECT_MODELS``: outer-race -> 6205-outer-defect,
  inner-race -> 6205-inner-defect, ball -> 6205-ball-defect), or the one given;
- ``speed_rpm``: the record's speed (the diagnosis's, refined on the 1X line);
- the sample rate: the record's (``plan.steps_for_rate``: a step at most the model's, and
  steps per sample so that the saved spacing is 1/rate exactly);
- ``housing_resonance_hz``: a resonance inside the record's band (the centre of the
  diagnosis's envelope band, else a quarter of the rate: 3 kHz at 12 kHz), below the
  record's Nyquist frequency, as a real housing's must be for the record to show it;
- the bearing's geometry (``ball_diameter``, ``pitch_diameter``, the race diameters D ∓ d
  and the ball count): the record's bearing, so that the defect lines stand at the orders
  the record's do. The shipped models have the seed paper's 6205 (d = 4.762 mm, D = 23.5
  mm); the CWRU 6205 is larger (d = 7.94 mm, D = 39.04 mm) but of almost the same d/D
  (0.2026 against 0.2034) and ball count, so its defect orders differ by 0.1-0.4 %
  (BPFI 5.412 against 5.415, BSF 2.366 against 2.357); another bearing's differ more.
"""

from __future__ import annotations

import math
from typing import Any

import xarray as xr

from analysis.errors import InputError
from analysis.measured.bearings import Bearing, lookup
from analysis.measured.compare import Comparison, compare
from analysis.measured.records import pick_channel, record_speed_hz

DEFECT_MODELS = {"outer-race": "6205-outer-defect", "inner-race": "6205-inner-defect",
                 "ball": "6205-ball-defect"}
"""The shipped defect model of each verdict."""
DURATION = 1.2
"""Simulated time (s), transient included: 1 s kept (a bin of 1 Hz)."""
TRANSIENT = 0.2
"""Time left out (s): > 25 rotor damping times of the 6205 models."""


def geometry_parameters(bearing: Bearing) -> dict[str, float]:
    """The model parameters of a bearing's geometry (m, rad): ball and pitch diameters, the
    races' diameters D − d and D + d (so that their mean is the pitch diameter and the gap
    between them one ball, as the seed paper's Table 1) and the contact angle."""
    d, pitch = bearing.ball_diameter_m, bearing.pitch_diameter_m
    return {"ball_diameter": d, "pitch_diameter": pitch, "inner_race_diameter": pitch - d,
            "outer_race_diameter": pitch + d, "contact_angle": bearing.contact_angle_rad}


def matching_run(verdict: str, record: xr.Dataset, model: str | None = None, *,
                 shaft_hz: float | None = None, band_hz: tuple[float, float] | None = None,
                 bearing: Bearing | None = None, resonance_hz: float | None = None
                 ) -> tuple[str, dict[str, float], int | None]:
    """(model, parameters, balls) of the run that matches ``record`` (module docstring)."""
    from analysis.model import load_model

    if model is None:
        if verdict not in DEFECT_MODELS:
            raise InputError(f"model: no defect model for the verdict '{verdict}'; name "
                             f"one of {', '.join(DEFECT_MODELS.values())}", field="model")
        model = DEFECT_MODELS[verdict]
    names = set(load_model(model).parameter_names)
    shaft = record_speed_hz(record) if shaft_hz is None else shaft_hz
    if shaft is None or not (math.isfinite(shaft) and shaft > 0):
        raise InputError("record: it has no shaft speed; give --rpm (or read it with --tacho)")
    fs = float(record.attrs["sample_rate_hz"])
    params: dict[str, float] = {"speed_rpm": float(shaft) * 60.0}
    if "housing_resonance_hz" in names:
        if resonance_hz is None:
            resonance_hz = (band_hz[0] + band_hz[1]) / 2 if band_hz else fs / 4
        if not (math.isfinite(resonance_hz) and 0 < resonance_hz < fs / 2):
            raise InputError(f"resonance: must lie below the record's Nyquist frequency "
                             f"{fs / 2:g} Hz, got {resonance_hz}")
        params["housing_resonance_hz"] = float(resonance_hz)
    balls = None
    if bearing is not None:
        params.update({k: v for k, v in geometry_parameters(bearing).items() if k in names})
        balls = bearing.n_balls
    return model, params, balls


def simulate_matching(diagnosis_or_verdict: Any, record: xr.Dataset, model: str | None = None,
                      *, channel: str | None = None, bearing: str | Bearing | None = None,
                      rpm: float | None = None, resonance_hz: float | None = None,
                      geometry: bool = True, duration: float = DURATION,
                      transient: float = TRANSIENT) -> Comparison:
    """Simulate the defect model of a diagnosis (a ``Diagnosis`` or its verdict string) at
    the record's speed (``rpm``, else the diagnosis's, else the record's), sample rate,
    bearing geometry (``geometry``; the diagnosis's bearing or ``bearing``) and a
    resonance in its band (``resonance_hz``, Hz; default the module docstring's), for
    ``duration`` s (``transient`` s left out), and compare it with the record's
    ``channel``. The comparison's provenance says what was simulated (``simulation``).

    >>> simulate_matching("none", xr.Dataset())  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    analysis.errors.InputError: model: no defect model for the verdict 'none'; name one ...
    """
    from analysis.integrate.plan import steps_for_rate
    from analysis.integrate.simulate import simulate
    from analysis.model import load_model

    verdict = str(getattr(diagnosis_or_verdict, "verdict", diagnosis_or_verdict))
    if model is None and verdict not in DEFECT_MODELS:
        matching_run(verdict, record)  # the one-line refusal
    if isinstance(bearing, str):
        bearing = lookup(bearing)
    bearing = bearing or getattr(diagnosis_or_verdict, "bearing", None)
    speed = getattr(diagnosis_or_verdict, "speed", None)
    shaft = rpm / 60.0 if rpm is not None else (speed.hz if speed is not None else None)
    band = getattr(diagnosis_or_verdict, "band", None)
    band_hz = (band.low_hz, band.high_hz) if band is not None else None
    name = pick_channel(record, channel)
    chosen, params, balls = matching_run(verdict, record, model, shaft_hz=shaft,
                                         band_hz=band_hz,
                                         bearing=bearing if geometry else None,
                                         resonance_hz=resonance_hz)
    fs = float(record.attrs["sample_rate_hz"])
    dt, save_every = steps_for_rate(fs, load_model(chosen).simulation_defaults["dt"])
    result = simulate(chosen, balls, duration=duration, transient=transient, dt=dt,
                      save_every=save_every, **params)
    comparison = compare(record, result, channel=name, bearing=bearing,
                         rpm=params["speed_rpm"] if rpm is not None else None)
    comparison.provenance["simulation"] = {
        "model": chosen, "n_balls": balls, "duration_s": duration, "transient_s": transient,
        "dt_s": dt, "save_every": save_every, "sample_rate_hz": fs, **params}
    return comparison
