"""Result files: netCDF (HDF5 via h5netcdf), written atomically and read with clear errors."""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from analysis.errors import InputError, Interrupt, WriteError

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


def _reason(exc: OSError) -> str:
    """Why a write failed, in a few words: 'File too large', 'No space left on device'."""
    if exc.errno:
        return os.strerror(exc.errno)
    text = " ".join(str(exc).split())
    found = re.search(r"errno = (\d+)", text)  # HDF5 names the errno inside its message
    return os.strerror(int(found.group(1))) if found else text[:120]


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def check_space(folder: Path, size: int, path: Path) -> None:
    """``WriteError`` when a file of about ``size`` bytes cannot be written in ``folder``:
    less free space on its file system, or a smaller file-size limit (``ulimit -f``), than
    ``size`` plus a margin. Checked before the write starts: HDF5 does not recover well from
    a disk that fills up under it."""
    import resource
    import shutil

    need = int(size * 1.05) + 2**20
    free = shutil.disk_usage(folder).free
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    room = min(free, limit if limit != resource.RLIM_INFINITY else free)
    if need > room:
        what = "free on its disk" if room == free else "allowed per file (ulimit -f)"
        raise WriteError(f"output: '{path}' needs about {need / 2**20:.1f} MiB and "
                         f"{room / 2**20:.1f} MiB are {what}; nothing was written")


def atomic_write(path: str | Path, write: Callable[[Path], None],
                 size: int | None = None) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, then rename it to ``path``.

    A crash, a full disk or Ctrl-C mid-write leaves at most nothing: the temporary file is
    removed and a file already at ``path`` is kept as it was. ``size``: the expected bytes,
    checked against the free space first (``check_space``).
    """
    path = check_output(path)
    folder = path.parent if str(path.parent) else Path(".")
    if size is not None:
        check_space(folder, size, path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise InputError(f"output: cannot write in '{folder}' ({exc.strerror})") from None
    os.close(fd)
    try:
        try:
            write(Path(tmp))
        except OSError as exc:
            raise WriteError(f"output: could not write '{path}' ({_reason(exc)}); nothing "
                             "was changed there") from None
        Interrupt.check()  # an interruption the writer swallowed: no rename
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
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"),
                        size=ds.nbytes)


def open_result(path: str | Path) -> xr.Dataset:
    """Read any bearingdyn result file (run, branch, diagram, chart) into memory: netCDF-4
    (what bearingdyn writes) or netCDF-3 (classic, 64-bit offset)."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"result file: '{path}' is a folder, not a result file")
    if not path.exists():
        raise InputError(f"result file: '{path}' does not exist")
    if not path.is_file():
        raise InputError(f"result file: '{path}' is not a plain file (a pipe or device)")
    try:
        with xr.open_dataset(path, engine=_engine(path)) as ds:
            return ds.load()
    except Exception as exc:  # h5py/h5netcdf/scipy raise many types for a damaged file
        text = " ".join(str(exc).split())[:200]
        raise InputError(f"result file: '{path}' is not a readable netCDF file ({text})") from None


def _engine(path: Path) -> str:
    """The xarray engine of a netCDF file: scipy for netCDF-3 (classic), h5netcdf else."""
    with open(path, "rb") as handle:
        return "scipy" if handle.read(3) == b"CDF" else "h5netcdf"


RUN_ATTRS_NONNEGATIVE = ("shaft_hz", "speed_rpm")
"""Attributes of a run that must be finite numbers >= 0 when present."""


def load_dataset(path: str | Path) -> xr.Dataset:
    """Read a simulation run of any model written by bearingdyn, or raise ``InputError``
    saying why not: it must have ``t`` and every state variable its ``state_names`` attr
    names (``x``, ``y``, ``vx``, ``vy`` for files written before that attr), and pass
    ``check_run``."""
    from analysis.signal import run_state_names

    data = open_result(path)
    missing = [v for v in run_state_names(data) if v not in data]
    if "t" not in data.coords or missing:
        raise InputError(f"result file: '{path}' is not a bearingdyn run "
                         f"(missing {', '.join(missing) or 't'})")
    check_run(data, path)
    return data


def check_run(ds: xr.Dataset, path: str | Path = "the run") -> None:
    """Raise ``InputError`` when a run cannot be analysed as it is: its times not strictly
    increasing at the step its attributes give, a state variable not finite or not over
    ``t``, or an attribute the analyses read (``dt``, frequencies, speed) not a finite
    number in its range (a damaged or edited file)."""
    from analysis.signal import run_state_names

    where = f"result file: '{path}'"
    t = np.asarray(ds["t"].values, dtype=float)
    if t.ndim != 1 or len(t) < 2:
        raise InputError(f"{where}: holds {t.size} sample(s); a run needs at least 2")
    for name in ("dt", *RUN_ATTRS_NONNEGATIVE, *(k for k in ds.attrs if
                                                 str(k).startswith(("vc_hz", "cage_hz")))):
        if name not in ds.attrs:
            continue
        try:
            value = float(ds.attrs[name])
        except (TypeError, ValueError):
            value = float("nan")
        if not (np.isfinite(value) and (value > 0 if name == "dt" else value >= 0)):
            raise InputError(f"{where}: attribute {name} must be a finite number "
                             f"{'> 0' if name == 'dt' else '>= 0'}, got {ds.attrs[name]} "
                             "(a damaged or edited file)")
    step = np.diff(t)
    if not np.all(np.isfinite(t)) or not np.all(step > 0):
        raise InputError(f"{where}: its times are not strictly increasing")
    if "dt" in ds.attrs:
        spacing = float(ds.attrs["dt"]) * float(ds.attrs.get("save_every", 1))
        if not np.allclose(step, spacing, rtol=1e-6, atol=0.0):
            raise InputError(f"{where}: its samples are not {spacing:g} s apart as its "
                             "attributes dt and save_every say (a damaged or edited file)")
    for name in run_state_names(ds):
        if ds[name].dims != ("t",):
            raise InputError(f"{where}: variable {name} is not a series over t")
        bad = ~np.isfinite(ds[name].values)
        if bad.any():
            raise InputError(f"{where}: variable {name} is not finite at t = "
                             f"{t[int(np.argmax(bad))]:g} s (NaN or inf); it cannot be "
                             "analysed")


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
        with xr.open_dataset(source, engine=_engine(Path(source))) as ds:
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
