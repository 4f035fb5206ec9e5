"""Generated trees written whole or not at all (standard library only).

A model's folder is written into a temporary folder beside its place and renamed into it, so
a full disk, a quota or a crash part way leaves the old folder (or none), never half of a
new one. A root outside the package (the user cache, ``generate --out``) also gets a
manifest of its files' SHA-256 (``modelgen.locations.MANIFEST``), checked when it is loaded.

A write that fails raises ``OSError`` naming the file it was writing (its final path), so
"No space left on device" says where.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from modelgen.locations import MANIFEST, manifest_text


def write_text(target: Path, text: str, shown: Path | None = None) -> None:
    """Write ``text`` to ``target`` (flushed to disk); an ``OSError`` names ``shown`` (the
    file's final path; default ``target``)."""
    try:
        with open(target, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(shown or target)) from None


def stage(target: Path, files: dict[str, str]) -> Path:
    """A new temporary folder beside ``target`` holding ``files`` (relative path -> text);
    removed again when a write fails."""
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}."))
    try:
        for rel, text in files.items():
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            write_text(tmp / rel, text, target / rel)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return tmp


def replace_folder(tmp: Path, target: Path) -> None:
    """Put the staged folder ``tmp`` at ``target``; a folder already there is moved aside
    first and removed after (put back if the rename fails)."""
    old = None
    if target.exists():
        old = target.with_name(f".{target.name}.old-{os.getpid()}")
        shutil.rmtree(old, ignore_errors=True)
        os.rename(target, old)
    try:
        os.rename(tmp, target)
    except BaseException:
        if old is not None:
            os.rename(old, target)
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def write_folder(target: Path, files: dict[str, str]) -> None:
    """``files`` as the whole folder ``target``: staged, then renamed into place."""
    replace_folder(stage(target, files), target)


def write_root(root: Path, files: dict[str, str], changed: list[str], *,
               manifest: bool) -> None:
    """Write the ``changed`` files of a generated root: a new root whole; in an existing
    root each model folder with a changed file whole (staged and renamed) and each changed
    top-level file atomically. ``manifest``: (re)write the root's manifest last, over all
    of ``files``."""
    if not root.exists():
        write_folder(root, {**files, **({MANIFEST: manifest_text(files)} if manifest else {})})
        return
    folders = sorted({rel.split("/", 1)[0] for rel in changed if "/" in rel})
    for name in folders:
        inside = {rel.split("/", 1)[1]: text for rel, text in files.items()
                  if rel.startswith(f"{name}/")}
        write_folder(root / name, inside)
    for rel in changed:
        if "/" not in rel:
            write_atomic(root / rel, files[rel])
    if manifest:
        write_atomic(root / MANIFEST, manifest_text(files))


def write_atomic(target: Path, text: str) -> None:
    """One file through a temporary file beside it and a rename."""
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
    os.close(fd)
    try:
        write_text(Path(tmp), text, target)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
