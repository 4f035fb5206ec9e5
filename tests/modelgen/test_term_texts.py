"""Term texts and model cards read as text (issue 32, section 4): no raw TeX such as
``^{3/2}`` in the term texts that the cards, the generated code and the spec reference
show, and the docs keep each parameter name of a card on one line."""

from __future__ import annotations

import re

import pytest

from docs.hooks import model_cards, model_page, unbroken_names
from modelgen.terms import TERM_CLASSES
from tests.conftest import ROOT

RAW_TEX = re.compile(r"\^\{|\\[a-zA-Z]+|\$")


@pytest.mark.parametrize("cls", TERM_CLASSES, ids=lambda c: c.__name__)
def test_term_summaries_have_no_raw_tex(cls):
    assert not RAW_TEX.search(cls.summary), cls.summary


def test_generated_term_lines_have_no_raw_tex():
    for card in sorted((ROOT / "generated").glob("*/MODEL.md")):
        terms = card.read_text(encoding="utf-8").split("## Terms", 1)[1].split("\n## ", 1)[0]
        assert not RAW_TEX.search(terms), (card, terms)


def test_every_parameter_name_of_every_card_is_kept_on_one_line():
    cards = model_cards()
    assert cards
    for folder, name, text in cards:
        table = text.split("## Parameters", 1)[1].split("\n## ", 1)[0]
        names = re.findall(r"^\| `([^`]+)` \|", table, re.M)
        assert names, folder
        page = model_page(folder, name, text)
        for parameter in names:
            assert (f'<span class="bd-name" style="white-space: nowrap">`{parameter}`</span>'
                    in page), (folder, parameter)


def test_only_a_first_cell_name_is_wrapped():
    text = "| name | x |\n|---|---|\n| `a_b` | `c_d` |\nsee `e_f` |"
    out = unbroken_names(text)
    assert out.count("nowrap") == 1 and "`c_d`" in out and "see `e_f`" in out
