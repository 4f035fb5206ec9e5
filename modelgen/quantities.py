"""The named physical quantities a spec may set: one name per quantity, its SI unit,
its allowed range, and how it is written in equations.

The same name is used in spec files, ``--set name=value``, Python keywords and the
attributes of result files (see DESIGN.md, "Names"). Ranges are physical plausibility
bounds; a value outside them is rejected with a message naming the field and the range.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Quantity:
    """A named runtime parameter of a model."""

    name: str
    unit: str
    low: float
    high: float
    latex: str
    meaning: str
    low_inclusive: bool = True

    def range_text(self) -> str:
        left = "[" if self.low_inclusive else "("
        return f"{left}{self.low:g}, {self.high:g}] {self.unit}"

    def contains(self, value: float) -> bool:
        above = value >= self.low if self.low_inclusive else value > self.low
        return above and value <= self.high


QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("speed_rpm", "rpm", 0.0, 1.0e6, r"n", "shaft speed (rpm; ω = π n / 30 rad/s)"),
        Quantity("rotor_mass", "kg", 0.0, 1.0e5, r"M_R", "rotor mass carried by the bearing",
                 low_inclusive=False),
        Quantity("contact_stiffness", "N/m^1.5", 0.0, 1.0e13, r"k",
                 "Hertz load-deflection constant, ball and both races combined",
                 low_inclusive=False),
        Quantity("damping", "N*s/m", 0.0, 1.0e7, r"c", "viscous damping of the rotor"),
        Quantity("radial_clearance", "m", -1.0e-3, 1.0e-3, r"\gamma_0",
                 "radial internal clearance (negative: preload)"),
        Quantity("radial_load", "N", -1.0e7, 1.0e7, r"P_r",
                 "constant radial load, acting in +x"),
        Quantity("unbalance_force", "N", 0.0, 1.0e7, r"P_u", "unbalance force amplitude"),
        Quantity("unbalance_scale", "1", 0.0, 1.0e3, r"s_u",
                 "factor on a shaft's unbalance forces m e ω² ([[shaft.unbalances]]; 0: a "
                 "balanced shaft)"),
        Quantity("inner_race_diameter", "m", 0.0, 10.0, r"D_i", "inner race (groove) diameter",
                 low_inclusive=False),
        Quantity("outer_race_diameter", "m", 0.0, 10.0, r"D_o", "outer race (groove) diameter",
                 low_inclusive=False),
        Quantity("pitch_diameter", "m", 0.0, 10.0, r"D_m", "pitch circle diameter",
                 low_inclusive=False),
        Quantity("ball_diameter", "m", 0.0, 1.0, r"D_b", "ball diameter", low_inclusive=False),
        Quantity("linear_stiffness", "N/m", -1.0e13, 1.0e13, r"k_1",
                 "linear spring stiffness of the rotor support (cubic_spring term)"),
        Quantity("cubic_stiffness", "N/m^3", -1.0e25, 1.0e25, r"k_3",
                 "cubic spring coefficient (cubic_spring term; > 0 hardening)"),
        Quantity("forcing_amplitude", "N", 0.0, 1.0e7, r"F",
                 "amplitude of the harmonic force F cos(ωt) in x (harmonic_force term)"),
        Quantity("ball_density", "kg/m^3", 0.0, 1.0e5, r"\rho_b", "ball material density",
                 low_inclusive=False),
        Quantity("groove_conformity_inner", "1", 0.505, 1.0, r"f_i",
                 "inner race groove radius over ball diameter (stiffness = geometry)"),
        Quantity("groove_conformity_outer", "1", 0.505, 1.0, r"f_o",
                 "outer race groove radius over ball diameter (stiffness = geometry)"),
        Quantity("youngs_modulus", "Pa", 0.0, 1.0e13, r"E",
                 "Young's modulus of balls and races (stiffness = geometry)",
                 low_inclusive=False),
        Quantity("poisson_ratio", "1", 0.0, 0.5, r"\nu",
                 "Poisson ratio of balls and races (stiffness = geometry)"),
        Quantity("diametral_clearance", "m", -2.0e-3, 2.0e-3, r"P_d",
                 "diametral clearance, total free radial play (clearance = diametral; "
                 "negative: preload)"),
        Quantity("housing_mass", "kg", 0.0, 1.0e5, r"M_H", "mass of the housing body",
                 low_inclusive=False),
        Quantity("housing_stiffness", "N/m", 0.0, 1.0e13, r"k_H",
                 "stiffness of the housing's support to ground (each direction)"),
        Quantity("housing_damping", "N*s/m", 0.0, 1.0e7, r"c_H",
                 "damping of the housing's support to ground (each direction)"),
        Quantity("rotor_inertia", "kg*m^2", 0.0, 1.0e5, r"J_R",
                 "transverse moment of inertia of the rotor about its centre of mass",
                 low_inclusive=False),
        Quantity("station", "m", -100.0, 100.0, r"a",
                 "axial position of a bearing on its tilting inner body, from the body's centre "
                 "(station_<bearing>)"),
        Quantity("hunt_crossley_damping", "s/m", 0.0, 10.0, r"\alpha",
                 "Hunt-Crossley damping factor of the ball contacts (damping = hunt_crossley): "
                 "restitution e ≈ 1 − α v at impact speed v"),
        Quantity("contact_angle", "rad", 0.0, 1.5, r"\alpha",
                 "contact angle of the balls (kinematics: cage = pitch_diameter, ball spin)"),
        Quantity("defect_depth", "m", 0.0, 1.0e-2, r"H_d",
                 "depth of a localized defect (localized_defect term; 0: no defect)"),
        Quantity("defect_length", "m", 0.0, 5.0e-2, r"L_d",
                 "length of a localized defect along the rolling direction "
                 "(localized_defect term)", low_inclusive=False),
        Quantity("defect_angle", "rad", -7.0, 7.0, r"\phi_d",
                 "angular position of a localized defect at t = 0 (outer race: from +x, the "
                 "radial load; inner race: turning with the shaft; ball: spin angle)"),
        Quantity("line_contact_stiffness", "N/m^1.111", 0.0, 1.0e13, r"K_l",
                 "line-contact load-deflection constant of Q = K_l δ^(10/9), roller and both "
                 "races combined (line_contact term)", low_inclusive=False),
        Quantity("roller_length", "m", 0.0, 1.0, r"l",
                 "effective length of a roller's line contact (line_contact term, "
                 "stiffness = geometry)", low_inclusive=False),
    )
}

TAKEN_NAMES = frozenset({
    # generated code: modules and helpers its functions use, their parameter vector
    "ca", "math", "sys", "p", "z", "hertz15", "race_stiffness", "inner_race_load",
    # attributes of result files besides the parameters (analysis.provenance.run_attrs)
    "model", "spec_sha256", "n_balls", "bearingdyn_version", "generator", "casadi_version",
    "method", "dt", "save_every", "duration", "transient", "x0", "y0", "vx0", "vy0", "rtol",
    "atol", "shaft_hz", "cage_hz", "vc_hz", "spec_file", "state_names",
    "ftf_hz", "bpfo_hz", "bpfi_hz", "bsf_hz",
})
"""Names that are not quantities but already mean something where parameter names go (the
generated code, result-file attributes): a user-declared parameter cannot take them."""

RPM_TO_RAD_PER_S = "pi/30"
"""Factor from rpm to rad/s, as written into the equations (ω = π n / 30)."""
