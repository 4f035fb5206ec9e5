"""A contact stiffness in the wrong unit is said aloud: the static ball deflection against
the clearance (``checks.check_deflection``), estimated by Stribeck's rule and checked here
against the model's own static equilibrium."""

from __future__ import annotations

import pytest

from analysis.integrate.checks import DEFLECTION_RATIO, check_deflection, static_deflection
from analysis.model import as_system
from analysis.stability.statics import equilibrium
from modelgen.spec import shipped_spec_names

SHIPPED = shipped_spec_names()


@pytest.mark.parametrize("n_balls", [8, 12])
def test_stribecks_estimate_agrees_with_the_static_equilibrium(n_balls):
    """With zero clearance and the balanced rotor's radial load, the most loaded ball's
    deflection is the rotor's static x (the ball at θ = 0 under the load). Stribeck's 5 is
    a rounded 4.37 (Harris, Sec. 7.2), so the estimate lies above, within 20 %."""
    values = dict(radial_clearance=0.0, radial_load=50.0, speed_rpm=0.0)
    eq = equilibrium("balanced-rotor", n_balls, **values)
    exact = float(eq.position[0])
    estimate = static_deflection(as_system("balanced-rotor", n_balls, **values), "bearing")
    assert exact > 0 and 1.0 <= estimate / exact < 1.2


def test_a_stiffness_in_n_per_mm_is_warned_about_and_the_default_is_not():
    said: list[str] = []
    check_deflection(as_system("vakharia2015", 8, contact_stiffness=7.055e9 / 10**4.5),
                     warn=said.append)
    assert len(said) == 1 and "check its unit" in said[0] and "times the radial clearance" \
        in said[0]
    for name in SHIPPED:
        system = as_system(name)
        quiet: list[str] = []
        check_deflection(system, warn=quiet.append)
        assert quiet == [], name
    assert DEFLECTION_RATIO == 10.0


def test_simulate_says_it_in_one_line(cli, tmp_path):
    res = cli("simulate", "vakharia2015", "--set", "contact_stiffness=2.231e5", "--duration",
              "0.01", "--transient", "0", "-o", "k.nc", cwd=tmp_path,
              env={"PYTHONWARNINGS": "default"})
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines() if "contact_stiffness" in line]
    assert len(lines) == 1 and lines[0].startswith("warning: contact_stiffness: 2.231e+05")
