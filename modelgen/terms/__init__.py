"""Force terms, one module per physical term. ``TERMS`` maps a spec's ``kind`` to its class."""

from modelgen.terms.base import Term
from modelgen.terms.centrifugal import Centrifugal
from modelgen.terms.contact import HertzContact
from modelgen.terms.damping import ViscousDamping
from modelgen.terms.defects import LocalizedDefect
from modelgen.terms.expression import ExpressionTerm
from modelgen.terms.loads import HarmonicForce, RadialLoad, Unbalance
from modelgen.terms.springs import CubicSpring
from modelgen.terms.two_contact import TwoContact

TERM_CLASSES: tuple[type[Term], ...] = (
    HertzContact, Centrifugal, ViscousDamping, RadialLoad, Unbalance, CubicSpring,
    HarmonicForce, ExpressionTerm, TwoContact, LocalizedDefect,
)
TERMS: dict[str, type[Term]] = {cls.model_fields["kind"].default: cls for cls in TERM_CLASSES}

__all__ = ["TERMS", "TERM_CLASSES", "Centrifugal", "CubicSpring", "ExpressionTerm", "HarmonicForce",
           "HertzContact", "LocalizedDefect", "RadialLoad", "Term", "TwoContact", "Unbalance",
           "ViscousDamping"]
