"""A rotor saved by ROSS (``ross.Rotor.save``, a .toml or .json file) as a ``[shaft]``.

ROSS (``ross-rotordynamics``, the ``[ross]`` extra) reads its own file
(``ross.Rotor.load``); its shaft elements, disks and linear bearings (and seals) are copied
number for number, nodes keeping ROSS's numbers. What a spec cannot hold is refused with one
message each: tapered elements, axial force or torque on an element, point masses, bearings
linked to another node, bearing mass coefficients. Bearing coefficients tabulated over
frequency (rad/s) become tables over ``speed_rpm``; bearingdyn interpolates them linearly
(ROSS fits a smoothing spline through them: between the table's speeds the two may differ).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modelgen.errors import SpecError
from modelgen.fe.schema import COEFFICIENTS, NAME, Shaft, parse_shaft

__all__ = ["BallBearing", "import_ross", "load_ross_rotor", "ross_spec_text", "shaft_data",
           "shaft_from_ross", "spec_data", "spec_text"]

RPM = 30.0 / math.pi
"""rpm per rad/s."""


@contextlib.contextmanager
def _quiet():
    """ROSS's import prints (CoolProp's REFPROP notice) and warns on stdout/stderr: keep
    the command's own output clean."""
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        saved = [os.dup(1), os.dup(2)]
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in (*saved, devnull):
                os.close(fd)


def import_ross() -> Any:
    """The ``ross`` module, imported quietly; SpecError naming the install line without it."""
    try:
        with _quiet():
            import ross
    except ImportError:
        raise SpecError("ross", ["ROSS is not installed: python3 -m pip install -e "
                                 "'.[ross]'"]) from None
    return ross


def load_ross_rotor(path: str | Path) -> Any:
    """``ross.Rotor.load(path)``, or SpecError with ROSS's reason in one line."""
    path = Path(path)
    if not path.is_file():
        raise SpecError(str(path), ["file not found"])
    if path.suffix.lower() not in (".toml", ".json"):
        raise SpecError(str(path), [f"ROSS saves rotors as .toml or .json, got "
                                    f"'{path.suffix or 'no suffix'}'"])
    ross = import_ross()
    try:
        with _quiet():
            return ross.Rotor.load(path)
    except Exception as exc:  # ROSS raises anything on a file it cannot read
        text = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise SpecError(str(path), [f"ROSS cannot read it as a rotor ({type(exc).__name__}: "
                                    f"{text})"]) from None


def _number(value: Any) -> float:
    return float(getattr(value, "magnitude", value))


def _values(value: Any) -> list[float]:
    import numpy as np

    return [float(v) for v in np.atleast_1d(np.asarray(getattr(value, "magnitude", value),
                                                       dtype=float))]


def _material_name(name: str, taken: set[str]) -> str:
    base = re.sub(r"[^A-Za-z0-9_ .-]", "_", str(name or "material")).strip() or "material"
    if not re.match(NAME, base):
        base = ("m" + base)[:60]
    name, i = base, 2
    while name in taken:
        name, i = f"{base}-{i}", i + 1
    return name


def shaft_data(rotor: Any, source: str = "<ross>") -> dict[str, Any]:
    """The ``[shaft]`` table (plain data, as TOML writes it) of a ``ross.Rotor``."""
    problems: list[str] = []
    materials: dict[tuple, dict] = {}
    elements = []
    for i, el in enumerate(sorted(rotor.shaft_elements, key=lambda e: e.n)):
        where = f"shaft element {i} (node {el.n})"
        if abs(el.odl - el.odr) > 1e-12 * el.odl or abs(el.idl - el.idr) > 1e-12 * el.odl:
            problems.append(f"{where}: tapered (odl != odr or idl != idr); bearingdyn's "
                            "elements are uniform: split it into uniform elements in ROSS")
        if _number(getattr(el, "axial_force", 0) or 0) or _number(getattr(el, "torque", 0)
                                                                   or 0):
            problems.append(f"{where}: axial force or torque is not supported")
        mat = el.material
        key = (mat.name, mat.E, mat.G_s, mat.rho)
        if key not in materials:
            name = _material_name(mat.name, {m["name"] for m in materials.values()})
            materials[key] = {"name": name, "E": float(mat.E), "G_s": float(mat.G_s),
                              "rho": float(mat.rho)}
        elements.append({
            "L": float(el.L), "odl": float(el.odl), "idl": float(el.idl),
            "material": materials[key]["name"], "n": int(el.n),
            "shear_effects": bool(el.shear_effects), "rotary_inertia": bool(el.rotary_inertia),
            "gyroscopic": bool(el.gyroscopic), "shear_method": str(el.shear_method_calc),
            "alpha": float(el.alpha), "beta": float(el.beta)})
    disks = [{"node": int(d.n), "m": float(d.m), "Id": float(d.Id), "Ip": float(d.Ip)}
             for d in rotor.disk_elements]
    bearings = []
    for b in rotor.bearing_elements:
        where = f"bearing at node {b.n}"
        if getattr(b, "n_link", None) is not None:
            problems.append(f"{where}: linked to node {b.n_link} (a support mass); only "
                            "bearings to ground are supported")
        for mass in ("mxx", "myy", "mxy", "myx"):
            if any(_values(getattr(b, mass, 0) or 0)):
                problems.append(f"{where}: mass coefficient {mass} is not supported")
                break
        entry: dict[str, Any] = {"node": int(b.n)}
        frequency = getattr(b, "frequency", None)
        table = frequency is not None and len(_values(frequency)) > 1
        if table:
            entry["speed_rpm"] = [f * RPM for f in _values(frequency)]
        for name in COEFFICIENTS:
            values = _values(getattr(b, name))
            entry[name] = values if table else values[0]
        bearings.append(entry)
    if getattr(rotor, "point_mass_elements", None):
        problems.append("point masses are not supported")
    if problems:
        raise SpecError(source, problems)
    return {"materials": list(materials.values()), "elements": elements, "disks": disks,
            "bearings": bearings}


def shaft_from_ross(path: str | Path) -> Shaft:
    """The validated ``Shaft`` of a ROSS rotor file."""
    rotor = load_ross_rotor(path)
    return parse_shaft(shaft_data(rotor, str(path)), str(path))


@dataclass(frozen=True)
class BallBearing:
    """A ball bearing of a catalogue geometry to put at a shaft node instead of its linear
    bearing (``import-ross --ball-bearing NODE=NAME``): SI units."""

    name: str
    ball_diameter: float
    pitch_diameter: float
    n_balls: int
    source: str = ""

    def contact_stiffness(self) -> float:
        """Hertz load-deflection constant of a ball between both races, N/m^1.5 (steel:
        E = 208 GPa, nu = 0.3; groove conformity 0.52), by ``modelgen.hertz``."""
        from modelgen.hertz import combined_stiffness, unrolled_stiffness

        k = [unrolled_stiffness(self.ball_diameter, self.pitch_diameter, CONFORMITY, STEEL_E,
                                STEEL_NU, sign) for sign in (1, -1)]
        return float(combined_stiffness(*k))


CONFORMITY, STEEL_E, STEEL_NU = 0.52, 2.08e11, 0.3
"""Groove conformity and bearing steel of an imported ball bearing's contact stiffness."""
CLEARANCE = 10e-6
"""Radial clearance of an imported ball bearing, m (the seed paper's, Table 1)."""
DAMPING = 200.0
"""Viscous damping of an imported ball bearing, N·s/m (as vakharia2015)."""


def _geometry_parameters(bearing: BallBearing, suffix: str) -> dict[str, dict]:
    where = f"bearing {bearing.name}" + (f": {bearing.source}" if bearing.source else "")
    return {
        f"inner_race_diameter{suffix}": {
            "value": bearing.pitch_diameter - bearing.ball_diameter, "unit": "m",
            "source": f"{where} (pitch - ball diameter)"},
        f"outer_race_diameter{suffix}": {
            "value": bearing.pitch_diameter + bearing.ball_diameter, "unit": "m",
            "source": f"{where} (pitch + ball diameter)"},
        f"ball_diameter{suffix}": {"value": bearing.ball_diameter, "unit": "m",
                                   "source": where},
        f"contact_stiffness{suffix}": {
            "value": bearing.contact_stiffness(), "unit": "N/m^1.5",
            "source": "Hertz, steel balls and races (E 208 GPa, nu 0.3), groove conformity "
                      "0.52 (modelgen.hertz)"},
        f"radial_clearance{suffix}": {"value": CLEARANCE, "unit": "m",
                                      "source": "assumption: the seed paper's (Table 1)"},
        f"damping{suffix}": {"value": DAMPING, "unit": "N*s/m",
                             "source": "assumption, as vakharia2015"}}


def spec_data(shaft: dict[str, Any], name: str, title: str, reference: str,
              ball_bearings: dict[int, BallBearing] | None = None,
              speed_rpm: float = 3000.0) -> dict[str, Any]:
    """A spec (plain data) of an imported shaft: ``[model]`` and ``[shaft]``; with
    ``ball_bearings`` (node: geometry) the linear bearing at each such node is replaced by
    a ball bearing ``b<node>`` with the seed model's terms (Hertz contact with clearance,
    viscous damping) and parameters (SpecError for a node without a linear bearing)."""
    ball_bearings = dict(ball_bearings or {})
    nodes = {b["node"] for b in shaft["bearings"]}
    missing = sorted(set(ball_bearings) - nodes)
    if missing:
        raise SpecError("--ball-bearing", [
            f"no bearing at node {n} to swap; the rotor's bearings are at nodes "
            f"{', '.join(str(k) for k in sorted(nodes)) or 'none'}" for n in missing])
    shaft = {**shaft, "bearings": [b for b in shaft["bearings"]
                                   if b["node"] not in ball_bearings]}
    data: dict[str, Any] = {"model": {"name": name, "title": title, "reference": reference}}
    if ball_bearings:
        shared = len({(b.ball_diameter, b.pitch_diameter, b.n_balls)
                      for b in ball_bearings.values()}) == 1
        parameters: dict[str, dict] = {"speed_rpm": {
            "value": speed_rpm, "unit": "rpm", "source": "assumption"}}
        terms = []
        bearings = []
        for node, bearing in sorted(ball_bearings.items()):
            label = f"b{node}"
            bearings.append({"name": label, "inner": "shaft", "node": node,
                             "n_balls": bearing.n_balls})
            parameters.update(_geometry_parameters(bearing, "" if shared else f"_{label}"))
            terms += [{"kind": "hertz_contact", "bearing": label},
                      {"kind": "viscous_damping", "bearing": label}]
        data["bearings"] = bearings
        data["shaft"] = shaft
        data["parameters"] = parameters
        data["terms"] = terms
    else:
        data["shaft"] = shaft
    return data


def spec_text(data: dict[str, Any], header: str) -> str:
    """The spec as TOML, after ``header`` (as comment lines)."""
    import tomli_w

    comment = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    return comment + "\n" + tomli_w.dumps(data)


MODEL_NAME = re.compile(r"^[a-z0-9][a-z0-9-]{0,62}$")
"""A spec's model name (its file's name without .toml)."""


def ross_spec_text(rotor_file: str | Path, output: str | Path,
                   ball_bearings: dict[int, BallBearing] | None = None) -> str:
    """The text of the spec ``output`` (its name is the model's) that holds the ROSS rotor
    of ``rotor_file``: validated (the ``[shaft]``, and the whole spec where it has ball
    bearings and the schema takes a shaft), SpecError otherwise."""
    output = Path(output)
    if output.suffix != ".toml" or not MODEL_NAME.match(output.stem):
        raise SpecError(str(output), ["-o: the spec's file name is its model's name: lower "
                                      "case letters, digits and '-', ending in .toml (e.g. "
                                      "my-rotor.toml)"])
    rotor = load_ross_rotor(rotor_file)
    source = Path(rotor_file).name
    shaft = shaft_data(rotor, str(rotor_file))
    data = spec_data(shaft, output.stem, f"Rotor imported from ROSS ({source})",
                     f"ROSS rotor file {source} (ross.Rotor.save); nodes as ROSS numbers them",
                     ball_bearings)
    parse_shaft(data["shaft"], str(output))
    from modelgen.spec import Spec, parse_spec

    if ball_bearings and "shaft" in Spec.model_fields:
        parse_spec(data, str(output))
    version = getattr(import_ross(), "__version__", "?")
    header = (f"Imported from the ROSS rotor file {source} (ROSS {version}) by bearingdyn "
              f"import-ross.\nNodes keep ROSS's numbers, 0 at the left end; SI units.")
    return spec_text(data, header)
