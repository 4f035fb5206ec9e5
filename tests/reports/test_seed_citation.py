"""`cite` gives the seed paper as a full entry of what its own text states (issue 32,
section 4): authors, title, affiliation, e-mails, keywords and abstract; never a venue, a
year or a DOI, which the text does not state (the entry's note says they are left out)."""

from __future__ import annotations

import json

import bibtexparser
import jsonschema
import pytest
import yaml

from analysis.cite import (
    SEED_PAPER_ABSTRACT,
    SEED_PAPER_AFFILIATION,
    SEED_PAPER_EMAILS,
    SEED_PAPER_KEY,
    SEED_PAPER_KEYWORDS,
    citation,
)
from tests.conftest import ROOT

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

INVENTED = ("doi", "journal", "booktitle", "year", "volume", "pages", "publisher", "url",
            "issn", "isbn")


def _seed_entry() -> dict:
    parser = bibtexparser.bparser.BibTexParser(common_strings=False,
                                               ignore_nonstandard_types=False)
    entries = {e["ID"]: e for e in bibtexparser.loads(citation("vakharia2015"),
                                                      parser=parser).entries}
    return entries[SEED_PAPER_KEY]


def test_bibtex_seed_entry_is_full_and_invents_nothing():
    entry = _seed_entry()
    assert entry["author"] == "Vakharia, V. and Gupta, V. K. and Kankar, P. K."
    assert "Jabalpur" in entry["institution"] and entry["address"].endswith("India")
    for email in SEED_PAPER_EMAILS:
        assert email in entry["email"]
    assert "pavankankar@gmail.com (corresponding)" in entry["email"]
    assert entry["keywords"].split(", ") == list(SEED_PAPER_KEYWORDS)
    assert entry["abstract"] == SEED_PAPER_ABSTRACT
    assert entry["abstract"].startswith("This paper aims to study the influence of varying")
    assert not set(INVENTED) & set(entry), sorted(set(INVENTED) & set(entry))
    assert "states no venue, year" in entry["note"] and "DOI" in entry["note"]


def test_cff_seed_reference_is_valid_and_invents_nothing():
    schema = json.loads((ROOT / "tests" / "data" / "cff-schema-1.2.0.json").read_text())
    data = yaml.safe_load(citation("vakharia2015", "cff"))
    jsonschema.validate(data, schema)
    ref = data["references"][0]
    assert ref["type"] == "generic"  # where it appeared is not stated
    assert [a["email"] for a in ref["authors"]] == list(SEED_PAPER_EMAILS)
    assert {a["affiliation"] for a in ref["authors"]} == {SEED_PAPER_AFFILIATION}
    assert ref["abstract"] == SEED_PAPER_ABSTRACT
    assert ref["keywords"] == list(SEED_PAPER_KEYWORDS)
    keys = {k.replace("-", "") for k in ref}
    assert not keys & {"doi", "journal", "year", "volume", "start", "end", "publisher",
                       "url", "conference", "collectiontitle"}
    assert "DOI" in ref["notes"]
