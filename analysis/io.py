"""Result files: netCDF (HDF5 via h5netcdf), written atomically and read with clear errors."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import xarray as xr

from analysis.errors import InputError, WriteError

FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff",
                   ".webp")
"""Figure files matplotlib writes, by suffix."""
NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf", ".h5")
"""Result files (netCDF-4 on HDF5)."""


def check_output(path: str | Path, suffixes: tuple[str, ...] | None = None,
                 what: str = "output") -> Path:
    """Raise ``InputError`` (naming ``what``) unless a file can be written at ``path``: a
    known suffix (when ``suffixes`` is given), a name the file system takes, an existing
    writable folder, and nothing there but (at most) a plain file, which is replaced.

    Checked before any work is done, so a refused output costs nothing."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    limit = _name_max(folder) - 24  # the temporary name adds a prefix and a suffix
    if len(os.fsencode(path.name)) > limit:
        raise InputError(f"{what}: the file name is {len(os.fsencode(path.name))} bytes "
                         f"long; at most {limit} here")
    if path.is_dir():
        raise InputError(f"{what}: '{path}' is a folder; give a file name")
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise InputError(f"{what}: '{path.name}' must end in one of {', '.join(suffixes)}"
                         f"{f', got {path.suffix!r}' if path.suffix else ' (no suffix given)'}")
    if os.path.lexists(path) and not path.is_file():
        raise InputError(f"{what}: '{path}' exists and is not a plain file (a pipe, device "
                         "or broken link); give another name")
    if not folder.is_dir():
        raise InputError(f"{what}: folder '{folder}' does not exist")
    if not os.access(folder, os.W_OK):
        raise InputError(f"{what}: folder '{folder}' is not writable")
    return path


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``.

    A crash, a full disk or Ctrl-C mid-write leaves at most nothing: the temporary file is
    removed and a file already at ``path`` is kept as it was.
    """
    path = check_output(path)
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise InputError(f"output: cannot write in '{folder}' ({exc.strerror})") from None
    os.close(fd)
    try:
        try:
            write(Path(tmp))
        except OSError as exc:
            raise WriteError(f"output: could not write '{path}' "
                             f"({exc.strerror or exc}); nothing was changed there") from None
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
