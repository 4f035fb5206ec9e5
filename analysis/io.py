"""Result files: netCDF (HDF5 via h5netcdf), written atomically and read with clear errors."""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from analysis.errors import InputError, Interrupt, WriteError
from modelgen.locations import broken_link

if TYPE_CHECKING:  # xarray is imported where a file is read or written (issue 39)
    import xarray as xr

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
        raise WriteError(f"output: '{path}' needs about {_bytes(need)} and {_bytes(room)} "
                         f"are {what}; nothing was written")


def _bytes(size: float) -> str:
    """``1.8 MiB``, ``50 KiB``, ``0 bytes``: a size said in the unit that shows it."""
    if size >= 2**20:
        return f"{size / 2**20:.1f} MiB"
    if size >= 2**10:
        return f"{size / 2**10:.0f} KiB"
    return f"{int(size)} bytes"


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
    remove_stale_temporaries(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=_temporary_prefix(path), suffix=".tmp", dir=folder)
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


STALE_AGE = 600.0
"""Seconds after its last change that a temporary file of the old name form (without the
writer's process id) is taken as left by a killed writer."""
_TEMPORARY = re.compile(r"(?:(?P<pid>\d+)-)?[a-z0-9_]{8}\.tmp")  # mkstemp: 8 characters


def _temporary_prefix(path: Path) -> str:
    """``.<name>.<pid>-``: the writer's process id in the temporary file's name, so that a
    later run can tell a temporary left by a killed writer from one still being written."""
    return f".{path.name}.{os.getpid()}-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # another user's process: it exists
    return True


def remove_stale_temporaries(path: str | Path) -> list[Path]:
    """Remove the temporary files that writers of ``path`` left behind when they were killed
    (SIGKILL, a power cut) during the final write: ``.<name>.<pid>-<random>.tmp`` beside
    ``path`` whose process no longer runs (and ``.<name>.<random>.tmp`` of older versions,
    unchanged for ``STALE_AGE`` s). A temporary that a running writer still fills is kept.
    Called by ``atomic_write`` before every write, so the next run to the same output cleans
    up after a killed one. Returns the files removed."""
    import time

    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    prefix = f".{path.name}."
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(prefix):
            continue
        found = _TEMPORARY.fullmatch(entry.name[len(prefix):])
        if found is None or not entry.is_file(follow_symlinks=False):
            continue
        try:
            if found["pid"] is not None:
                stale = int(found["pid"]) != os.getpid() and not _alive(int(found["pid"]))
            else:
                stale = time.time() - entry.stat(follow_symlinks=False).st_mtime > STALE_AGE
            if stale:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue  # gone already, or not ours to remove: the write goes on
    return removed


def save_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to netCDF-4 at ``path`` atomically."""
    return atomic_write(path, lambda tmp: _to_netcdf(ds, tmp), size=ds.nbytes)


def _to_netcdf(ds: xr.Dataset, path: Path) -> None:
    """``ds.to_netcdf(path, engine="h5netcdf")``, without the import of ``dask.distributed``
    that xarray's dask-scheduler probe costs where dask is installed (issue 39: a small
    write took 0.16-0.25 CPU-s, 0.04-0.06 without it). The file is the same, byte for
    byte."""
    with _scheduler_probe_without_distributed():
        ds.to_netcdf(path, engine="h5netcdf")


_PROBES = (("xarray.backends.locks", "get_dask_scheduler"),
           ("xarray.backends.writers", "get_dask_scheduler"),
           ("xarray.backends.locks", "_get_scheduler"),  # older xarray: the old name
           ("xarray.backends.api", "_get_scheduler"))
"""Where xarray keeps its dask-scheduler probe (the function and the names it is imported
under), in the versions bearingdyn supports."""
_PROBE_LOCK = threading.Lock()


@contextlib.contextmanager
def _scheduler_probe_without_distributed() -> Iterator[None]:
    """Within: xarray's dask-scheduler probe answers without importing ``distributed`` when
    nothing in this process has imported it (no dask cluster can then run here).

    xarray asks which dask scheduler runs before it writes a netCDF file, to pick the kind
    of lock that orders the writes and whether to close the file between dask's writes (for
    data held in dask chunks under a multiprocessing or distributed scheduler only). Its
    probe imports ``distributed`` (0.1-0.2 CPU-s) to look for a client, although a client
    exists only once ``distributed`` is imported. Without ``distributed`` imported the answer
    is None where nothing has imported dask either (no dask computation can run here: the
    answer xarray gives where dask is not installed) and ``"threaded"`` (xarray's own) where
    dask is imported with no scheduler configured; anything else (``distributed`` imported,
    a configured scheduler, a dask collection asked about) goes to xarray's probe. Either
    answer picks a threading lock and no closing between writes, as xarray's would for data
    held in memory: the file is the same. One writer at a time patches the probe."""
    import xarray.backends.locks  # noqa: F401  (the probe's module, with its importers)

    with _PROBE_LOCK:
        found = [(sys.modules[module], name) for module, name in _PROBES
                 if module in sys.modules and callable(getattr(sys.modules[module], name, None))]
        originals = [getattr(module, name) for module, name in found]
        try:
            for (module, name), original in zip(found, originals, strict=True):
                setattr(module, name, _cheap_probe(original))
            yield
        finally:
            for (module, name), original in zip(found, originals, strict=True):
                setattr(module, name, original)


def _cheap_probe(original: Callable[..., str | None]) -> Callable[..., str | None]:
    """xarray's dask-scheduler probe ``original``, answered without importing
    ``distributed`` where that cannot change the answer
    (``_scheduler_probe_without_distributed``)."""

    def probe(get=None, collection=None) -> str | None:
        if "distributed" in sys.modules or get is not None or collection is not None:
            return original(get, collection)
        dask = sys.modules.get("dask")
        if dask is None:
            return None
        if dask.config.get("scheduler", None) is not None or dask.config.get("get", None):
            return original(get, collection)
        return "threaded"

    return probe


def open_result(path: str | Path) -> xr.Dataset:
    """Read any bearingdyn result file (run, branch, diagram, chart) into memory: netCDF-4
    (what bearingdyn writes) or netCDF-3 (classic, 64-bit offset)."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"result file: '{path}' is a folder, not a result file")
    check_readable(path)
    import xarray as xr

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


def check_readable(path: Path) -> None:
    """``InputError`` unless a result file can be opened at ``path``: it does not exist, is
    a broken symbolic link (a loop, a missing target), or is not a plain file."""
    if not path.exists():
        raise InputError(f"result file: '{path}' {broken_link(path) or 'does not exist'}")
    if not path.is_file():
        raise InputError(f"result file: '{path}' is not a plain file (a pipe or device)")


def read_attrs(path: str | Path) -> dict[str, Any]:
    """The attrs of the result file at ``path``, read without its data."""
    check_readable(Path(path))
    import xarray as xr

    with xr.open_dataset(path, engine=_engine(Path(path))) as ds:
        return dict(ds.attrs)
