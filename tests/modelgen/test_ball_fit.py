"""An --n-balls that cannot fit is refused (issue 32, section 4): the generated range and
the runtime check agree, a --set of the diameters is checked too, and a model without the
diameters says the fit cannot be checked."""

from __future__ import annotations

import pytest

import analysis.model as model_module
from analysis.errors import InputError
from analysis.model import as_system, balls_that_fit, load_model
from tests.conftest import SPECS

WITH_BALLS = [n for n in sorted(p.stem for p in SPECS.glob("*.toml"))
              if load_model(n).bearings]


@pytest.mark.parametrize("name", WITH_BALLS)
def test_runtime_fit_equals_the_generated_range(name):
    model = load_model(name)
    for bearing in model.bearings:
        fit = balls_that_fit(model.defaults, bearing.name)
        assert bearing.most == (64 if fit is None else min(64, fit[0]))


def test_a_set_diameter_is_checked_against_the_balls():
    system = as_system("vakharia2015", 12)
    with pytest.raises(InputError, match=r"n_balls: must be at most 6: 6 balls of 0.012 m"):
        system.replace(ball_diameter=0.012)
    with pytest.raises(InputError, match=r"n_balls\[left\]: must be at most 5"):
        as_system("two-bearing-rotor", {"left": 12}, ball_diameter=0.012)
    assert as_system("vakharia2015", 6, ball_diameter=0.012).structure == (6,)


def test_without_diameters_the_fit_is_said_to_be_unchecked(monkeypatch):
    with pytest.raises(InputError, match="no ball and pitch diameters, so whether they fit "
                                         "cannot be checked"):
        load_model("balanced-rotor").structure(65)  # no ball diameter in its spec
    assert balls_that_fit({}, "bearing") is None
    assert balls_that_fit({"ball_diameter": 0.01}, "bearing") is None
    assert balls_that_fit({"ball_diameter": 0.01, "inner_race_diameter": 0.03,
                           "outer_race_diameter": 0.05}, "bearing")[0] == 12
    monkeypatch.setattr(model_module, "balls_that_fit", lambda values, bearing: None)
    with pytest.raises(InputError, match="whether they fit cannot be checked"):
        load_model("vakharia2015").structure(80)


def test_the_cli_refuses_balls_that_do_not_fit(cli, tmp_path):
    done = cli("simulate", "vakharia2015", "--n-balls", "12", "--set", "ball_diameter=0.012",
               "-o", str(tmp_path / "r.nc"))
    assert done.returncode == 2
    assert done.stderr.strip().startswith("error: n_balls: must be at most 6")
    assert not list(tmp_path.iterdir())
