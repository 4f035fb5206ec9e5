"""Bearings by name: a small cited catalogue of ball-bearing geometries, a geometry typed out
(``d=…,D=…,z=…,angle=…``), or a shipped model's bearing, and their defect frequencies.

Convention (the one of the whole project, :class:`analysis.model.FaultFrequencies`): with the
outer race fixed, ball diameter d, pitch diameter D, z balls and contact angle α,

    FTF = f_s/2·(1 − (d/D) cos α)          (cage, fundamental train)
    BPFO = z·FTF                            (ball pass, outer race)
    BPFI = z·(f_s − FTF)                    (ball pass, inner race)
    BSF = D/(2d)·f_s·(1 − ((d/D) cos α)²)   (ball spin: one turn of a ball about its own axis)

and 2xBSF, the rate at which a spall on a ball strikes the races (once on each per spin):
the figure the CWRU Bearing Data Center lists as "rolling element" frequency. The formulas
are computed in one place, ``FaultFrequencies.from_kinematics`` (from f_s, FTF, z, α), for
simulated runs and measured records alike (R. B. Randall, J. Antoni, "Rolling element
bearing diagnostics—A tutorial", MSSP 25 (2011) 485–520, Eqs. 1–4).

Catalogue (:data:`CATALOGUE`):

* ``6205-cwru`` (``6205-2rs``, ``6205-de``): the drive-end 6205-2RS JEM SKF of the Case
  Western Reserve University Bearing Data Center (d = 0.3126 in, D = 1.537 in, 9 balls);
* ``6203-cwru`` (``6203-2rs``, ``6203-fe``): its fan-end 6203-2RS JEM SKF (d = 0.2656 in,
  D = 1.122 in, 8 balls);
* ``6205-seed`` (``6205``, ``6205-vakharia``): the 6205 of the seed paper (Vakharia, Gupta,
  Kankar, Table 1: d = 4.762 mm, races 18.738 and 28.262 mm, so D = 23.5 mm, their mean,
  docs/paper-slips.md S5) with the 9 balls of the project's 6205 defect models.

Inches are converted to metres exactly (1 in = 25.4 mm).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from analysis.errors import InputError
from analysis.model import FaultFrequencies

INCH = 0.0254
"""Metres per inch (exact)."""
BSF_CONVENTION = ("BSF = ball spin frequency (D/2d)·f_s·(1 − (d/D·cos α)²); 2xBSF = twice it, "
                  "the rate a ball spall strikes the races (the CWRU data centre's "
                  "'rolling element' figure)")
"""How the project names the ball lines (said with every table of defect frequencies)."""
LINES = ("FTF", "BPFO", "BPFI", "BSF", "2xBSF")
"""The defect frequencies of :meth:`Bearing.frequencies`, in this order."""


@dataclass(frozen=True)
class Bearing:
    """A ball bearing's geometry (SI units) and where it comes from."""

    name: str
    ball_diameter_m: float
    pitch_diameter_m: float
    n_balls: int
    contact_angle_rad: float
    source: str

    def __post_init__(self) -> None:
        check_geometry(self.ball_diameter_m, self.pitch_diameter_m, self.n_balls,
                       self.contact_angle_rad, self.name)

    @property
    def cage_ratio(self) -> float:
        """FTF / f_s = (1 − (d/D) cos α)/2 (outer race fixed, rolling without slip)."""
        return 0.5 * (1.0 - self.ball_diameter_m / self.pitch_diameter_m
                      * math.cos(self.contact_angle_rad))

    def frequencies(self, shaft_hz: float) -> dict[str, float]:
        """FTF, BPFO, BPFI, BSF and 2xBSF (Hz) at the shaft frequency ``shaft_hz`` (Hz), by
        ``FaultFrequencies.from_kinematics``, the project's one formula."""
        shaft = float(shaft_hz)
        if not (math.isfinite(shaft) and shaft > 0):
            raise InputError(f"speed: must be a finite shaft speed > 0 Hz, got {shaft_hz}")
        table = FaultFrequencies.from_kinematics(shaft, self.cage_ratio * shaft, self.n_balls,
                                                 self.contact_angle_rad).as_dict()
        return {**table, "2xBSF": 2.0 * table["BSF"]}

    def orders(self) -> dict[str, float]:
        """The defect frequencies as multiples of the shaft speed."""
        return self.frequencies(1.0)

    def as_dict(self) -> dict:
        """The geometry (SI), its source, the multiples of shaft speed and the convention."""
        return {**asdict(self), "orders": self.orders(), "convention": BSF_CONVENTION}


def check_geometry(d: float, pitch: float, z: int, angle: float, name: str = "") -> None:
    """InputError unless the bearing can exist: 0 < d < D (a ball larger than the pitch
    circle cannot roll on it), z ≥ 3 whole balls that fit on the pitch circle
    (z ≤ π/asin(d/D)), 0 ≤ α < 90°."""
    label = f"bearing: {name}: " if name else "bearing: "
    values = (d, pitch, angle)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        raise InputError(f"{label}the diameters and angle must be finite numbers, got "
                         f"d={d}, D={pitch}, angle={angle}", field="bearing")
    if not 0 < d < pitch:
        raise InputError(f"{label}the ball diameter d must be > 0 and smaller than the pitch "
                         f"diameter D, got d={d * 1e3:g} mm, D={pitch * 1e3:g} mm", field="bearing")
    if isinstance(z, bool) or int(z) != z or z < 3:
        raise InputError(f"{label}the number of balls z must be a whole number >= 3, got {z}",
                         field="bearing")
    fit = math.floor(math.pi / math.asin(d / pitch))
    if z > fit:
        raise InputError(f"{label}{z} balls of {d * 1e3:g} mm do not fit on a pitch circle "
                         f"of {pitch * 1e3:g} mm (at most {fit})", field="bearing")
    if not 0 <= angle < math.pi / 2:
        raise InputError(f"{label}the contact angle must be in [0, 90) degrees, got "
                         f"{math.degrees(angle):g}", field="bearing")


CWRU = ("Case Western Reserve University Bearing Data Center, bearing information "
        "(../shared/data/cwru/README.md)")

CATALOGUE: dict[str, Bearing] = {
    "6205-cwru": Bearing("6205-cwru", 0.3126 * INCH, 1.537 * INCH, 9, 0.0,
                         f"6205-2RS JEM SKF, drive end; {CWRU}: d = 0.3126 in, D = 1.537 in"),
    "6203-cwru": Bearing("6203-cwru", 0.2656 * INCH, 1.122 * INCH, 8, 0.0,
                         f"6203-2RS JEM SKF, fan end; {CWRU}: d = 0.2656 in, D = 1.122 in"),
    "6205-seed": Bearing("6205-seed", 4.762e-3, (18.738e-3 + 28.262e-3) / 2, 9, 0.0,
                         "seed paper (Vakharia, Gupta, Kankar) Table 1: d = 4.762 mm, D the "
                         "mean of the races 18.738 and 28.262 mm (docs/paper-slips.md S5); 9 "
                         "balls as the 6205 defect models; contact angle 0"),
}
"""The cited bearings, by canonical name."""

ALIASES = {"6205-2rs": "6205-cwru", "6205-de": "6205-cwru", "6205-skf": "6205-cwru",
           "6203-2rs": "6203-cwru", "6203-fe": "6203-cwru", "6203-skf": "6203-cwru",
           "6205": "6205-seed", "6205-vakharia": "6205-seed"}
"""Other names of the catalogue's bearings."""

_FIELDS = {"d": "ball diameter (mm)", "D": "pitch diameter (mm)", "z": "balls",
           "angle": "contact angle (degrees)"}


def parse_geometry(text: str) -> Bearing:
    """``d=7.94,D=39.04,z=9,angle=0``: ball and pitch diameters in mm, the number of balls,
    the contact angle in degrees (optional, default 0). InputError naming ``bearing``."""
    values: dict[str, str] = {}
    for part in text.split(","):
        key, sep, value = (s.strip() for s in part.partition("="))
        if not sep or key not in _FIELDS or key in values:
            raise InputError(f"bearing: a geometry is d=MM,D=MM,z=BALLS[,angle=DEG] "
                             f"(d, D in mm, angle in degrees), got {text!r}", field="bearing")
        values[key] = value
    missing = [k for k in ("d", "D", "z") if k not in values]
    if missing:
        raise InputError(f"bearing: the geometry lacks {', '.join(missing)} "
                         f"(d=MM,D=MM,z=BALLS[,angle=DEG]), got {text!r}", field="bearing")
    try:
        d, pitch = float(values["d"]) * 1e-3, float(values["D"]) * 1e-3
        angle = math.radians(float(values.get("angle", "0")))
        z_float = float(values["z"])
    except ValueError:
        raise InputError(f"bearing: d, D, z and angle must be numbers, got {text!r}",
                         field="bearing") from None
    z = int(z_float) if z_float.is_integer() else z_float
    return Bearing(text, d, pitch, z, angle,  # type: ignore[arg-type]
                   "given: d, D in mm, angle in degrees")


def model_bearing(name: str, bearing: str | None = None) -> Bearing:
    """The bearing of a shipped model (its first, or ``bearing``) at its default parameters:
    the ball count, contact angle and ball and pitch diameters of its spec; where the
    model's cage does not roll on its pitch diameter (the seed paper's Eq. 1 takes the races),
    the ball of its cage kinematics, d = D·(1 − 2·FTF/f_s)/cos α, so that the frequencies
    equal the model's own (``Model.frequencies``)."""
    from analysis.model import balls_that_fit, load_model

    model = load_model(name)
    if not model.bearing_names:
        raise InputError(f"bearing: model '{model.name}' has no bearing", field="bearing")
    which = bearing or model.bearing_names[0]
    if which not in model.bearing_names:
        raise InputError(f"bearing: model '{model.name}' has no bearing '{which}'; "
                         f"bearings: {', '.join(model.bearing_names)}", field="bearing")
    values = model.defaults
    index = model.bearing_names.index(which)
    n = model.default_structure[index]
    freqs = model.frequencies(values=values)
    fault = freqs.faults[which]
    fit = balls_that_fit(values, which)
    if fit is None:
        raise InputError(f"bearing: model '{model.name}' gives no ball and pitch diameter "
                         f"for bearing '{which}'", field="bearing")
    _, d, pitch = fit
    angle = float(values.get(f"contact_angle_{which}", values.get("contact_angle", 0.0)))
    races = [values.get(f"{k}_{which}", values.get(k)) for k in ("inner_race_diameter",
                                                                 "outer_race_diameter")]
    if None not in races:
        pitch = (float(races[0]) + float(races[1])) / 2  # type: ignore[arg-type]
    ratio = fault.ftf / freqs.shaft_hz
    source = f"model {model.name} ({model.spec_file}), bearing '{which}', defaults"
    effective = pitch * (1 - 2 * ratio) / math.cos(angle)
    if abs(effective - d) > 1e-9 * pitch:
        source += (f"; ball of its cage kinematics {effective * 1e3:.4g} mm (spec "
                   f"{d * 1e3:.4g} mm)")
    return Bearing(model.name if len(model.bearing_names) == 1 else f"{model.name}:{which}",
                   effective, pitch, int(n), angle, source)


def lookup(text: str) -> Bearing:
    """A bearing by catalogue name or alias (case-insensitive), by geometry
    (``d=…,D=…,z=…[,angle=…]``, mm and degrees), or by a shipped model's name
    (``6205-inner-defect``, ``vakharia2015``; ``model:bearing`` for one of several)."""
    key = str(text).strip()
    low = key.lower()
    if not key:
        raise InputError("bearing: give a catalogue name (" + ", ".join(CATALOGUE)
                         + "), d=MM,D=MM,z=BALLS[,angle=DEG] or a model's name", field="bearing")
    if low in CATALOGUE or low in ALIASES:
        return CATALOGUE[ALIASES.get(low, low)]
    if "=" in key:
        return parse_geometry(key)
    from analysis.model import available_models

    name, _, which = key.partition(":")
    if name in available_models() or name.endswith(".toml"):
        return model_bearing(name, which or None)
    names = ", ".join([*CATALOGUE, *ALIASES])
    raise InputError(f"bearing: no bearing {key!r}; give one of {names}, a geometry "
                     f"d=MM,D=MM,z=BALLS[,angle=DEG] (mm, degrees) or a model's name "
                     f"(bearingdyn models)", field="bearing")


def frequency_table(bearing: Bearing, shaft_hz: float) -> list[str]:
    """Lines of text: the defect frequencies (Hz and multiples of f_s) and the convention."""
    rows = [f"{bearing.name}: d = {bearing.ball_diameter_m * 1e3:.4g} mm, D = "
            f"{bearing.pitch_diameter_m * 1e3:.4g} mm, z = {bearing.n_balls}, contact angle "
            f"{math.degrees(bearing.contact_angle_rad):g} deg ({bearing.source})"]
    for key, value in bearing.frequencies(shaft_hz).items():
        rows.append(f"  {key:>6} {value:9.2f} Hz  {value / shaft_hz:8.4f} x shaft")
    rows.append(f"  ({BSF_CONVENTION})")
    return rows

