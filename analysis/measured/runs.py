"""A measured record as the analyses of simulated runs read one: ``record_run`` turns a
record, its chosen channels, its speed and a bearing into a run-like ``xarray.Dataset``
that ``analysis.signal`` (spectra, envelope spectra, waterfalls, orbits) and the figures of
``analysis.reports`` accept unchanged.

The run-like dataset has the chosen channels over ``t`` (in the record's units; in SI with
``si``: a proximity probe's µm as m, so orbits are drawn in µm as a run's are), attrs
``state_names`` (the channels), ``shaft_hz`` (the mean speed / 60; 0 without a speed: no
line is then named by X), with a bearing its defect frequencies ``ftf_hz``, ``bpfo_hz``,
``bpfi_hz``, ``bsf_hz`` at that speed (``analysis.signal.spectrum.fault_frequencies``
reads them), ``bearing`` and the naming tolerance ``label_tolerance_rel`` (:data:`SLIP`),
and every attr of the record (``kind = "record"`` and its
provenance). It names no model: a record has no model resonance, so an envelope band is
the one where the measured signal is most impulsive (``analysis.signal.envelope``). With
``changing_speed`` the record's speed over ``t`` (a tacho's or a speed table's) becomes a
speed profile (``analysis.integrate.speed_profile``: at most ``MAX_ROWS`` rows), as a
run-up's, for ``waterfall`` and once-per-revolution marks."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.measured.records import (
    SPEED,
    pick_channel,
    read_record,
    record_speed_hz,
    speed_words,
    to_si,
)

SLIP = 0.01
"""Fraction of its frequency within which a record's line is named by a defect frequency
(attr ``label_tolerance_rel``, read by ``analysis.signal.spectrum.find_peaks``): rolling
elements slip by 1–2 % (Randall & Antoni, MSSP 25 (2011), Sec. 2.1), and the CWRU
records' lines sit within 0.5 % of theory."""
FAULT_ATTRS = {"FTF": "ftf_hz", "BPFO": "bpfo_hz", "BPFI": "bpfi_hz", "BSF": "bsf_hz"}
"""Bearing.frequencies keys -> the attrs a run carries them in."""


def record_run(record: xr.Dataset, chosen: Sequence[str] | str | None = None, *,
               bearing: Any = None, si: bool = False, changing_speed: bool | None = False,
               what: str = "this analysis") -> xr.Dataset:
    """The run-like dataset of ``record``'s channels ``chosen`` (names or patterns,
    :func:`~analysis.measured.records.pick_channel`; None: the only channel), see the
    module. ``bearing``: a ``Bearing`` or its name (``analysis.measured.bearings.lookup``)
    whose defect frequencies the spectra name; it needs the record's speed (``InputError``
    saying ``give --rpm or --tacho``, naming ``what``). ``changing_speed``: the speed over
    ``t`` as a speed profile (``InputError`` for a record at one speed); None: where the
    record has a speed over ``t``; False: one speed, the mean (``InputError`` where the
    speed over ``t`` spans more than :data:`STEADY` of it: its lines would smear; a
    waterfall follows it)."""
    patterns = [chosen] if chosen is None or isinstance(chosen, str) else list(chosen)
    names = list(dict.fromkeys(pick_channel(record, p) for p in patterns or [None]))
    data = {}
    for name in names:
        values, units = to_si(record, name) if si else (record[name].values,
                                                         record[name].attrs.get("units", "1"))
        data[name] = ("t", np.asarray(values, dtype=float),
                      {**record[name].attrs, "units": units})
    attrs = dict(record.attrs)
    speed = record_speed_hz(record)
    attrs.update(state_names=" ".join(names), shaft_hz=0.0 if speed is None else speed)
    ds = xr.Dataset(data, coords={"t": record["t"]}, attrs=attrs)
    if changing_speed is None:
        changing_speed = SPEED in record.data_vars
    if changing_speed:
        _profile(ds, record, what)
    elif SPEED in record.data_vars:
        _steady(record, what)
    if bearing is not None:
        _bearing(ds, bearing, speed, what)
    return ds


def _bearing(ds: xr.Dataset, bearing: Any, speed: float | None, what: str) -> None:
    from analysis.measured.bearings import lookup

    found = lookup(bearing) if isinstance(bearing, str) else bearing
    if speed is None:
        raise InputError(f"{what}: the defect frequencies of {found.name} need the shaft "
                         f"speed, and '{ds.attrs.get('source_file', 'the record')}' has "
                         "none; give --rpm or --tacho")
    shaft = float(ds.attrs["shaft_hz"])
    table = found.frequencies(shaft)
    ds.attrs.update({FAULT_ATTRS[k]: float(table[k]) for k in FAULT_ATTRS})
    ds.attrs.update(bearing=found.name, bearing_source=found.source,
                    label_tolerance_rel=SLIP)


STEADY = 0.05
"""Largest spread (max − min)/mean of a record's speed over ``t`` that an analysis at one
speed (a spectrum) takes as one speed, the mean."""


def _steady(record: xr.Dataset, what: str) -> None:
    speeds = record[SPEED].values
    spread = float(np.ptp(speeds) / np.mean(speeds))
    if spread > STEADY:
        raise InputError(f"{what}: the record's speed changes ({speed_words(record)}: "
                         f"{spread:.0%} of its mean, more than {STEADY:.0%}), so its lines "
                         "smear; use bearingdyn waterfall (--orders) for a run-up")


MAX_ROWS = 257
"""Most rows of the speed profile made from a record's speed over t (``speed_profile``)."""


def _profile(ds: xr.Dataset, record: xr.Dataset, what: str) -> None:
    """The record's speed over ``t`` as a speed-profile table in ``ds``'s attrs."""
    from analysis.integrate.speed_profile import SpeedProfile

    if SPEED not in record.data_vars:
        raise InputError(f"{what}: needs a speed that changes along the record, and this "
                         f"record's speed is {speed_words(record)}; give --tacho CHANNEL or "
                         "--rpm TABLE.csv (or use bearingdyn spectrum)")
    t = record["t"].values
    if "speed_table_t" in record.attrs and len(record.attrs["speed_table_t"]) <= MAX_ROWS:
        times = np.asarray(record.attrs["speed_table_t"], dtype=float)
        rpm = np.asarray(record.attrs["speed_table_rpm"], dtype=float)
    else:
        times = np.linspace(0.0, float(t[-1]), min(MAX_ROWS, t.size))
        rpm = np.interp(times, t, record[SPEED].values)
    profile = SpeedProfile.table(times, rpm, str(record.attrs.get("speed_source", "")))
    ds.attrs.update(profile.attrs(float(t[-1])))
    ds.attrs.update(duration=float(t[-1]), shaft_hz=float(rpm[0]) / 60.0,
                    speed_rpm=float(rpm[0]))


def is_record_file(path: str | Path, foreign: bool = True) -> bool:
    """Whether ``path`` is read as a measured record: any file that is not netCDF, or a
    netCDF file that is a record or (with ``foreign``) names no model (a simulated result
    names its model)."""
    from analysis.io import NETCDF_SUFFIXES, read_attrs

    path = Path(path)
    if path.suffix.lower() not in NETCDF_SUFFIXES or not path.is_file():
        return path.suffix.lower() not in NETCDF_SUFFIXES
    try:
        attrs = read_attrs(path)
    except Exception:  # damaged: the run reader says why
        return False
    return attrs.get("kind") == "record" or (foreign and not isinstance(attrs.get("model"),
                                                                          str))


def open_record_run(path: str | Path, chosen: Sequence[str] | str | None = None, *,
                    fs: float | None = None, rpm: float | str | None = None,
                    tacho: str | None = None, bearing: Any = None, si: bool = False,
                    changing_speed: bool = False, what: str = "this analysis") -> xr.Dataset:
    """:func:`read_record` then :func:`record_run`: the command line's one call."""
    record = read_record(path, fs=fs, rpm=rpm, tacho=tacho)
    return record_run(record, chosen, bearing=bearing, si=si, changing_speed=changing_speed,
                      what=what)


__all__ = ["is_record_file", "open_record_run", "record_run"]
