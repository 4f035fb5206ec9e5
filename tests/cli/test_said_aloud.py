"""Inputs that are allowed but not what the user may think: the command goes on, with one
warning line that says so (a shadowed user spec, a Lyapunov exponent whose sign a short
run does not resolve)."""

from __future__ import annotations

import pytest

from analysis.cli.stability import unresolved_warning
from tests.conftest import SPECS, run_cli


def test_a_user_spec_named_like_a_shipped_model_is_said_to_shadow_it(tmp_path):
    """Another model runs, with one warning; the shadowed name itself is refused (the
    catalogue's ``models-shadowed-name`` row)."""
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "duffing.toml").write_text((SPECS / "duffing.toml").read_text())
    res = run_cli("simulate", "mathieu", "-o", "r.nc", "--duration", "0.1", "--transient", "0",
                  "--no-compile", cwd=tmp_path,
                  env={"BEARINGDYN_MODELS": "mine", "PYTHONWARNINGS": "default"})
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines() if line.startswith("warning:")]
    assert len(lines) == 1, res.stderr
    assert "mine/duffing.toml has the name of the shipped model 'duffing'" in lines[0]
    assert "the name 'duffing' is refused" in lines[0]


@pytest.mark.parametrize(("value", "ci", "warned"), [(290.0, 580.0, True), (-50.0, 10.0, False),
                                                     (0.0, 1.0, True), (5.0, 5.0, False)])
def test_an_unresolved_exponent_is_warned_with_the_run_it_needs(value, ci, warned):
    line = unresolved_warning(value, ci, 0.1)
    assert (line is not None) == warned
    if line and value:
        # the interval shrinks as 1/sqrt(T): (2 * 580 / 290)^2 * 0.1 s = 1.6 s
        assert "about 1.6 s of averaging" in line and line.startswith("warning: λ1 = 290")


def test_lyapunov_of_a_short_run_warns_in_one_line(tmp_path):
    res = run_cli("lyapunov", "vakharia2015", "--duration", "0.02", "--transient", "0.01",
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    warnings = [line for line in res.stderr.splitlines() if line.startswith("warning: λ1")]
    assert len(warnings) == 1 and "the interval is wider than the value" in warnings[0]
    assert "(--duration) would narrow it" in warnings[0]
