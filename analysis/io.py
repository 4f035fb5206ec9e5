"""Result files: netCDF (HDF5 via h5netcdf), written atomically and read with clear errors."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import InputError


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``.

    A crash mid-write leaves at most a ``.tmp`` file, never a half-written result under the
    final name.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise InputError(f"output: '{path}' is a folder; give a file name")
    if not folder.is_dir():
        raise InputError(f"output: folder '{folder}' does not exist")
    if not os.access(folder, os.W_OK):
        raise InputError(f"output: folder '{folder}' is not writable")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise InputError(f"output: cannot write in '{folder}' ({exc.strerror})") from None
    os.close(fd)
    try:
        write(Path(tmp))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # as an ordinary open() would have made it
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise InputError(f"output: cannot write '{path}' ({exc.strerror})") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def save_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to netCDF-4 at ``path`` atomically."""
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))


def open_result(path: str | Path) -> xr.Dataset:
    """Read any bearingdyn result file (run, branch, diagram, chart) into memory."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"result file: '{path}' does not exist")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load()
    except Exception as exc:  # h5py/h5netcdf raise many types for a damaged file
        raise InputError(f"result file: '{path}' is not a readable netCDF file ({exc})") from None


def load_dataset(path: str | Path) -> xr.Dataset:
    """Read a simulation run of any model written by bearingdyn, or raise ``InputError``
    saying why not: it must have ``t`` and every state variable its ``state_names`` attr
    names (``x``, ``y``, ``vx``, ``vy`` for files written before that attr)."""
    from analysis.signal import run_state_names

    data = open_result(path)
    missing = [v for v in run_state_names(data) if v not in data]
    if "t" not in data.coords or missing:
        raise InputError(f"result file: '{path}' is not a bearingdyn run "
                         f"(missing {', '.join(missing) or 't'})")
    return data


def provenance(source: Any) -> dict[str, Any]:
    """The provenance of a result in plain JSON types, the same content as its netCDF attrs:
    ``source`` is a result (``xarray`` object: its attrs), a mapping of attrs, or a
    ``System`` (then ``analysis.integrate.simulate.run_attrs`` of it: the model, spec path
    and sha256, balls per bearing, every parameter value, the frequencies and the versions,
    exactly what ``simulate`` writes for that system before the run's own settings), or the
    path of a result file (its attrs, read without its data)."""
    from analysis.model import System

    if isinstance(source, (str, Path)):
        if not Path(source).is_file():
            raise InputError(f"result file: '{source}' does not exist")
        with xr.open_dataset(source, engine="h5netcdf") as ds:
            attrs: Mapping = dict(ds.attrs)
    elif isinstance(source, System):
        from analysis.integrate.simulate import run_attrs

        attrs = run_attrs(source.model, source.structure, dict(source.parameters))
    else:
        attrs = getattr(source, "attrs", source)
    return {str(key): _plain(value) for key, value in attrs.items()}


def _plain(value: Any) -> Any:
    """A netCDF attribute value as a JSON value (numpy scalars and arrays to Python)."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes):
        return value.decode()
    return value
