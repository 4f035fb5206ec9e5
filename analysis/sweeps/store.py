"""Sweep results stored point by point, so an interrupted sweep resumes where it stopped.

Each finished point is one ``.npz`` file in ``<output>.parts/``, written to a temporary name
and renamed: a point is either complete or absent, whichever process wrote it, with no
shared file. ``sweep.json`` records the sweep's definition; resuming with a different
definition is refused. When every point is done the sweep assembles the final netCDF file
(atomically) and removes the folder.

- **One process per output.** The process that runs a sweep holds an exclusive lock
  (``flock``) on ``<output>.parts/lock`` for the whole sweep; a second process on the same
  output is refused with one line. The kernel releases the lock when the holder ends, even by
  SIGKILL, so a killed sweep resumes at once.
- **Damaged points are recomputed.** On opening, every stored point is read back; one that
  cannot be read (truncated, zero bytes, not an ``.npz``) is removed, reported to
  ``on_damaged`` and computed again. An unreadable ``sweep.json`` is rewritten only when
  no point is stored; otherwise the folder is refused (its points cannot be matched to a
  definition).
- **Blocks.** ``save_block`` stores several points as one entry (``block-<first key>``:
  their ``keys`` and each field stacked), whole or absent like a point; ``points`` reads
  entries of both kinds back point by point, ``point_count`` counts them. A caller that
  holds its points as columns (the chart) writes the same entry with ``save_columns`` and
  reads every entry back as columns with ``columns``: no dict per point either way.
- **Resuming is said, not guessed.** ``command`` (beside ``sweep.json``) records the command
  line that started the sweep; a re-run with another definition is refused naming it and
  the fields that differ. A sweep stopped part way (Ctrl-C, SIGTERM, an error) leaves its
  points and ``kept_note`` says so: ``88 of 200 points kept in out.nc.parts; run the same
  command to resume``, added to the exception as a note (``BaseException.add_note``) that
  the command line prints under its one line.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shlex
import shutil
import sys
import tempfile
import zipfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError, check_count

MANIFEST = "sweep.json"
BLOCK = "block-"
"""The key of a block of points: ``block-`` and its first point's key."""
LOCK = "lock"
COMMAND = "command"
"""The file (in ``OUTPUT.parts``) holding the command line that started the sweep."""


def command_line(argv: list[str] | None = None) -> str:
    """The command line of this process as a user would type it again: ``bearingdyn …``
    for the console command (or ``python -m analysis.cli``), else the script and its
    arguments."""
    argv = list(sys.argv if argv is None else argv)
    head = Path(argv[0]).name if argv else "python3"
    if head == "bearingdyn" or Path(argv[0] if argv else "").parts[-3:] == (
            "analysis", "cli", "__main__.py"):
        head = "bearingdyn"
    return shlex.join([head, *argv[1:]])


def _differences(stored: Any, given: Any, where: str = "") -> list[str]:
    """The dotted names of the fields where two definitions differ (at most the leaves)."""
    if isinstance(stored, dict) and isinstance(given, dict):
        found = []
        for key in sorted(set(stored) | set(given), key=str):
            name = f"{where}.{key}" if where else str(key)
            if key not in stored or key not in given:
                found.append(name)
            else:
                found += _differences(stored[key], given[key], name)
        return found
    return [] if stored == given else [where or "definition"]


INT64 = 2**63 - 1


def check_definition(definition: Any, where: str = "") -> None:
    """``InputError`` naming the field when a definition holds a whole number that the
    result file cannot store (beyond a 64-bit signed integer, such as a seed of 2**70):
    judged before the store is made, so a refused value leaves no folder that would then
    block the corrected command."""
    if isinstance(definition, dict):
        for key, value in definition.items():
            check_definition(value, f"{where}.{key}" if where else str(key))
    elif isinstance(definition, (list, tuple)):
        for value in definition:
            check_definition(value, where)
    elif isinstance(definition, int) and not isinstance(definition, bool):
        check_count(where or "definition", definition, -INT64, INT64)


class PointStore:
    """The stored points of one sweep output. ``lock=True`` (the process running the
    sweep): take the output's lock and check the stored points; workers open it unlocked."""

    def __init__(self, output: str | Path, definition: dict[str, Any], *, lock: bool = False,
                 on_damaged: Callable[[str], None] | None = None):
        check_definition(definition)  # before the folder is made
        self.on_damaged = on_damaged
        """Told the key of a stored point that cannot be read (it is computed again)."""
        self.output = Path(output)
        self.folder = self.output.with_name(self.output.name + ".parts")
        self._lock_fd: int | None = None
        self.made = not self.folder.exists()
        """Whether this store made the folder (``discard`` removes only such a folder)."""
        manifest = self.folder / MANIFEST
        text = json.dumps(definition, sort_keys=True, indent=1, default=float)
        if lock:
            if not self.output.parent.exists():
                raise InputError(f"output: folder '{self.output.parent}' does not exist")
            self.folder.mkdir(parents=True, exist_ok=True)
            self._lock()
        try:
            stored = json.loads(manifest.read_text()) if manifest.exists() else None
        except (OSError, ValueError):
            if any(self.folder.glob("*.npz")):
                self.close()
                raise InputError(f"output: {self.folder / MANIFEST} is damaged and points are "
                                 "stored beside it; delete the folder to start again") from None
            stored = None
        if stored is not None and stored != json.loads(text) and self.done():
            self.close()
            differ = _differences(stored, json.loads(text))
            shown = ", ".join(differ[:4]) + (", …" if len(differ) > 4 else "")
            raise InputError(
                f"output: {self.folder} holds an unfinished sweep with a different "
                f"definition ({self.point_count()} points stored; differs in {shown}); "
                f"{self.stored_command_text()}, or delete the folder")
        if stored != json.loads(text):  # none yet, or one of no stored point: replaced
            self.folder.mkdir(parents=True, exist_ok=True)
            _atomic_bytes(manifest, text.encode())
            _atomic_bytes(self.folder / COMMAND, (command_line() + "\n").encode())
        if lock:
            self.check(on_damaged)

    def _lock(self) -> None:
        import fcntl

        fd = os.open(self.folder / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise InputError(f"output: another bearingdyn process is writing "
                                 f"'{self.output}' (it holds {self.folder / LOCK}); wait for "
                                 "it to finish, or choose another output") from None
            raise
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._lock_fd = fd

    def check(self, on_damaged: Callable[[str], None] | None = None) -> list[str]:
        """Read every stored point back; remove (and return the keys of) those that cannot
        be read, so they are computed again. Temporary files (``.*.tmp``) left by a process
        killed mid-write are removed: the caller holds the output's lock, and its workers
        have not started."""
        for path in self.folder.glob(".*.tmp"):
            path.unlink(missing_ok=True)
        damaged = []
        for path in sorted(self.folder.glob("*.npz")):
            try:
                self.load(path.stem)
            except (OSError, ValueError, EOFError, zipfile.BadZipFile):
                path.unlink(missing_ok=True)
                damaged.append(path.stem)
                if on_damaged:
                    on_damaged(path.stem)
        return damaged

    def done(self) -> set[str]:
        """Keys of the points already stored."""
        return {p.stem for p in self.folder.glob("*.npz")}

    def stored_command(self) -> str | None:
        """The command line that started the stored sweep (None: not recorded)."""
        try:
            return (self.folder / COMMAND).read_text().strip() or None
        except OSError:
            return None

    def stored_command_text(self) -> str:
        """How to finish the stored sweep, in words: its command, when recorded."""
        command = self.stored_command()
        if command is None:
            return "finish it with the command that started it (not recorded)"
        return f"finish it with the command that started it: {command}"

    def kept_note(self, total: int | None = None, what: str = "points") -> str | None:
        """After a sweep stopped part way: ``88 of 200 points kept in OUT.parts; run the
        same command to resume`` (``total``: the sweep's points; None: not counted), or
        None when the folder is gone (nothing was kept)."""
        if not self.folder.exists():
            return None
        kept = self.point_count()
        count = f"{kept} of {total}" if total is not None else f"{kept}"
        if kept == 1 and total is None:  # "1 block (256 states) kept", not "1 blocks"
            noun, _, rest = what.partition(" ")
            what = f"{noun.removesuffix('s')} {rest}".strip()
        return f"{count} {what} kept in {self.folder}; run the same command to resume"

    def stopped(self, exc: BaseException, total: int | None = None,
                what: str = "points") -> None:
        """The sweep stopped on ``exc``: ``discard`` the folder if it holds nothing, and
        note on ``exc`` how many points are kept and how to resume (``kept_note``). A
        refusal before any point gets no note; an interruption before any point is told
        that nothing was kept."""
        self.discard()
        note = self.kept_note(total, what)
        if note and self.done():
            exc.add_note(note)
        elif isinstance(exc, KeyboardInterrupt):  # stopped before any point was stored
            exc.add_note(f"nothing was kept: none of the {total if total is not None else ''} "
                         f"{what} had finished".replace("  ", " "))

    def save(self, key: str, values: dict[str, Any]) -> None:
        def write(handle):
            np.savez(handle, **{k: np.asarray(v) for k, v in values.items()})

        fd, tmp = tempfile.mkstemp(prefix=f".{key}.", suffix=".tmp", dir=self.folder)
        target = self.folder / f"{key}.npz"
        try:
            with _naming(target), os.fdopen(fd, "wb") as handle:
                write(handle)
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(tmp, target)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)

    def save_block(self, points: list[tuple[str, dict[str, Any]]]) -> None:
        """Store ``(key, values)`` points (the same fields, each of one shape) as one entry:
        ``keys`` and every field stacked over the points, in one atomic write."""
        self.save_columns([key for key, _ in points], stacked([values for _, values in points]))

    def save_columns(self, keys: Sequence[str], columns: dict[str, np.ndarray]) -> None:
        """Store points given as columns (each field an array over the points, in the order
        of ``keys``) as one entry, exactly as ``save_block`` stores the same points (``keys``
        and the fields in their order, one atomic write): no dict per point."""
        if not len(keys) or any(len(column) != len(keys) for column in columns.values()):
            raise ValueError("a block's columns must hold one value per key (one key at least)")
        self.save(BLOCK + str(keys[0]), {"keys": np.array(keys), **columns})

    def points(self) -> dict[str, dict[str, np.ndarray]]:
        """Every stored point, key → values, from entries of one point and blocks alike."""
        found: dict[str, dict[str, np.ndarray]] = {}
        for name in sorted(self.done()):
            entry = self.load(name)
            if not name.startswith(BLOCK):
                found[name] = entry
                continue
            fields = [f for f in entry if f != "keys"]
            for j, key in enumerate(entry["keys"].tolist()):
                found[key] = {f: entry[f][j] for f in fields}
        return found

    def columns(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Every stored point as columns, entries of one point and blocks alike: the keys
        and each field, concatenated over the entries in ``points``' order (a key stored
        twice: its last row is the one ``points`` gives), the fields of the first entry
        (another entry lacking one: ``KeyError``). No dict per point."""
        keys, entries = [], []
        for name in sorted(self.done()):
            entry = self.load(name)
            if name.startswith(BLOCK):
                keys.append(entry.pop("keys"))
            else:
                keys.append(np.array([name]))
                entry = {f: value[None] for f, value in entry.items()}
            entries.append(entry)
        if not entries:
            return np.array([], dtype=str), {}
        return np.concatenate(keys), {f: np.concatenate([entry[f] for entry in entries])
                                      for f in entries[0]}

    def keys(self) -> set[str]:
        """The keys of the stored points (a block's own ``keys``, read without its
        fields): what ``done`` is for a store of single points."""
        found = set()
        for name in self.done():
            if not name.startswith(BLOCK):
                found.add(name)
                continue
            with np.load(self.folder / f"{name}.npz", allow_pickle=False) as data:
                found.update(data["keys"].tolist())
        return found

    def point_count(self) -> int:
        """How many points are stored (a block counts its points)."""
        return len(self.keys())

    def load(self, key: str) -> dict[str, np.ndarray]:
        with np.load(self.folder / f"{key}.npz", allow_pickle=False) as data:
            return {k: data[k] for k in data.files}

    def close(self) -> None:
        """Release the output's lock (also done by the kernel when the process ends)."""
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None

    def discard(self) -> None:
        """After a sweep that failed: remove the folder when this store made it and no point
        was stored (a refusal leaves nothing behind), and release the lock."""
        if self.made and not self.done():
            self.remove()
        self.close()

    def remove(self) -> None:
        """Delete the stored points (the sweep is assembled) and release the lock."""
        shutil.rmtree(self.folder, ignore_errors=True)
        self.close()


def stacked(rows: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Points' values (the same fields, each of one shape) as columns: each field stacked
    over the points (``np.stack`` of ``np.asarray``), what ``PointStore.save_block``
    stores. ``ValueError`` when the points' fields differ."""
    fields = rows[0].keys()
    if any(values.keys() != fields for values in rows):
        raise ValueError("a block's points must have the same fields")
    return {name: np.stack([np.asarray(values[name]) for values in rows]) for name in fields}


def _atomic_bytes(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with _naming(path), os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def _naming(path: Path):
    """Re-raise an ``OSError`` without a file name (a full disk while writing) naming
    ``path``, so the one line the user sees says which file could not be written."""
    try:
        yield
    except OSError as exc:
        if exc.filename is not None:
            raise
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
