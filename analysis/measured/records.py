"""Measured records: one type for a measured signal, whatever file it came from.

A record is an ``xarray.Dataset``:

- coordinate ``t`` (s), float64, uniformly sampled from 0 (the name a simulated run's time
  has, so the spectra, envelopes and figures of ``analysis.signal`` read both);
- one data variable per channel, named by the channel's short name (``DE`` for the CWRU
  variable ``X105_DE_time``; else the file's name made a valid identifier), float64, attrs
  ``units`` (one of ``analysis.measured.readers.UNITS``: g, m/s^2, m/s, m, um, V, 1),
  ``long_name`` and ``original_name``;
- attrs ``kind = "record"``, ``sample_rate_hz`` and ``sample_rate_source`` (``file: …``,
  ``file name: 12k``, ``--fs``), ``source_file``, ``sha256`` (of the file), ``reader`` (the
  library function), ``original_names`` (JSON list) and, where known, ``speed_rpm`` (the
  mean shaft speed, rpm) with ``speed_source`` (``file: X105RPM``, ``--rpm``, ``tacho:
  NAME``, ``speed table``); a speed that changes is also the data variable ``speed_rpm``
  over ``t`` (a speed table, or the speed of a once-per-revolution tacho channel, whose
  name is the attr ``tacho_channel``).

``read_record`` reads any file the readers know (``analysis.measured.readers.READERS``,
by suffix) and judges what the file lacks: the rate (``--fs``), the speed (``--rpm`` or
``--tacho``), each in one ``InputError`` line naming the parameter that gives it (its
``field``: the command line names the option).
"""

from __future__ import annotations

import fnmatch
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.measured.readers import Channel, Raw, reader_for, unit_of

SPEED = "speed_rpm"
"""The data variable of a speed that changes along the record (rpm over ``t``)."""
G = 9.80665
"""Standard gravity (m/s^2): 1 g."""
TO_SI = {"g": (G, "m/s^2"), "um": (1e-6, "m")}
"""Units that are not SI -> (factor, SI unit); every other unit is SI already (or V, 1)."""
UNIFORM = 0.01
"""A time column is uniform when every step lies within this fraction of the mean step (text
files round their times)."""


def is_record(ds: Any) -> bool:
    """Whether ``ds`` is a measured record (its attrs' ``kind`` is ``"record"``)."""
    return str(getattr(ds, "attrs", {}).get("kind", "")) == "record"


def channels(record: xr.Dataset) -> list[str]:
    """The record's channel names (its data variables over ``t`` but the speed)."""
    return [str(n) for n, v in record.data_vars.items() if n != SPEED and v.dims == ("t",)]


def _listing(record: xr.Dataset) -> str:
    out = []
    for name in channels(record):
        original = str(record[name].attrs.get("original_name", name))
        out.append(name if original == name else f"{name} ({original})")
    return ", ".join(out)


def pick_channel(record: xr.Dataset, pattern: str | None, field: str = "channel") -> str:
    """The channel ``pattern`` names: a channel's name, or its file's name, exactly (either
    case), or a glob (``*DE*``) or a substring of either, case-insensitive, that only one
    channel matches (``DE`` picks ``X105_DE_time``'s channel). With None: the only channel.
    ``InputError`` naming ``field`` (the parameter that gave ``pattern``: ``channel``,
    ``tacho``) and listing the channels otherwise."""
    names = channels(record)
    where = f" in '{record.attrs['source_file']}'" if "source_file" in record.attrs else ""
    if pattern is None:
        if len(names) == 1:
            return names[0]
        # no value given: the command line names no option from a field, so the line does
        raise InputError(f"--{field}: this record has {len(names)} channels; give one of "
                         f"{_listing(record)}")
    text = str(pattern).strip()
    pairs = [(n, str(record[n].attrs.get("original_name", n))) for n in names]
    tests = (lambda n, o: text in (n, o),
             lambda n, o: text.lower() in (n.lower(), o.lower()),
             lambda n, o: any(fnmatch.fnmatch(s.lower(), text.lower()) for s in (n, o)),
             lambda n, o: any(text.lower() in s.lower() for s in (n, o)))
    for test in tests:
        found = [n for n, o in pairs if test(n, o)]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise InputError(f"{field}: {text!r} matches {len(found)} channels{where} "
                             f"({', '.join(found)}); give one of {_listing(record)}",
                             field=field)
    raise InputError(f"{field}: no channel {text!r}{where}; channels: {_listing(record)}",
                     field=field)


def record_speed_hz(record: xr.Dataset) -> float | None:
    """The record's mean shaft speed (Hz): of its speed over ``t`` where it has one, else
    its ``speed_rpm`` attr; None where the record has no speed (give ``--rpm`` or
    ``--tacho``)."""
    if SPEED in record.data_vars:
        return float(np.mean(record[SPEED].values)) / 60.0
    if "speed_rpm" in record.attrs:
        return float(record.attrs["speed_rpm"]) / 60.0
    return None


def to_si(record: xr.Dataset, channel: str) -> tuple[np.ndarray, str]:
    """A channel's values in SI units and that unit: g -> m/s^2 (x 9.80665), um -> m
    (x 1e-6); other units as they are (m/s^2, m/s, m; V and 1 have no SI form)."""
    name = pick_channel(record, channel)
    units = str(record[name].attrs.get("units", "1"))
    factor, si = TO_SI.get(units, (1.0, units))
    return np.asarray(record[name].values, dtype=float) * factor, si


# ------------------------------------------------------------------------- reading


def sha256_of(path: Path) -> str:
    """The sha256 of a file's bytes (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _positive(value: Any, name: str, unit: str, *, field: str | None = None) -> float:
    """``value`` as a float > 0 (``unit``), or ``InputError`` naming ``name`` (the
    parameter ``field``, when it is one)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not (math.isfinite(number) and number > 0):
        raise InputError(f"{name}: must be a finite number > 0 {unit}, got {value}",
                         field=field)
    return number


def _check_file(path: Path) -> None:
    from modelgen.locations import broken_link

    if not path.exists():
        raise InputError(f"record: '{path}' {broken_link(path) or 'does not exist'}")
    if path.is_dir():
        raise InputError(f"record: '{path}' is a folder, not a result file or a measured "
                         "record (diagnose takes a folder of records)")
    if not path.is_file():
        raise InputError(f"record: '{path}' is not a plain file")


def read_record(path: str | Path, *, fs: float | None = None, channel: str | None = None,
                rpm: float | str | None = None, tacho: str | None = None,
                scale: float | None = None, units: str | None = None) -> xr.Dataset:
    """The measured record in the file at ``path`` (a reader by suffix: CSV/TSV, WAV, MAT,
    UFF, TDMS, netCDF; see ``analysis.measured.readers``).

    ``fs``: the sampling rate (Hz) of a file that states none (a CSV without a time
    column, a MAT-file without a rate; a rate the file name states, ``12k_…``, is replaced
    by it; a rate the file itself states must agree). ``channel``: keep only that channel
    (and the tacho), by name or pattern (:func:`pick_channel`). ``rpm``: the shaft speed
    (rpm), or the path of a speed table (CSV ``t_s,speed_rpm``, as ``simulate
    --speed-rpm`` reads it); ``tacho``: the channel of a once-per-revolution tacho, whose
    pulses give the speed (not with ``rpm``). Either replaces a speed the file notes.
    ``scale``: every channel's values are multiplied by it (units per full scale for a WAV
    file, whose integer samples are first scaled to [-1, 1)); ``units``: the channels'
    units (one of ``analysis.measured.readers.UNITS``).

    Every problem is one ``InputError`` naming the file or the parameter (with its
    ``field``); a missing rate says ``give --fs HZ``. A record without a speed is returned
    without one (:func:`record_speed_hz` None): the analyses that need it say ``give --rpm
    or --tacho``."""
    path = Path(path)
    fs = None if fs is None else _positive(fs, "fs", "Hz", field="fs")
    scale = None if scale is None else _nonzero_scale(scale)
    units = None if units is None else unit_of(units, "units", field="units")
    if rpm is not None and tacho is not None:
        raise InputError("tacho: give --rpm or --tacho, not both", field="tacho")
    table = None if rpm is None else _speed_given(rpm)
    _check_file(path)
    raw = reader_for(path)(path)
    rate, rate_source = _rate(raw, fs, path)
    record = _dataset(raw, rate, rate_source, path, scale, units)
    if channel is not None:
        keep = [pick_channel(record, channel)]
        if tacho is not None:
            keep.append(pick_channel(record, tacho, "tacho"))
        record = record[list(dict.fromkeys(keep)) + ([SPEED] if SPEED in record else [])]
    return _with_speed(record, raw, table, tacho)


def _nonzero_scale(scale: Any) -> float:
    try:
        number = float(scale)
    except (TypeError, ValueError):
        number = math.nan
    if not math.isfinite(number) or number == 0:
        raise InputError(f"scale: must be a finite number other than 0, got {scale!r}",
                         field="scale")
    return number


def _speed_given(rpm: float | str) -> Any:
    """``rpm``: a speed (rpm, a number) or a speed table (``SpeedProfile`` of a CSV); a
    table's errors name ``rpm``, the parameter that gave it."""
    if isinstance(rpm, str):
        try:
            number = float(rpm)
        except ValueError:
            from analysis.integrate.speed_profile import read_table

            try:
                return read_table(rpm)
            except InputError as exc:
                if exc.field != "speed_rpm":
                    raise
                raise InputError("rpm" + str(exc)[len(exc.field):], field="rpm") from None
        return _positive(number, "rpm", "rpm", field="rpm") \
            if math.isfinite(number) and number > 0 else _positive(rpm, "rpm", "rpm", field="rpm")
    return _positive(rpm, "rpm", "rpm", field="rpm")


def _rate(raw: Raw, fs: float | None, path: Path) -> tuple[float, str]:
    """The sampling rate (Hz) and where it came from: the file's own (``fs`` must agree),
    ``--fs``, or the file name's (replaced by ``--fs``)."""
    if raw.t is not None:
        t = np.asarray(raw.t, dtype=float)
        if t.size < 2:
            raise InputError(f"record: '{path}' holds {t.size} sample(s); a record needs at "
                             "least 2")
        steps = np.diff(t)
        step = (t[-1] - t[0]) / (t.size - 1)
        if not (math.isfinite(step) and step > 0) or np.max(np.abs(steps - step)) > UNIFORM \
                * step:
            raise InputError(f"record: '{path}': its times are not uniformly spaced "
                             f"(increasing, each step within {UNIFORM:.0%} of the mean); a "
                             "record is sampled at one rate")
        raw.fs = 1.0 / step
        if t[0] != 0:
            raw.attrs["time_offset_s"] = float(t[0])  # the record's t starts at 0
    stated = raw.fs is not None and not raw.fs_source.startswith("file name")
    if stated:
        rate = _positive(raw.fs, f"record: '{path}': its sampling rate", "Hz")
        if fs is not None and abs(fs - rate) > 1e-6 * rate:
            raise InputError(f"fs: the file states {rate:g} Hz ({raw.fs_source}), got "
                             f"--fs {fs:g}; leave --fs out", field="fs")
        return rate, raw.fs_source
    if fs is not None:
        return fs, "--fs"
    if raw.fs is not None:
        return float(raw.fs), raw.fs_source
    raise InputError(f"record: '{path}' states no sampling rate; give --fs HZ")


def _dataset(raw: Raw, rate: float, rate_source: str, path: Path, scale: float | None,
             units: str | None) -> xr.Dataset:
    lengths = {c.name: c.values.size for c in raw.channels}
    if len(set(lengths.values())) != 1:
        raise InputError(f"record: '{path}': its channels have different lengths "
                         f"({', '.join(f'{k} {v}' for k, v in lengths.items())}); a record's "
                         "channels are sampled together")
    n = next(iter(lengths.values()))
    if n < 2:
        raise InputError(f"record: '{path}' holds {n} sample(s); a record needs at least 2")
    names = [c.name for c in raw.channels]
    if len(set(names)) != len(names):
        raise InputError(f"record: '{path}': two channels share a name ({', '.join(names)})")
    data = {c.name: _variable(c, path, scale, units) for c in raw.channels}
    attrs = {"kind": "record", "sample_rate_hz": float(rate),
             "sample_rate_source": rate_source, "source_file": str(path),
             "sha256": sha256_of(path), "reader": raw.reader,
             "original_names": json.dumps([c.original_name or c.name for c in raw.channels])}
    for key, value in raw.attrs.items():
        if key not in attrs:
            attrs[key] = value
    if scale is not None:
        attrs["scale"] = scale
    if raw.attrs.get("kind") == "record":  # a saved record: its own provenance is kept
        attrs.update({k: raw.attrs[k] for k in ("source_file", "sha256", "reader",
                                                 "original_names", "sample_rate_source")
                      if k in raw.attrs})
        attrs.update(saved_file=str(path), saved_sha256=sha256_of(path))
    return xr.Dataset(data, coords={"t": ("t", np.arange(n) / rate, {"units": "s"})},
                      attrs=attrs)


def _variable(c: Channel, path: Path, scale: float | None, units: str | None):
    values = np.asarray(c.values, dtype=np.float64)
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise InputError(f"record: '{path}': channel {c.name} holds {bad} values that are "
                         "not finite numbers (NaN or infinite)")
    if scale is not None:
        values = values * scale
    unit = units or unit_of(c.units, f"record: '{path.name}' channel {c.name}")
    return ("t", values, {"units": unit, "long_name": c.long_name or c.name,
                          "original_name": c.original_name or c.name})


# ------------------------------------------------------------------------- speed


def _with_speed(record: xr.Dataset, raw: Raw, table: Any, tacho: str | None) -> xr.Dataset:
    """The record with its speed: ``--rpm`` (a number or a table), ``--tacho``, the file's
    (a noted speed, or a saved record's), each checked (finite, > 0)."""
    if table is not None or tacho is not None:
        record = record.drop_vars(SPEED, errors="ignore")
        for key in ("speed_rpm", "speed_source", "tacho_channel", "tacho_pulses",
                    "speed_table_t", "speed_table_rpm", "speed_table_file"):
            record.attrs.pop(key, None)
    if isinstance(table, float):
        record.attrs.update(speed_rpm=table, speed_source="--rpm")
    elif table is not None:
        record = _speed_table(record, table)
    elif tacho is not None:
        record = tacho_speed(record, pick_channel(record, tacho, "tacho"))
    elif raw.speed_curve is not None:
        record[SPEED] = ("t", raw.speed_curve, {"units": "rpm"})
    elif raw.speed_rpm is not None:
        speed = raw.speed_rpm
        if not (math.isfinite(speed) and speed > 0):
            raise InputError(f"record: '{record.attrs['source_file']}': its speed "
                             f"{raw.speed_name} is {speed:g} rpm; give the speed with --rpm "
                             "or --tacho")
        record.attrs.update(speed_rpm=float(speed), speed_source=f"file: {raw.speed_name}")
    if SPEED in record.data_vars:
        speeds = record[SPEED].values
        if not np.all(np.isfinite(speeds) & (speeds > 0)):
            raise InputError(f"record: '{record.attrs['source_file']}': its speed over t is "
                             "not a finite number > 0 rpm everywhere; give --rpm or --tacho")
    elif "speed_rpm" in record.attrs:
        _positive(record.attrs["speed_rpm"], "record: speed_rpm", "rpm")
    return record


def _speed_table(record: xr.Dataset, profile: Any) -> xr.Dataset:
    """The record with the speed of a table (``SpeedProfile``), which must cover it."""
    t = record["t"].values
    times, rpm = profile.knots(float(t[-1]))
    if times[-1] < t[-1] * (1 - 1e-9):
        raise InputError(f"rpm: the speed table's last t_s ({times[-1]:g} s) must reach the "
                         f"end of the record ({t[-1]:g} s)", field="rpm")
    record[SPEED] = ("t", np.interp(t, times, rpm), {"units": "rpm"})
    record.attrs.update(speed_rpm=float(np.mean(record[SPEED].values)),
                        speed_source="speed table", speed_table_t=times, speed_table_rpm=rpm,
                        speed_table_file=str(profile.source))
    return record


def tacho_pulses(values: np.ndarray, fs: float) -> np.ndarray:
    """The times (s) of a tacho's pulses: its rising edges through 70 % of its range after
    it fell below 30 % (a Schmitt trigger, so noise on a level does not count twice), each
    interpolated between the two samples around it."""
    x = np.asarray(values, dtype=float)
    low, high = float(np.min(x)), float(np.max(x))
    if not high > low:
        return np.zeros(0)
    lo, hi = low + 0.3 * (high - low), low + 0.7 * (high - low)
    state = np.where(x >= hi, 1, np.where(x <= lo, 0, -1))
    known = np.where(state >= 0, np.arange(x.size), 0)
    np.maximum.accumulate(known, out=known)
    held = state[known]
    k = np.flatnonzero((held[1:] == 1) & (held[:-1] == 0)) + 1
    before = x[k - 1]
    fraction = np.clip((hi - before) / np.where(x[k] > before, x[k] - before, 1.0), 0, 1)
    return (k - 1 + fraction) / fs


IRREGULAR = 0.25
"""Largest median change of a tacho's interval from one revolution to the next: more is not
a shaft (noise crossing the trigger levels at random)."""


def tacho_speed(record: xr.Dataset, channel: str) -> xr.Dataset:
    """The record with the speed of its once-per-revolution tacho ``channel``: 60/(time
    between pulses) rpm, at the middle of each interval and linear in between (continued
    along the first and last intervals' trend beyond them). ``InputError`` for a tacho with
    fewer than two pulses, or pulses whose intervals jump by more than :data:`IRREGULAR`
    from one to the next (in the median: not a shaft)."""
    fs = float(record.attrs["sample_rate_hz"])
    pulses = tacho_pulses(record[channel].values, fs)
    if pulses.size < 2:
        raise InputError(f"tacho: channel {channel} has {pulses.size} pulse(s) (rising "
                         "edges through 70 % of its range); a once-per-revolution tacho needs "
                         "at least two", field="tacho")
    intervals = np.diff(pulses)
    if intervals.size > 2:  # a shaft's speed changes little from one turn to the next
        jumps = float(np.median(np.abs(np.diff(intervals)) / intervals[:-1]))
        if jumps > IRREGULAR:
            raise InputError(f"tacho: channel {channel}'s {pulses.size} pulses are not "
                             f"regular (successive intervals differ by {jumps:.0%} in the "
                             "median); is it a once-per-revolution tacho?", field="tacho")
    middle = 0.5 * (pulses[1:] + pulses[:-1])
    rpm = 60.0 / intervals
    record[SPEED] = ("t", _extended(record["t"].values, middle, rpm), {"units": "rpm"})
    mean = 60.0 * (pulses.size - 1) / float(pulses[-1] - pulses[0])
    record.attrs.update(speed_rpm=mean, speed_source=f"tacho: {channel}",
                        tacho_channel=channel, tacho_pulses=int(pulses.size))
    return record


def _extended(t: np.ndarray, middle: np.ndarray, rpm: np.ndarray) -> np.ndarray:
    """The speed (rpm) at times ``t``: linear between the intervals' middles, and beyond the
    first and last middle along the line through the nearest (up to) 5 intervals' speeds,
    held at no less than half the edge speed (a run-up's speed before the second pulse)."""
    out = np.interp(t, middle, rpm)
    if middle.size < 3:
        return out
    for side, edge in ((t < middle[0], slice(0, 5)), (t > middle[-1], slice(-5, None))):
        slope, offset = np.polyfit(middle[edge], rpm[edge], 1)
        floor = 0.5 * float(rpm[edge][0 if edge.start == 0 else -1])
        out[side] = np.maximum(slope * t[side] + offset, floor)
    return out


def speed_words(record: xr.Dataset) -> str:
    """``1797 rpm (file: X105RPM)``, ``1200…1800 rpm, mean 1500 (tacho: TACHO)``, or
    ``none in the file (give --rpm or --tacho)``."""
    if SPEED in record.data_vars:
        s = record[SPEED].values
        return (f"{float(s.min()):.0f}…{float(s.max()):.0f} rpm, mean "
                f"{float(record.attrs.get('speed_rpm', s.mean())):.0f} rpm "
                f"({record.attrs.get('speed_source', '?')})")
    if "speed_rpm" in record.attrs:
        return (f"{float(record.attrs['speed_rpm']):g} rpm "
                f"({record.attrs.get('speed_source', '?')})")
    return "none in the file (give --rpm or --tacho)"


def needs_speed(record: xr.Dataset, what: str) -> float:
    """The record's mean shaft speed (Hz), or ``InputError``: ``what`` needs one."""
    speed = record_speed_hz(record)
    if speed is None:
        raise InputError(f"{what}: '{record.attrs.get('source_file', 'the record')}' has no "
                         "shaft speed; give --rpm or --tacho")
    return speed


def record_summary(record: xr.Dataset) -> dict[str, Any]:
    """What ``bearingdyn record info`` shows, in plain JSON types: the file read and the one
    the record came from (a saved record's original), the rate and its source, samples and
    duration (s), the speed (rpm, its source; None without one), each channel (name, units,
    original name, rms, min, max in its units) and the provenance."""
    from analysis.provenance import plain

    n = record.sizes["t"]
    rate = float(record.attrs["sample_rate_hz"])
    speed = record_speed_hz(record)
    read = record.attrs.get("saved_file", record.attrs.get("source_file"))
    out = {"file": str(read), "source_file": str(record.attrs.get("source_file")),
           "sample_rate_hz": rate,
           "sample_rate_source": str(record.attrs.get("sample_rate_source", "")),
           "samples": int(n), "duration_s": n / rate, "speed": speed_words(record),
           "speed_rpm": None if speed is None else 60.0 * speed,
           "speed_source": record.attrs.get("speed_source"), "channels": []}
    for name in channels(record):
        values = np.asarray(record[name].values, dtype=float)
        attrs = record[name].attrs
        out["channels"].append({
            "name": name, "units": str(attrs.get("units", "1")),
            "original_name": str(attrs.get("original_name", name)),
            "long_name": str(attrs.get("long_name", name)),
            "rms": float(np.sqrt(np.mean((values - values.mean()) ** 2))),
            "min": float(values.min()), "max": float(values.max())})
    out.update({"sha256": record.attrs.get("sha256"), "reader": record.attrs.get("reader"),
                "original_names": json.loads(str(record.attrs.get("original_names", "[]"))),
                "provenance": {str(k): plain(v) for k, v in record.attrs.items()}})
    return out


__all__ = ["SPEED", "channels", "is_record", "needs_speed", "pick_channel", "read_record",
           "record_speed_hz", "record_summary", "speed_words", "tacho_pulses", "tacho_speed",
           "to_si"]
