"""Sweep results stored point by point, so an interrupted sweep resumes where it stopped.

Each finished point is one ``.npz`` file in ``<output>.parts/``, written to a temporary name
and renamed: a point is either complete or absent, whichever process wrote it, with no lock
and no shared file. ``sweep.json`` records the sweep's definition; resuming with a different
definition is refused. When every point is done the sweep assembles the final netCDF file
(atomically) and removes the folder.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import InputError

MANIFEST = "sweep.json"


class PointStore:
    def __init__(self, output: str | Path, definition: dict[str, Any]):
        self.output = Path(output)
        self.folder = self.output.with_name(self.output.name + ".parts")
        manifest = self.folder / MANIFEST
        text = json.dumps(definition, sort_keys=True, indent=1, default=float)
        if manifest.exists():
            if json.loads(manifest.read_text()) != json.loads(text):
                raise InputError(
                    f"output: {self.folder} holds an unfinished sweep with a different "
                    "definition; finish it with the same command, or delete the folder")
        else:
            if not self.output.parent.exists():
                raise InputError(f"output: folder '{self.output.parent}' does not exist")
            self.folder.mkdir(parents=True, exist_ok=True)
            _atomic_bytes(manifest, text.encode())

    def done(self) -> set[str]:
        """Keys of the points already stored."""
        return {p.stem for p in self.folder.glob("*.npz")}

    def save(self, key: str, values: dict[str, Any]) -> None:
        def write(handle):
            np.savez(handle, **{k: np.asarray(v) for k, v in values.items()})

        fd, tmp = tempfile.mkstemp(prefix=f".{key}.", suffix=".tmp", dir=self.folder)
        try:
            with os.fdopen(fd, "wb") as handle:
                write(handle)
            os.replace(tmp, self.folder / f"{key}.npz")
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)

    def load(self, key: str) -> dict[str, np.ndarray]:
        with np.load(self.folder / f"{key}.npz", allow_pickle=False) as data:
            return {k: data[k] for k in data.files}

    def remove(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def _atomic_bytes(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "wb") as handle:
        handle.write(data)
    os.replace(tmp, path)
