"""What the figures and the explorer page name and range, without drawing anything (no
matplotlib here, so a worker that only computes a page's data never imports it): peak labels
for print, the frequency range of a spectrum plot, the partner variable of a Poincaré map."""

from __future__ import annotations

import xarray as xr

from analysis.errors import InputError
from analysis.provenance import is_velocity, state_names
from analysis.signal.spectrum import label_frequencies


def display_label(label: str) -> str:
    """A peak label for print: unicode minus (VC−X)."""
    return label.replace("-", "\u2212")


def f_max_of(attrs) -> float | None:
    """Upper frequency of a spectrum plot from a run's attrs (Hz): 2.5 (largest VC + X), or
    10 base frequencies without bearings (None: the whole spectrum). A series of runs
    (N_b = 6 … 10) shares the largest of theirs (``series_f_max``)."""
    try:
        base, vcs, _ = label_frequencies(attrs)
    except InputError:  # no frequencies at all: draw everything
        return None
    top = max(vcs.values(), default=0.0)
    if top > 0:
        return 2.5 * (top + base)
    return 10.0 * base if base > 0 else None


def series_f_max(attrs_list) -> float | None:
    """One frequency range for a series of runs: the largest ``f_max_of`` of them."""
    tops = [f for f in (f_max_of(a) for a in attrs_list) if f]
    return max(tops) if tops else None


def default_partner(ds: xr.Dataset, var: str) -> str:
    """The variable drawn against ``var`` in a Poincaré map: its velocity (``vx`` for
    ``x``), else the next state variable."""
    names = state_names(ds)
    if f"v{var}" in names:
        return f"v{var}"
    if is_velocity(var, names):
        return var[1:]
    others = [n for n in names if n != var]
    return others[0] if others else var
