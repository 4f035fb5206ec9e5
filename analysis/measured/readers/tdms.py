"""TDMS records (National Instruments; ``npTDMS``): each numeric channel is a channel,
named by its channel name (``group_channel`` where two groups share one), its rate
1/``wf_increment`` (or a channel ``time``/``t`` of times in s) and its units the
``unit_string`` property where it is one of ``analysis.measured.readers.UNITS``. Install:
``python3 -m pip install -e '.[measured]'``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.measured.readers import (
    UNIT_ALIASES,
    UNITS,
    Channel,
    Raw,
    as_column,
    identifier,
    missing_library,
    unreadable,
)
from analysis.measured.readers.delimited import TIME_NAMES


def _channels(path: Path) -> list:
    try:
        from nptdms import TdmsFile
    except ImportError:
        raise missing_library("npTDMS", path) from None
    try:
        tdms = TdmsFile.read(str(path))
        return [(group.name, channel.name, dict(channel.properties), channel[:])
                for group in tdms.groups() for channel in group.channels()]
    except Exception as exc:  # npTDMS raises many types for a damaged file
        raise unreadable(path, "TDMS", exc) from None


def _units(text: object) -> str | None:
    raw = str(text or "").strip()
    unit = raw if raw in UNITS else UNIT_ALIASES.get(raw.lower())
    return unit if unit in UNITS and unit != "1" else None


def read(path: Path) -> Raw:
    """The numeric channels of a TDMS file (see the module)."""
    found = [(g, c, p, v) for g, c, p, v in _channels(path)
             if np.asarray(v).dtype.kind in "biuf" and np.asarray(v).size > 1]
    if not found:
        raise InputError(f"record: '{path}' holds no numeric channel")
    times = next((np.asarray(v, dtype=float) for _, c, p, v in found
                  if c.lower() in TIME_NAMES and not p.get("wf_increment")), None)
    if times is not None:  # a time channel instead of waveform properties
        found = [f for f in found if f[1].lower() not in TIME_NAMES]
    names = [c for _, c, _, _ in found]
    unique = len(set(names)) == len(names)
    channels, rates = [], set()
    for group, name, props, values in found:
        full = name if unique else f"{group}_{name}"
        increment = props.get("wf_increment")
        rates.add(round(1.0 / float(increment), 9) if increment else None)
        channels.append(Channel(identifier(full), as_column(values, full, path),
                                _units(props.get("unit_string")),
                                str(props.get("NI_ChannelName", f"{group}/{name}")),
                                f"{group}/{name}"))
    if times is not None and rates == {None}:
        return Raw(channels, "nptdms.TdmsFile.read", t=times, fs_source="file: time channel")
    if len(rates) != 1:
        raise InputError(f"record: '{path}': its channels have different sampling rates "
                         f"({', '.join(str(r) for r in rates)} Hz); a record has one")
    rate = rates.pop()
    return Raw(channels, "nptdms.TdmsFile.read", fs=rate,
               fs_source="file: wf_increment" if rate else "")
