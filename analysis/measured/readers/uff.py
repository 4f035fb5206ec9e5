"""Universal File Format records (``pyuff``): each set of type 58 holding a time response
(function type 1) is a channel; its rate is 1/abscissa increment, its units the ordinate's
label where it is one of ``analysis.measured.readers.UNITS``. A channel is named by the
set's ID line 1 (``id1``), or by its response node and direction (``n3_z``) where the ID
lines do not tell the sets apart. Install: ``python3 -m pip install -e '.[measured]'``."""

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

DIRECTIONS = {0: "s", 1: "x", 2: "y", 3: "z", -1: "mx", -2: "my", -3: "mz", 4: "rx", 5: "ry",
              6: "rz"}
"""UFF direction codes as channel-name suffixes (0: scalar)."""


def _sets(path: Path) -> list[dict]:
    try:
        import pyuff
    except ImportError:
        raise missing_library("pyuff", path) from None
    try:
        found = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions for damaged files
        raise unreadable(path, "UFF", exc) from None
    return found if isinstance(found, list) else [found]


def _units(label: str) -> str | None:
    text = str(label).strip()
    unit = text if text in UNITS else UNIT_ALIASES.get(text.lower())
    return unit if unit in UNITS and unit != "1" else None


def read(path: Path) -> Raw:
    """The type-58 time responses of a UFF file as channels (see the module)."""
    sets = [s for s in _sets(path) if s.get("type") == 58 and int(s.get("func_type", 0)) == 1]
    if not sets:
        raise InputError(f"record: '{path}' holds no type-58 time response (function type "
                         "1); a record needs sampled signals")
    ids = [str(s.get("id1", "")).strip() for s in sets]
    by_id = len(set(ids)) == len(ids) and all(i and i.upper() != "NONE" for i in ids)
    channels, rates = [], set()
    for s, label in zip(sets, ids, strict=True):
        node = f"n{int(s.get('rsp_node', 0))}_{DIRECTIONS.get(int(s.get('rsp_dir', 0)), 's')}"
        name = label if by_id else node
        values = as_column(np.real(s["data"]), name, path)
        even = s.get("abscissa_spacing", 1) and s.get("abscissa_inc")
        rates.add(round(1.0 / float(s["abscissa_inc"]), 9) if even else None)
        channels.append(Channel(identifier(name), values,
                                _units(s.get("ordinate_axis_units_lab", "")),
                                f"{label} (node {s.get('rsp_node')}, direction "
                                f"{s.get('rsp_dir')})", name))
    if rates == {None} and all("x" in s for s in sets):  # uneven abscissa: the times
        return Raw(channels, "pyuff.UFF.read_sets", t=np.asarray(sets[0]["x"], dtype=float),
                   fs_source="file: abscissa values")
    if len(rates) != 1 or None in rates:
        raise InputError(f"record: '{path}': its time responses have different or no sampling "
                         f"rates ({', '.join(str(r) for r in rates)} Hz); a record has one")
    return Raw(channels, "pyuff.UFF.read_sets", fs=rates.pop(),
               fs_source="file: abscissa increment")
