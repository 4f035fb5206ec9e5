"""One forcing vocabulary: periods and sections are parsed by one grammar
(``analysis.forcing``), each with its own words and messages; a model forced at a
parameter's period names that parameter by its role, whatever it is called."""

from __future__ import annotations

import re
import tomllib
from fractions import Fraction

import pytest
import tomli_w

from analysis.errors import InputError
from analysis.forcing import PERIOD, SECTION, ForcingName, period_parameter
from analysis.integrate.checks import fastest_forcing
from analysis.integrate.flow import Period
from analysis.integrate.simulate import simulate
from analysis.model import System, load_model
from analysis.signal.poincare import parse_section, section_period
from analysis.stability.classify import default_section
from analysis.stability.periodic import default_period
from tests.conftest import SPECS


@pytest.mark.parametrize(("text", "parsed"), [
    ("vc", ForcingName("vc")), ("shaft:3", ForcingName("shaft", 3)),
    ("vc[left]:2", ForcingName("vc", 2, name="left")),
    ("ratio:37/15", ForcingName("ratio", ratio=Fraction(37, 15))),
    (" param:forcing_period ", ForcingName("param", name="forcing_period")),
])
def test_periods_parse_with_the_shared_grammar(text, parsed):
    assert PERIOD.parse(text) == parsed
    period = Period.parse(text)
    assert (period.kind, period.count, period.ratio, period.name) == \
        (parsed.kind, parsed.count, parsed.ratio, parsed.name)


@pytest.mark.parametrize(("text", "parsed"), [
    ("shaft", ("shaft", None)), ("cage[left]", ("cage", "left")), ("vc", ("vc", None)),
    ("param:forcing_period", ("param", "forcing_period")),
])
def test_sections_parse_with_the_shared_grammar(text, parsed):
    assert parse_section(text) == parsed
    assert SECTION.parse(text) == ForcingName(parsed[0], name=parsed[1])


@pytest.mark.parametrize(("vocabulary", "text", "message"), [
    (PERIOD, "moon", "period: must be vc, shaft, vc:k, shaft:k, ratio:p/q, vc[bearing] (a "
     "model with several bearings) or param:NAME (the period in s held by parameter NAME), "
     "got 'moon'"),
    (PERIOD, "param", "period: param:NAME needs a parameter name, got 'param'"),
    (PERIOD, "shaft:0", "period: the number in 'shaft:0' must be a positive integer (or p/q "
     "with p, q > 0 for ratio)"),
    (PERIOD, "cage", "period: must be vc, shaft"),
    (SECTION, "moon", "section: must be shaft, cage, vc, cage[bearing], vc[bearing] or "
     "param:NAME, got 'moon'"),
    (SECTION, "vc:2", "section: must be shaft, cage, vc"),
    (SECTION, "shaft[left]", "section: must be shaft, cage, vc"),
    (SECTION, "param:", "section: param:NAME needs a parameter name, got 'param:'"),
])
def test_each_vocabulary_keeps_its_words_and_messages(vocabulary, text, message):
    with pytest.raises(InputError, match=re.escape(message)):
        vocabulary.parse(text)


@pytest.fixture
def tau_model(tmp_path, monkeypatch):
    """mathieu with its forcing period called ``tau``, named by the expression's ``period``."""
    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    load_model.cache_clear()
    data = tomllib.loads((SPECS / "mathieu.toml").read_text())
    data["model"]["name"] = "tau-mathieu"
    data["parameters"]["tau"] = data["parameters"].pop("forcing_period")
    term = data["terms"][0]
    term["fx"] = term["fx"].replace("forcing_period", "tau")
    term["period"] = "tau"
    path = tmp_path / "tau-mathieu.toml"
    path.write_text(tomli_w.dumps(data))
    yield load_model(path)
    load_model.cache_clear()


def test_a_renamed_forcing_period_is_found_by_its_role(tau_model):
    assert tau_model.role("forcing_period") == ("tau",)
    assert period_parameter(tau_model) == "tau"
    assert str(default_period(tau_model)) == "param:tau"
    name, freq = fastest_forcing(System.make(tau_model))
    assert name == "F = 1/tau" and freq == pytest.approx(1 / (2 * 3.141592653589793))
    run = simulate(tau_model, duration=20.0, transient=0.0)
    assert run.attrs["forcing_parameter"] == "tau"
    assert default_section(run) == "param:tau"
    assert section_period(run, default_section(run)) == pytest.approx(2 * 3.141592653589793)


def test_runs_written_before_the_role_still_name_forcing_period():
    attrs = {"n_balls": 0, "shaft_hz": 0.0, "forcing_period": 0.5}
    assert default_section(attrs) == "param:forcing_period"
