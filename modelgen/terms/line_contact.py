"""Line contact of cylindrical rollers: Q = K max(0, δ_i)^{10/9} per roller (N, δ in m).

A roller of effective length l pressed between two races deforms along a line; Palmgren's
empirical law for one roller–race contact of steel on steel is

    δ = 3.84·10⁻⁵ Q^0.9 / l^0.8        (δ in mm, Q in N, l in mm),

i.e. Q = K_c δ^{10/9} with K_c = 8.06·10⁴ l^{8/9} N/mm^{10/9} (A. Palmgren, Ball and Roller
Bearing Engineering, 3rd ed., Burbank, Philadelphia, 1959; quoted by T. A. Harris,
M. N. Kotzalas, Rolling Bearing Analysis, 5th ed., Vol. 1, CRC 2007, ch. 6, and used for the
contact stiffness of roller bearings since). It does not depend on the races' radii, so the
inner and outer contacts are alike and in series: at one load δ = 2 δ_c, and
K = K_c · 2^{−10/9}. In SI: K_c = (l^{0.8}/c)^{10/9} with c = 3.84·10⁻⁵ · 10⁻³ · 10^{−2.4} m
per N^0.9 m^−0.8 (the mm of δ and of l converted).

Options of ``line_contact``: ``stiffness = "geometry"`` (Palmgren, from ``roller_length``)
or ``"given"`` (``line_contact_stiffness``, N/m^(10/9), rollers and both races combined);
the clearance and cage options of ``hertz_contact``; no contact damping. The rolling
element's diameter is ``ball_diameter`` (the roller diameter), so the cage kinematics and
the defect frequencies are those of the ball bearing with the same geometry.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from modelgen.lazy import sympy as sp
from modelgen.symbols import Context
from modelgen.terms.contact import CLEARANCE_PARAMETER, HertzContact, deflection

PALMGREN_MM = 3.84e-5
"""Palmgren's coefficient: δ = 3.84e-5 Q^0.9 / l^0.8 with δ, l in mm and Q in N."""
EXPONENT = (10 / 9, 17)
"""10/9, as the double nearest to it (the generated code prints it as 1.1111111111111112):
the arguments of its SymPy Float."""
LINE_STIFFNESS: dict[str, tuple[str, ...]] = {
    "given": ("line_contact_stiffness",), "geometry": ("roller_length",),
}


def palmgren_constant(length: sp.Expr | float) -> sp.Expr:
    """K_c (N/m^(10/9)) of one roller–race line contact of ``length`` (m), SI form."""
    coefficient = PALMGREN_MM * 1e-3 * 10.0 ** -2.4
    return sp.Float(coefficient ** -(10 / 9), 17) * length ** sp.Float(8 / 9, 17)


class LineContact(HertzContact):
    """Cylindrical rollers: line contact with both races, Q = K max(0, δ_i)^{10/9}."""

    kind: Literal["line_contact"] = "line_contact"  # type: ignore[assignment]
    damping: Literal["none"] = "none"  # type: ignore[assignment]

    summary: ClassVar[str] = (
        "line contact of rollers with clearance, load K·max(0, x cos θ_i + y sin θ_i − γ_0)"
        "^(10/9) per roller (Palmgren)"
    )

    def required_parameters(self) -> tuple[str, ...]:
        cage = (("inner_race_diameter", "outer_race_diameter")
                if self.cage == "race_diameters" else ("ball_diameter", "pitch_diameter"))
        return tuple(dict.fromkeys((*LINE_STIFFNESS[self.stiffness],
                                    CLEARANCE_PARAMETER[self.clearance], *self.needs, *cage)))

    def role_quantities(self) -> dict[str, str]:
        """As ``hertz_contact``, but no Hertz constant: K of a line contact is no k of
        Q = k δ^{3/2}."""
        roles = super().role_quantities()
        roles.pop("contact_stiffness", None)
        return roles

    def stiffness_constant(self, ctx: Context) -> sp.Expr:
        """K of Q = K δ^{10/9} (N/m^(10/9)): given, or Palmgren's two contacts in series."""
        if self.stiffness == "given":
            return ctx.p("line_contact_stiffness")
        return palmgren_constant(ctx.p("roller_length")) * sp.Float(2.0 ** (-10 / 9), 17)

    def ball_load(self, ctx: Context) -> sp.Expr:
        delta = deflection(ctx, self.clearance)
        return self.stiffness_constant(ctx) * sp.Max(0, delta) ** sp.Float(*EXPONENT)

    def _describe_stiffness(self) -> str:
        if self.stiffness == "given":
            return ""
        return ("; K = 2^(−10/9)·K_c, K_c = 8.06e4 l^(8/9) N/mm^(10/9) per roller–race contact "
                "(Palmgren; l = roller_length; modelgen/terms/line_contact.py)")
