"""Signal analysis of a simulated run: ``spectrum`` (amplitude spectra, peaks named as
combinations of the shaft frequency X and each bearing's varying-compliance frequency VC)
and ``poincare`` (stroboscopic Poincaré sections at the shaft, cage, VC or a parameter's
period), for runs of any model.

The helpers here read which variables a run has from its attrs (``state_names``, written by
``simulate``; files written before it have ``x y vx vy``) without importing the integrator.
"""

from __future__ import annotations

from collections.abc import Mapping

import xarray as xr

PAPER_STATE = ("x", "y", "vx", "vy")
"""The state of the paper's one-body models, and of files older than ``state_names``."""


def run_state_names(ds: xr.Dataset) -> tuple[str, ...]:
    """The state variables of a run (or section), in the order of the state vector."""
    names = ds.attrs.get("state_names")
    return tuple(str(names).split()) if names else PAPER_STATE


def is_velocity(name: str, names: tuple[str, ...]) -> bool:
    """Whether ``name`` is the velocity of another state variable (``vx`` of ``x``)."""
    return name.startswith("v") and name[1:] in names


def displacement_names(ds: xr.Dataset) -> tuple[str, ...]:
    """The default variables of spectra and figures: the translations (``x``, ``y``) of the
    run's first body (``x``, ``y``; ``x_rotor``, ``y_rotor``; ``x`` for one coordinate)."""
    names = run_state_names(ds)
    positions = [n for n in names if not is_velocity(n, names)]
    if not positions:
        return names[:1]
    suffix = positions[0].partition("_")[2]
    chosen = tuple(n for n in positions if n.partition("_")[0] in ("x", "y")
                   and n.partition("_")[2] == suffix)
    return chosen or (positions[0],)


def vc_frequencies(attrs: Mapping) -> dict[str, float]:
    """Each bearing's VC frequency (Hz) from a run's attrs: ``{"": vc_hz}`` for a model with
    one bearing, ``{"left": vc_hz_left, …}`` for several, ``{}`` without bearings (VC 0)."""
    several = {key[len("vc_hz_"):]: float(value) for key, value in attrs.items()
               if str(key).startswith("vc_hz_")}
    if several:
        return several
    vc = float(attrs.get("vc_hz", 0.0))
    return {"": vc} if vc > 0 else {}


def cage_frequencies(attrs: Mapping) -> dict[str, float]:
    """Each bearing's cage frequency (Hz), keyed like :func:`vc_frequencies`."""
    several = {key[len("cage_hz_"):]: float(value) for key, value in attrs.items()
               if str(key).startswith("cage_hz_")}
    if several:
        return several
    cage = float(attrs.get("cage_hz", 0.0))
    return {"": cage} if cage > 0 else {}
