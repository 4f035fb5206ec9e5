"""Readers of measured records: one small module per file format, each an adapter from its
library into one channel description (``Raw``: names, units, values, rate), and the table
``READERS`` (file suffix -> reader) that ``analysis.measured.records.read_record`` looks up.

A reader is a function ``read(path) -> Raw``; it raises ``InputError`` naming the
file for a file it cannot read. It reports the rate the file states (None where it states
none) and where it comes from; it does not apply ``--fs``, ``--scale`` or ``--units``,
judge the speed or build the Dataset: that is ``records``'s, the same for every format."""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError

UNITS = ("g", "m/s^2", "m/s", "m", "um", "V", "1")
"""The units a channel may carry: acceleration in g or m/s², velocity m/s, displacement m or
µm (``um``), a voltage (V, unscaled), or ``1`` (a number whose unit the file does not say)."""

UNIT_ALIASES = {"m/s2": "m/s^2", "m/s²": "m/s^2", "ms^-2": "m/s^2", "µm": "um", "μm": "um",
                "micron": "um", "microns": "um", "volt": "V", "volts": "V",
                "v": "V", "": "1", "-": "1", "none": "1", "g": "g", "gs": "g"}


def unit_of(text: Any, where: str, *, field: str | None = None) -> str:
    """``text`` as one of :data:`UNITS` (aliases such as ``m/s2``, ``µm`` accepted), or
    ``InputError`` naming ``where`` (the parameter ``units``, a file's channel; ``field``:
    ``where`` when it is a parameter)."""
    raw = "" if text is None else str(text).strip()
    unit = raw if raw in UNITS else UNIT_ALIASES.get(raw.lower(), raw)
    if unit not in UNITS:
        raise InputError(f"{where}: units must be one of {', '.join(UNITS)}, got {raw!r}",
                         field=field)
    return unit


@dataclass
class Channel:
    """One channel as its file holds it: ``name`` (the channel's short name, a valid
    identifier), ``values`` (1-D), ``units`` (one of :data:`UNITS`, None where the file does
    not say), a longer description and the name the file gives it (``X105_DE_time``;
    default: ``name``)."""

    name: str
    values: np.ndarray
    units: str | None = None
    long_name: str = ""
    original_name: str = ""


@dataclass
class Raw:
    """What a reader found in a file: its channels, the reader (the library function), the
    sampling rate (Hz; None where the file has none) and where it came from, a time column
    (s) where the file gives times instead of a rate, a speed (rpm) the file notes and the
    name it has there, and any other attributes to keep (a saved record's: its provenance)."""

    channels: list[Channel]
    reader: str
    fs: float | None = None
    fs_source: str = ""
    t: np.ndarray | None = None
    speed_rpm: float | None = None
    speed_name: str = ""
    attrs: dict[str, Any] = field(default_factory=dict)
    speed_curve: np.ndarray | None = None
    """The speed (rpm) at each sample, where the file holds one (a record saved with a
    speed table or a tacho's speed)."""


Reader = Callable[[Path], Raw]

READERS: dict[str, str] = {
    ".csv": "delimited", ".tsv": "delimited", ".txt": "delimited",
    ".wav": "wav",
    ".mat": "matlab",
    ".uff": "uff", ".unv": "uff",
    ".tdms": "tdms",
    ".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf", ".h5": "netcdf",
}
"""File suffix -> the module of ``analysis.measured.readers`` whose ``read`` reads it."""


def reader_for(path: Path) -> Reader:
    """The ``read`` function of ``path``'s suffix; ``InputError`` naming the suffixes read."""
    module = READERS.get(path.suffix.lower())
    if module is None:
        raise InputError(f"record: '{path}' has a suffix ({path.suffix or 'none'}) no reader "
                         f"knows; records are read from {', '.join(READERS)}")
    return importlib.import_module(f"analysis.measured.readers.{module}").read


def missing_library(module: str, path: Path) -> InputError:
    """The error for a reader whose library is not installed: the install line."""
    return InputError(f"record: reading '{path.name}' needs the Python package {module}; "
                      "install it with python3 -m pip install -e '.[measured]'")


def unreadable(path: Path, what: str, exc: BaseException) -> InputError:
    """The error for a file its library could not read (damaged, truncated, another kind)."""
    text = " ".join(str(exc).split())[:160] or type(exc).__name__
    return InputError(f"record: '{path}' is not a readable {what} file ({text})")


def identifier(name: str) -> str:
    """A channel's name made a valid identifier: ``Acc 1 [g]`` -> ``Acc_1_g``."""
    text = re.sub(r"\W+", "_", str(name).strip()).strip("_")
    if not text:
        return "channel"
    return f"c_{text}" if text[0].isdigit() else text


def rate_from_name(path: Path) -> float | None:
    """The sampling rate a file name states at its start, as the CWRU data set names its
    files (``12k_Drive_End_IR007_0_105.mat``: 12 000 Hz; ``48k_…``: 48 000 Hz); None
    otherwise."""
    found = re.match(r"^(\d+(?:\.\d+)?)k(?:hz)?[_\- ]", path.name, re.I)
    return float(found.group(1)) * 1e3 if found else None


def as_column(values: Any, name: str, path: Path) -> np.ndarray:
    """A channel's values as a 1-D float64 array (a column or row vector flattened);
    ``InputError`` for a matrix or text."""
    array = np.asarray(values)
    if array.dtype.kind not in "biuf":
        raise InputError(f"record: '{path.name}': {name} holds {array.dtype} values, not "
                         "numbers")
    if array.ndim > 1 and sorted(array.shape)[-2] != 1:
        raise InputError(f"record: '{path.name}': {name} is a {array.shape} array; a channel "
                         "is one column")
    return array.astype(np.float64).ravel()
