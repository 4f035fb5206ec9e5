"""CSV and TSV records (the standard library's ``csv`` for the header, ``numpy.loadtxt``
for the numbers).

A header line is optional: cells that are not numbers name the columns, with units in
brackets or parentheses (``DE [g]``, ``probe_x (um)``). A column named ``t``, ``time``,
``t_s`` or ``time (s)`` (or ``time (ms)``, ``time (us)``) holds the times (uniform) and
gives the rate; without one the rate is ``--fs``. Columns without a header are named
``c1``, ``c2``, …; ``#`` starts a comment. The delimiter: a tab for ``.tsv``, else the one
of ``, ; tab space`` that the header (or the first row) uses."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np

from analysis.errors import InputError
from analysis.measured.readers import Channel, Raw, identifier, unit_of, unreadable

TIME_NAMES = ("t", "time", "t_s", "time_s", "times")
TIME_UNITS = {None: 1.0, "s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}
"""Units of a time column -> seconds."""
_UNIT_IN_NAME = re.compile(r"^(.*?)\s*[\[(]\s*([^\])]*)\s*[\])]\s*$")


def _first_line(path: Path) -> tuple[int, str]:
    """(lines before it, the first line that is neither blank nor a comment)."""
    try:
        with open(path, encoding="utf-8-sig", errors="strict") as handle:
            for number, line in enumerate(handle):
                if line.strip() and not line.lstrip().startswith("#"):
                    return number, line.rstrip("\r\n")
                if number > 1000:
                    break
    except UnicodeDecodeError as exc:
        raise unreadable(path, "CSV", exc) from None
    raise InputError(f"record: '{path}' holds no rows of numbers")


def _delimiter(path: Path, line: str) -> str | None:
    if path.suffix.lower() == ".tsv":
        return "\t"
    for candidate in (",", ";", "\t"):
        if candidate in line:
            return candidate
    return None  # whitespace


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _name_and_units(cell: str) -> tuple[str, str | None]:
    found = _UNIT_IN_NAME.match(cell.strip())
    if found:
        return found.group(1).strip(), found.group(2).strip()
    return cell.strip(), None


def read(path: Path) -> Raw:
    """The columns of a CSV/TSV file as channels (see the module)."""
    skip, line = _first_line(path)
    delimiter = _delimiter(path, line)
    cells = next(csv.reader([line], delimiter=delimiter)) if delimiter else line.split()
    header = not all(_is_number(c) for c in cells if c.strip())
    try:
        table = np.loadtxt(path, delimiter=delimiter, comments="#", ndmin=2,
                           skiprows=skip + (1 if header else 0), dtype=np.float64,
                           encoding="utf-8-sig")
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise unreadable(path, "CSV", exc) from None
    if table.size == 0:
        raise InputError(f"record: '{path}' holds no rows of numbers")
    names = [_name_and_units(c) for c in cells] if header else \
        [(f"c{i + 1}", None) for i in range(table.shape[1])]
    if len(names) != table.shape[1]:
        raise InputError(f"record: '{path}': the header names {len(names)} columns, the rows "
                         f"hold {table.shape[1]}")
    channels, times = [], None
    for (name, units), column in zip(names, table.T, strict=True):
        if name.lower() in TIME_NAMES and times is None and units in TIME_UNITS:
            times = column * TIME_UNITS[units]
            continue
        channels.append(Channel(identifier(name), column, None if units is None else
                                unit_of(units, f"record: '{path.name}' column {name!r}"),
                                name, name))
    if not channels:
        raise InputError(f"record: '{path}' holds a time column and no channel")
    return Raw(channels, "numpy.loadtxt", t=times, fs_source="file: time column" if times
               is not None else "")
