"""How to cite a model: a BibTeX entry or a Citation File Format (CFF 1.2.0) file.

A model is cited by what pins its equations down: its name and title, the path of its spec
as cited (``modelgen/specs/NAME.toml`` for a shipped model, the real absolute path for a spec
of your own), the spec's SHA-256 (``sha256sum`` of the file gives the same), the versions of
bearingdyn, SymPy and CasADi that generated its code, and where its equations come from (the
spec's ``reference``). Models built on the seed paper (their reference names Vakharia) also
cite the paper itself, with everything its own text states: the title, the three authors,
their affiliation (Mechanical Engineering Discipline, PDPM Indian Institute of Information
Technology, Design and Manufacturing Jabalpur, Jabalpur 482005, India) and e-mail addresses
(the corresponding author marked), the abstract and the keywords:

    V. Vakharia, V. K. Gupta, P. K. Kankar, *Nonlinear dynamic analysis of ball bearings due
    to varying number of balls and centrifugal force*.

The seed paper's text names no venue, year, volume, pages or DOI, so none is given here and
the entry says so in its ``note`` (add them from the publisher's page when you cite it; this
module never guesses them).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from analysis.model import Model, load_model
from analysis.provenance import package_version

Format = Literal["bibtex", "cff"]
FORMATS: tuple[str, ...] = ("bibtex", "cff")

SEED_PAPER_TITLE = ("Nonlinear Dynamic Analysis of Ball Bearings Due to Varying Number of "
                    "Balls and Centrifugal Force")
SEED_PAPER_AUTHORS = (("Vakharia", "V."), ("Gupta", "V. K."), ("Kankar", "P. K."))
"""The seed paper's authors (family name, initials), as its first page gives them."""
SEED_PAPER_EMAILS = ("vinayvakharia4343@gmail.com", "vkgupta@iiitdmj.ac.in",
                     "pavankankar@gmail.com")
"""The authors' e-mail addresses, in the order of ``SEED_PAPER_AUTHORS``, as the first page
gives them."""
SEED_PAPER_CORRESPONDING = "Kankar"
"""The author the first page marks as corresponding (✉)."""
SEED_PAPER_INSTITUTION = ("Mechanical Engineering Discipline, PDPM Indian Institute of "
                          "Information Technology, Design and Manufacturing Jabalpur")
SEED_PAPER_ADDRESS = "Jabalpur 482005, India"
SEED_PAPER_AFFILIATION = f"{SEED_PAPER_INSTITUTION}, {SEED_PAPER_ADDRESS}"
"""The affiliation of all three authors, as the first page gives it."""
SEED_PAPER_KEYWORDS = ("Nonlinear dynamics", "Ball bearing", "Unbalanced rotor",
                       "Centrifugal force", "Poincare map")
SEED_PAPER_ABSTRACT = (
    "This paper aims to study the influence of varying number of balls on nonlinear dynamic "
    "behavior of an unbalanced rotor supported by ball bearings. Centrifugal force due to "
    "rotation of balls is included in the model. An oscillating spring-mass-damper is "
    "considered to formulate the contact between races and rolling elements. Stiffness for "
    "the spring-mass-damper system is calculated using Hertzian elastic contact deformation "
    "theory. The results show appearance of regions of periodic, sub-harmonic and chaotic "
    "behavior on response of the system. Invariably, the route to chaos is seen to be "
    "intermittency mechanism by period doubling behavior. Poincare maps and frequency "
    "responses are used to explain and to study the system behavior.")
"""The seed paper's abstract, word for word."""
SEED_PAPER_UNSTATED = ("The source text states no venue, year, volume, pages, publisher or "
                       "DOI; add them from the publisher's record")
"""What the entry says about the fields it leaves out."""
SEED_PAPER_KEY = "vakharia-ball-bearings"
SOFTWARE_AUTHOR = "The bearingdyn developers"
REPOSITORY_LICENSE = "MIT"


@dataclass(frozen=True)
class ModelCitation:
    """What a citation of one model says (plain strings)."""

    name: str
    title: str
    spec_file: str
    """The spec's path as cited: ``modelgen/specs/NAME.toml`` or the absolute path."""
    spec_sha256: str
    reference: str
    """Where the equations come from (the spec's ``reference``; may be empty)."""
    bearingdyn_version: str
    generator: dict[str, str]
    """Versions that generated the code: ``{"bearingdyn": …, "sympy": …, "casadi": …}``."""

    @property
    def key(self) -> str:
        return "bearingdyn-" + re.sub(r"[^a-z0-9-]", "-", self.name.lower())

    @property
    def cites_seed_paper(self) -> bool:
        return "vakharia" in self.reference.lower()

    @property
    def generator_text(self) -> str:
        return ", ".join(f"{k} {v}" for k, v in self.generator.items())


def model_citation(model: Model | str | Path) -> ModelCitation:
    """The facts a citation of ``model`` (a ``Model``, a model name, a spec path or a
    generated folder) states."""
    model = model if isinstance(model, Model) else load_model(model)
    module = model.module
    return ModelCitation(name=model.name, title=str(module.TITLE), spec_file=model.spec_file,
                         spec_sha256=model.spec_sha256,
                         reference=str(getattr(module, "REFERENCE", "") or ""),
                         bearingdyn_version=package_version(),
                         generator={str(k): str(v) for k, v in module.GENERATOR.items()})


def citation(model: Model | str | Path, format: Format = "bibtex") -> str:
    """The citation of ``model`` as text: ``"bibtex"`` (a ``@misc`` entry for the model and,
    for a model on the seed paper, one for the paper) or ``"cff"`` (a CITATION.cff file,
    CFF 1.2.0, the paper among its references)."""
    if format not in FORMATS:
        from analysis.errors import InputError

        raise InputError(f"format: must be one of {', '.join(FORMATS)}, got {format!r}")
    facts = model_citation(model)
    return bibtex(facts) if format == "bibtex" else cff(facts)


_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "{": r"\{", "}": r"\}", "&": r"\&", "%": r"\%",
                  "$": r"\$", "#": r"\#", "_": r"\_", "~": r"\textasciitilde{}",
                  "^": r"\textasciicircum{}"}


def latex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped (for fields a style typesets)."""
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in text)


def _verbatim(text: str) -> str:
    """``text`` for a field no style typesets (paths, hashes): kept as it is, braces
    escaped so the entry stays balanced."""
    return text.replace("{", r"\{").replace("}", r"\}")


def _entry(kind: str, key: str, fields: list[tuple[str, str]]) -> str:
    width = max(len(name) for name, _ in fields)
    body = ",\n".join(f"  {name:<{width}} = {{{value}}}" for name, value in fields)
    return f"@{kind}{{{key},\n{body}\n}}\n"


def bibtex(facts: ModelCitation) -> str:
    """BibTeX entries: the model (``@misc``; ``specfile``, ``sha256`` and ``generator`` are
    extra fields kept verbatim for machines) and, when the model is built on it, the seed
    paper."""
    note = (f"Model {facts.name}, code generated by {facts.generator_text} from the spec "
            f"{facts.spec_file}, SHA-256 {facts.spec_sha256}")
    if facts.reference:
        note += f". Equations: {facts.reference.rstrip('.')}"
    fields = [("author", "{" + SOFTWARE_AUTHOR + "}"),
              ("title", "{bearingdyn model " + latex_escape(facts.name) + "}: "
               + latex_escape(facts.title)),
              ("howpublished", f"bearingdyn {latex_escape(facts.bearingdyn_version)}, "
                               f"spec {latex_escape(facts.spec_file)}"),
              ("version", latex_escape(facts.bearingdyn_version)),
              ("note", latex_escape(note)),
              ("specfile", _verbatim(facts.spec_file)),
              ("sha256", facts.spec_sha256),
              ("generator", _verbatim(facts.generator_text))]
    if facts.cites_seed_paper:
        fields.append(("related", SEED_PAPER_KEY))
    out = _entry("misc", facts.key, fields)
    if facts.cites_seed_paper:
        out += "\n" + seed_paper_bibtex()
    return out


def seed_paper_bibtex() -> str:
    """The seed paper as a full BibTeX ``@misc`` entry of what its own text states: authors,
    title, affiliation (``institution`` and ``address``), e-mail addresses, keywords and
    abstract, and a ``note`` naming the fields it leaves out because the text does not
    state them (venue, year, DOI: never guessed)."""
    authors = " and ".join(f"{family}, {given}" for family, given in SEED_PAPER_AUTHORS)
    emails = ", ".join(f"{family}: {email}" + (" (corresponding)"
                                               if family == SEED_PAPER_CORRESPONDING else "")
                       for (family, _), email in zip(SEED_PAPER_AUTHORS, SEED_PAPER_EMAILS,
                                                     strict=True))
    return _entry("misc", SEED_PAPER_KEY, [
        ("author", authors), ("title", "{" + SEED_PAPER_TITLE + "}"),
        ("institution", latex_escape(SEED_PAPER_INSTITUTION)),
        ("address", latex_escape(SEED_PAPER_ADDRESS)),
        ("email", _verbatim(emails)), ("keywords", ", ".join(SEED_PAPER_KEYWORDS)),
        ("abstract", latex_escape(SEED_PAPER_ABSTRACT)),
        ("note", latex_escape(SEED_PAPER_UNSTATED))])


def _yaml(value: object, indent: int = 0) -> str:
    """A YAML block for plain values: strings double-quoted (JSON strings are YAML)."""
    pad = " " * indent
    if isinstance(value, dict):
        lines = []
        for k, v in value.items():
            if isinstance(v, (dict, list)):
                lines.append(f"{pad}{k}:\n{_yaml(v, indent + 2)}")
            else:
                lines.append(f"{pad}{k}: {json.dumps(v, ensure_ascii=False)}")
        return "\n".join(lines)
    if isinstance(value, list):
        lines = []
        for item in value:
            block = _yaml(item, indent + 2)
            lines.append(f"{pad}- {block.lstrip()}")
        return "\n".join(lines)
    return pad + json.dumps(value, ensure_ascii=False)


def seed_paper_cff() -> dict:
    """The seed paper as a CFF reference: type ``generic`` (its text does not say where it
    appeared), the authors with their affiliation and e-mail, the abstract, the keywords and
    a note on what is left out."""
    return {"type": "generic", "title": SEED_PAPER_TITLE,
            "authors": [{"family-names": family, "given-names": given,
                         "affiliation": SEED_PAPER_AFFILIATION, "email": email}
                        for (family, given), email in zip(SEED_PAPER_AUTHORS,
                                                          SEED_PAPER_EMAILS, strict=True)],
            "abstract": SEED_PAPER_ABSTRACT, "keywords": list(SEED_PAPER_KEYWORDS),
            "notes": SEED_PAPER_UNSTATED + "."}


def cff(facts: ModelCitation) -> str:
    """A CITATION.cff (CFF 1.2.0) for the model: the spec's hash as an identifier, its path,
    the generator versions and the equations' reference in the abstract; the seed paper
    among the references when the model is built on it."""
    abstract = (f"{facts.title}. Spec file {facts.spec_file} (SHA-256 {facts.spec_sha256}); "
                f"code generated by {facts.generator_text}.")
    if facts.reference:
        abstract += f" Equations: {facts.reference.rstrip('.')}."
    data: dict = {
        "cff-version": "1.2.0",
        "message": f"If you use the bearingdyn model {facts.name}, please cite it as below, "
                   "with the SHA-256 of its spec.",
        "type": "software",
        "title": f"bearingdyn model {facts.name}: {facts.title}",
        "version": facts.bearingdyn_version,
        "authors": [{"name": SOFTWARE_AUTHOR}],
        "license": REPOSITORY_LICENSE,
        "abstract": abstract,
        "identifiers": [{"type": "other", "value": f"sha256:{facts.spec_sha256}",
                         "description": f"SHA-256 of the spec file {facts.spec_file}"}],
        "keywords": ["rotor dynamics", "ball bearing", "nonlinear dynamics", facts.name],
    }
    if facts.cites_seed_paper:
        data["references"] = [seed_paper_cff()]
    return _yaml(data) + "\n"
