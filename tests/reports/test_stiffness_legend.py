"""Stiffness legends keep their names apart (issue 32, section 4): ``k[x_rotor, x_rotor]``
for a model of several bodies, not ``k_x_rotorx_rotor``."""

from __future__ import annotations

from analysis.reports.plots import coefficient_name, stiffness_figure
from analysis.stability.statics import coefficients


def test_names_of_a_one_body_model_stay_short():
    name = coefficient_name(["x", "y"])
    assert name("x", "y") == "k_xy"


def test_legends_of_a_two_body_model_separate_the_coordinates():
    fig = stiffness_figure(coefficients("rotor-housing", n_angles=2))
    texts = [t.get_text() for ax in fig.axes if ax.get_legend()
             for t in ax.get_legend().get_texts()]
    assert "k[x_rotor, x_rotor]" in texts and "k[y_housing, y_housing] mean over the pitch" \
        in texts
    assert not [t for t in texts if "rotorx" in t or "housingy" in t or "rotory" in t]
