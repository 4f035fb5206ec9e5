"""Force terms, one module per physical term. ``TERMS`` maps a spec's ``kind`` to its class."""

from modelgen.terms.base import Term
from modelgen.terms.centrifugal import Centrifugal
from modelgen.terms.contact import HertzContact
from modelgen.terms.damping import ViscousDamping
from modelgen.terms.defects import LocalizedDefect
from modelgen.terms.expression import ExpressionTerm
from modelgen.terms.line_contact import LineContact
from modelgen.terms.loads import HarmonicForce, RadialLoad, Unbalance
from modelgen.terms.springs import CubicSpring
from modelgen.terms.two_contact import TwoContact
from modelgen.terms.waviness import BallWaviness, InnerRaceWaviness, OuterRaceWaviness

TERM_CLASSES: tuple[type[Term], ...] = (
    HertzContact, Centrifugal, ViscousDamping, RadialLoad, Unbalance, CubicSpring,
    HarmonicForce, ExpressionTerm, TwoContact, LocalizedDefect, OuterRaceWaviness,
    InnerRaceWaviness, BallWaviness, LineContact,
)
TERMS: dict[str, type[Term]] = {cls.model_fields["kind"].default: cls for cls in TERM_CLASSES}

__all__ = ["TERMS", "TERM_CLASSES", "BallWaviness", "Centrifugal", "CubicSpring",
           "ExpressionTerm", "HarmonicForce", "HertzContact", "InnerRaceWaviness",
           "LineContact", "LocalizedDefect", "OuterRaceWaviness", "RadialLoad", "Term",
           "TwoContact", "Unbalance", "ViscousDamping"]
