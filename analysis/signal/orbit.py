"""Shaft orbits of a run: the x–y path of each body's centre and of each bearing's relative
displacement (its inner body's race centre against its outer body's), with the bearing's
radial clearance and the points once per shaft revolution (the keyphasor marks).

A bearing's relative displacement (X, Y) is the linear map of the state its generated
model gives (``station_map_<bearing>``: (state index, ∂X/∂q, ∂Y/∂q)): the rotor's centre
for the paper's one-body models, rotor minus housing for ``rotor-housing``, the rotor's
centre plus its tilts times the bearing's station for ``two-bearing-rotor``. A bearing's
balls touch when the relative displacement along a ball's angle exceeds the radial
clearance γ0 (the circle of radius γ0 drawn with it).

The marks are the state at the shaft angles 2πk: the shaft section
(``analysis.signal.poincare``: t_k = k/X at constant speed). A run whose speed follows a
profile is marked where its shaft angle (``analysis.signal.phasor.shaft_angle``: the
profile's ∫ω dt) crosses 2πk (the times from the profile's exact inverse, the state
interpolated linearly between samples).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr

from analysis.errors import InputError
from analysis.integrate.speed_profile import profile_of
from analysis.provenance import state_names, system_of_attrs
from analysis.signal.phasor import shaft_angle
from analysis.signal.poincare import poincare_section


@dataclass(frozen=True)
class Orbit:
    """One orbit: ``name`` (``rotor``, ``bearing left``), what it is (``what``), its
    path ``x``, ``y`` and marks ``mark_x``, ``mark_y`` (once per revolution) in ``unit``
    (m), and the radial clearance (m; None when it is not a bearing's or unknown)."""

    name: str
    what: str
    x: np.ndarray
    y: np.ndarray
    mark_x: np.ndarray
    mark_y: np.ndarray
    unit: str = "m"
    clearance: float | None = None
    mark_t: np.ndarray | None = None


def revolution_marks(ds: xr.Dataset) -> xr.Dataset | None:
    """The state once per shaft revolution (dimension ``k``, every state variable), or None
    for a run without a turning shaft; see the module docstring for runs with a
    ``shaft_angle``."""
    names = state_names(ds)
    if "shaft_angle" in ds.variables or profile_of(ds.attrs) is not None:
        angle = shaft_angle(ds)  # the speed follows a profile: marks at 2πk
        t = np.asarray(ds["t"].values, dtype=float)
        turns = np.arange(math.ceil(angle[0] / (2 * math.pi)),
                          math.floor(angle[-1] / (2 * math.pi)) + 1)
        profile = profile_of(ds.attrs)
        t_k = np.interp(turns * 2 * math.pi, angle, t) if profile is None else \
            np.clip(profile.time_at_angle(turns * 2 * math.pi, float(ds.attrs["duration"])),
                    t[0], t[-1])  # the profile's exact inverse
        return xr.Dataset({n: ("k", np.interp(t_k, t, ds[n].values)) for n in names},
                          coords={"k": turns, "t": ("k", t_k)})
    if not float(ds.attrs.get("shaft_hz", 0.0)) > 0:
        return None
    return poincare_section(ds, "shaft")


def _linear(source: xr.Dataset, terms: list[tuple[str, float, float]]
            ) -> tuple[np.ndarray, np.ndarray]:
    x = sum(a * np.asarray(source[n].values, dtype=float) for n, a, _ in terms if a)
    y = sum(b * np.asarray(source[n].values, dtype=float) for n, _, b in terms if b)
    zero = np.zeros(source.sizes[next(iter(source.dims))])
    return (zero + x, zero + y)


def _clearances(model, values: dict[str, float]) -> list[float | None]:
    """The radial clearance (m) of each bearing: one value of the clearance role per
    bearing, or the first for all."""
    found = model.role_values("clearance", values)
    bearings = model.bearing_names
    if len(found) == len(bearings):
        return list(found)
    return [found[0] if found else None] * len(bearings)


def node_terms(model, node: int) -> list[tuple[int, float, float]]:
    """Node ``node``'s translation (x, y) as a linear map of a flexible model's state: the
    generated module's ``NODE_MAP`` rows (state index, ∂x/∂q, ∂y/∂q; m/m). ``InputError``
    naming ``--node`` for a model without finite-element nodes or a node it lacks."""
    node_map = getattr(model.module, "NODE_MAP", None)
    if node_map is None:
        raise InputError(f"node: only for a flexible (finite-element) model; "
                         f"{model.name} has no shaft nodes", field="node")
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)) \
            or not 0 <= int(node) < len(node_map):
        raise InputError(f"node: a node of {model.name}, 0…{len(node_map) - 1}, got {node}",
                         field="node")
    return [(int(i), float(a), float(b)) for i, a, b in node_map[int(node)]]


def node_orbit(ds: xr.Dataset, node: int) -> Orbit:
    """The orbit of shaft node ``node`` of a flexible model's run: its translation (x, y, m)
    from the run's reduced state through the model's ``NODE_MAP`` (``node_terms``), with
    the marks once per revolution and, at a bearing's node, that bearing's clearance.
    ``InputError`` (naming ``--node``) for a rigid model or a node it lacks."""
    system = system_of_attrs(ds.attrs)
    model = system.model
    rows = node_terms(model, node)
    names = state_names(ds)
    terms = [(names[i], a, b) for i, a, b in rows]
    marks = revolution_marks(ds)
    bearing, clearance = None, None
    for b, c in zip(model.bearings, _clearances(model, dict(system.parameters)), strict=True):
        rows_b = getattr(model.module, f"station_map_{b.name}")(system.p)
        if sorted((int(i), float(u), float(v)) for i, u, v in rows_b) == sorted(rows):
            bearing, clearance = b.name, c  # the bearing whose station is this node
            break
    what = f"shaft node {int(node)}'s translation" + (f" (bearing {bearing})" if bearing
                                                       else "")
    mark = _linear(marks, terms) if marks is not None and marks.sizes.get("k", 0) \
        else (np.array([]), np.array([]))
    return Orbit(f"node {int(node)}", what, *_linear(ds, terms), *mark, unit="m",
                 clearance=clearance, mark_t=None if marks is None else marks["t"].values)


def orbits(ds: xr.Dataset, x: str | None = None, y: str | None = None,
           node: int | None = None) -> list[Orbit]:
    """The orbits of a run: with ``x`` and ``y`` (two state variables) that pair only; with
    ``node`` (a flexible model's shaft node) that node's only (``node_orbit``); else
    each body's centre (bodies that move in a plane) and each bearing's relative
    displacement, a bearing whose displacement is its body's centre drawn once (as the
    bearing, with its clearance). ``InputError`` naming a variable the run lacks, or a
    run with no planar motion."""
    if node is not None:
        if x is not None or y is not None:
            raise InputError("node: draws one shaft node's orbit; give --node or --var, "
                             "not both", field="node")
        return [node_orbit(ds, node)]
    names = state_names(ds)
    marks = revolution_marks(ds)
    if x is not None or y is not None:
        from analysis.signal.full_spectrum import orbit_pair

        x, y = orbit_pair(ds, x, y)
        unit = str(ds[x].attrs.get("units", "m"))
        mark = (marks[x].values, marks[y].values) if marks is not None else (np.array([]),) * 2
        return [Orbit(f"{x}, {y}", f"{y} against {x}", np.asarray(ds[x].values, float),
                      np.asarray(ds[y].values, float), *mark, unit=unit,
                      mark_t=None if marks is None else marks["t"].values)]
    system = system_of_attrs(ds.attrs)
    model = system.model
    values = dict(system.parameters)
    p = system.p
    found: list[Orbit] = []
    maps: list[tuple[str, list]] = []
    clearances = _clearances(model, values)
    for bearing, clearance in zip(model.bearings, clearances, strict=True):
        rows = getattr(model.module, f"station_map_{bearing.name}")(p)
        terms = [(names[int(i)], float(a), float(b)) for i, a, b in rows]
        outer = "ground" if bearing.outer == "ground" else f"the {bearing.outer}'s"
        label = "bearing" if bearing.name == "bearing" else f"bearing {bearing.name}"
        maps.append((label, terms))
        found.append((label,
                      f"{bearing.inner}'s race centre relative to {outer}", terms,
                      clearance))
    bodies = []
    for body, motion, coordinates in model.module.BODIES:
        suffix = "" if len(model.module.BODIES) == 1 else f"_{body}"
        if "y" not in coordinates:
            continue
        terms = [(f"x{suffix}", 1.0, 0.0), (f"y{suffix}", 0.0, 1.0)]
        if any(sorted(t for t in m if t[1] or t[2]) == sorted(terms) for _, m in maps):
            continue  # the same path as a bearing's: drawn once, as the bearing
        bodies.append((body, f"centre of the {body}" + (" (translation)" if "tilt" in motion
                                                         else ""), terms, None))
    if not bodies and not found:
        raise InputError(f"orbit: this run ({ds.attrs.get('model', '?')}) has no body that "
                         f"moves in a plane (variables: {', '.join(names)}); an orbit needs "
                         "two coordinates")
    unit = "m"
    out = []
    for name, what, terms, clearance in [*bodies, *found]:
        path = _linear(ds, terms)
        mark = _linear(marks, terms) if marks is not None and marks.sizes.get("k", 0) \
            else (np.array([]), np.array([]))
        out.append(Orbit(name, what, *path, *mark, unit=unit, clearance=clearance,
                         mark_t=None if marks is None else marks["t"].values))
    return out


__all__ = ["Orbit", "node_orbit", "node_terms", "orbits", "revolution_marks"]
