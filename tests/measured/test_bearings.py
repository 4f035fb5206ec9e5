"""Bearings by name (``analysis.measured.bearings``): the catalogue against the multiples the
CWRU Bearing Data Center publishes (an independent published result), a model's bearing
against the model's own kinematics, the geometry grammar and the bearings that cannot
exist."""

from __future__ import annotations

import math

import pytest

from analysis.errors import InputError
from analysis.measured.bearings import (
    BSF_CONVENTION,
    CATALOGUE,
    Bearing,
    frequency_table,
    lookup,
    parse_geometry,
)

# The CWRU data centre's bearing table (../shared/data/cwru/README.md): multiples of the
# shaft speed; its "ball" figure is 2xBSF.
CWRU_ORDERS = {
    "6205-cwru": {"BPFI": 5.4152, "BPFO": 3.5848, "FTF": 0.39828, "2xBSF": 4.7135},
    "6203-cwru": {"BPFI": 4.9469, "BPFO": 3.0530, "FTF": 0.3817, "2xBSF": 3.9874},
}


@pytest.mark.parametrize("name", sorted(CWRU_ORDERS))
def test_catalogue_matches_the_data_centre(name):
    orders = lookup(name).orders()
    for line, published in CWRU_ORDERS[name].items():
        assert orders[line] == pytest.approx(published, rel=1e-3), line
    assert orders["2xBSF"] == pytest.approx(2 * orders["BSF"], rel=1e-15)


def test_frequencies_scale_with_the_shaft_and_follow_the_textbook():
    b = lookup("6205-2RS")  # an alias, any case
    assert b is CATALOGUE["6205-cwru"]
    r = b.ball_diameter_m / b.pitch_diameter_m
    f = b.frequencies(29.95)
    assert f["FTF"] == pytest.approx(29.95 / 2 * (1 - r), rel=1e-12)
    assert f["BPFI"] == pytest.approx(9 * 29.95 / 2 * (1 + r), rel=1e-12)
    assert f["BSF"] == pytest.approx(29.95 / (2 * r) * (1 - r * r), rel=1e-12)
    assert b.ball_diameter_m == pytest.approx(0.3126 * 0.0254, rel=1e-15)


@pytest.mark.parametrize("model", ["6205-inner-defect", "vakharia2015"])
def test_a_models_bearing_has_the_models_frequencies(model):
    """The model's own Model.frequencies (its cage kinematics; vakharia2015's cage rolls on
    the races, Eq. 1) against the Bearing built from its parameters."""
    from analysis.model import load_model

    m = load_model(model)
    freqs = m.frequencies()
    own = next(iter(freqs.faults.values())).as_dict()
    b = lookup(model)
    got = b.frequencies(freqs.shaft_hz)
    for key, value in own.items():
        assert got[key] == pytest.approx(value, rel=1e-12), key
    assert b.n_balls == m.default_n_balls


def test_seed_6205_is_table_1():
    b = lookup("6205-seed")
    assert b.ball_diameter_m == pytest.approx(4.762e-3)
    assert b.pitch_diameter_m == pytest.approx(23.5e-3)
    assert b.n_balls == 9
    model = lookup("6205-outer-defect")
    assert model.orders()["BPFO"] == pytest.approx(b.orders()["BPFO"], rel=1e-12)


def test_geometry_in_mm_and_degrees():
    b = parse_geometry("d=7.94,D=39.04,z=9,angle=15")
    assert (b.ball_diameter_m, b.pitch_diameter_m, b.n_balls) == pytest.approx(
        (7.94e-3, 39.04e-3, 9))
    assert b.contact_angle_rad == pytest.approx(math.radians(15))
    assert lookup("d=7.94,D=39.04,z=9").contact_angle_rad == 0.0


@pytest.mark.parametrize("text, words", [
    ("d=40,D=39,z=9", "smaller than the pitch"),
    ("d=7.94,D=39.04,z=2", "z must be a whole number >= 3"),
    ("d=7.94,D=39.04,z=9.5", "whole number"),
    ("d=7.94,D=39.04,z=30", "do not fit"),
    ("d=7.94,D=39.04,z=9,angle=90", r"\[0, 90\)"),
    ("d=7.94,D=39.04,z=9,angle=-1", r"\[0, 90\)"),
    ("d=7.94,D=39.04", "lacks z"),
    ("d=x,D=39.04,z=9", "must be numbers"),
    ("d=7.94,D=39.04,z=9,w=3", "d=MM,D=MM"),
    ("no-such-bearing", "no bearing 'no-such-bearing'"),
])
def test_impossible_or_unknown_bearing_is_one_line(text, words):
    with pytest.raises(InputError, match=words) as err:
        lookup(text)
    assert str(err.value).startswith("bearing:") and err.value.field == "bearing"
    assert "\n" not in str(err.value)


def test_speed_must_be_positive():
    b = lookup("6203-cwru")
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(InputError, match="speed"):
            b.frequencies(bad)


def test_table_states_the_convention():
    rows = frequency_table(lookup("6205-cwru"), 1797 / 60)
    assert rows[-1].strip() == f"({BSF_CONVENTION})"
    assert any(row.split()[0] == "2xBSF" for row in rows[1:-1])
    assert isinstance(Bearing("x", 1e-3, 1e-2, 3, 0.0, "test"), Bearing)
