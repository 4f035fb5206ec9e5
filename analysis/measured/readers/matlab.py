"""MATLAB records: v4, v5, v7 and v7.2 files (``scipy.io.loadmat``) and v7.3 files (HDF5,
``h5py``; MATLAB stores an array transposed there).

Each numeric vector is a channel. The CWRU bearing data's variables are understood
(https://engineering.case.edu/bearingdatacenter): ``X105_DE_time``, ``X105_FE_time`` and
``X105_BA_time`` are the drive-end, fan-end and base accelerometers in g (channels ``DE``,
``FE``, ``BA``), and ``X105RPM`` the motor speed noted during the test. A few CWRU files
hold a second record's variables too (``X098_DE_time`` beside ``X099_DE_time``): the record
the file name ends with (``…_099.mat``) keeps the short names and its speed, the other its
full names. A scalar ``fs``, ``Fs``,
``sample_rate`` or ``sampling_rate`` gives the rate in Hz; without one the rate is
``--fs``, or the one the file name states at its start (``12k_…``: 12 000 Hz, as the CWRU
files are named)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError
from analysis.measured.readers import (
    Channel,
    Raw,
    as_column,
    identifier,
    rate_from_name,
    unreadable,
)

CWRU_CHANNEL = re.compile(r"^X(\d+)_(DE|FE|BA)_time$")
CWRU_SPEED = re.compile(r"^X(\d+)RPM$|^rpm$|^RPM$|^speed_rpm$")
RATE_NAMES = ("fs", "Fs", "FS", "sample_rate", "sampling_rate", "sample_rate_hz")
CWRU_PLACES = {"DE": "drive-end accelerometer", "FE": "fan-end accelerometer",
               "BA": "base accelerometer"}


def _load(path: Path) -> tuple[dict[str, Any], str]:
    """The file's variables (name -> array) and the reader used."""
    import scipy.io
    from scipy.io.matlab import matfile_version

    try:
        major, _ = matfile_version(str(path))
    except Exception as exc:  # too short, not a MAT-file header
        raise unreadable(path, "MATLAB", exc) from None
    if major == 2:
        return _load_hdf5(path), "h5py (MATLAB v7.3)"
    try:
        data = scipy.io.loadmat(str(path), squeeze_me=False, mat_dtype=False)
    except Exception as exc:  # scipy raises many types for a damaged file
        raise unreadable(path, "MATLAB", exc) from None
    return {k: v for k, v in data.items() if not k.startswith("__")}, "scipy.io.loadmat"


def _load_hdf5(path: Path) -> dict[str, Any]:
    import h5py

    out: dict[str, Any] = {}
    try:
        with h5py.File(path, "r") as f:
            for name, item in f.items():
                if name.startswith("#") or not isinstance(item, h5py.Dataset):
                    continue
                kind = item.attrs.get("MATLAB_class", b"")
                kind = kind.decode() if isinstance(kind, bytes) else str(kind)
                if kind in ("char", "cell", "struct", "logical"):
                    continue
                out[name] = np.asarray(item[()]).T  # MATLAB's column-major order
    except Exception as exc:
        raise unreadable(path, "MATLAB v7.3 (HDF5)", exc) from None
    return out


def record_number(path: Path) -> int | None:
    """The CWRU record number a file name ends with (``…_0_105.mat``: 105), or None."""
    found = re.search(r"_(\d+)$", path.stem)
    return int(found.group(1)) if found else None


def _ours(name: str, number: int | None) -> bool:
    """Whether a CWRU variable (``X105_DE_time``, ``X105RPM``) is of record ``number``."""
    found = re.match(r"^X(\d+)", name)
    return found is not None and number is not None and int(found.group(1)) == number


def _short_names(names: list[str], number: int | None) -> dict[str, str]:
    """Each channel variable's channel name: DE/FE/BA for CWRU names unless two share one;
    then the file's own record (``number``, from its name) keeps the short name and the
    other (a few CWRU files hold a second record's variables too) its full name."""
    short = {}
    for name in names:
        found = CWRU_CHANNEL.match(name)
        short[name] = found.group(2) if found else identifier(name)
    out = {}
    for name, value in short.items():
        sharing = [n for n, v in short.items() if v == value]
        own = [n for n in sharing if _ours(n, number)]
        keep = len(sharing) == 1 or own == [name]
        out[name] = value if keep else identifier(name)
    return out


def read(path: Path) -> Raw:
    """The vector variables of a MAT-file as channels, its speed and rate where it notes
    them (see the module)."""
    variables, reader = _load(path)
    number = record_number(path)
    speed, speed_name, rate, vectors = None, "", None, {}
    for name, value in variables.items():
        array = np.asarray(value)
        if array.dtype.kind not in "biuf" or array.size == 0:
            continue
        if array.size == 1:
            if CWRU_SPEED.match(name) and (speed is None or _ours(name, number)):
                speed, speed_name = float(array.ravel()[0]), name
            elif name in RATE_NAMES:
                rate = float(array.ravel()[0])
            continue
        if array.ndim <= 2 and min(array.shape, default=1) == 1:
            vectors[name] = as_column(array, name, path)
    if not vectors:
        raise InputError(f"record: '{path}' holds no numeric vector (no channel); "
                         f"variables: {', '.join(variables) or 'none'}")
    short = _short_names(list(vectors), number)
    channels = []
    for name, values in vectors.items():
        found = CWRU_CHANNEL.match(name)
        units = "g" if found else None
        long_name = (f"{CWRU_PLACES[found.group(2)]} (CWRU record {found.group(1)})"
                     if found else name)
        channels.append(Channel(short[name], values, units, long_name, name))
    raw = Raw(channels, reader, speed_rpm=speed, speed_name=speed_name)
    from_name = rate_from_name(path)
    if rate is not None:
        raw.fs, raw.fs_source = rate, "file: fs variable"
    elif from_name is not None:
        raw.fs, raw.fs_source = from_name, f"file name: {path.name.split('_')[0]}"
    return raw
