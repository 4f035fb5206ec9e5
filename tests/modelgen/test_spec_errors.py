"""Spec errors (issue 32, section 4): one path style, each list of known names written once,
and a bad spec of your own refused while the command line is read, before the command
imports xarray, CasADi or the integrators."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib

import pytest
import tomli_w

from modelgen.errors import SpecError
from modelgen.spec import field_path, lists_once, load_spec
from tests.conftest import ROOT, SPECS

OLD_STYLE = re.compile(r"\b(terms|bearings|bodies)\.\d")


def _bad_spec(tmp_path, edit) -> str:
    data = tomllib.loads((SPECS / "vakharia2015.toml").read_text())
    edit(data)
    path = tmp_path / "vakharia2015.toml"
    path.write_text(tomli_w.dumps(data))
    with pytest.raises(SpecError) as info:
        load_spec(path)
    return str(info.value)


def test_pydantic_and_cross_field_errors_share_one_path_style(tmp_path):
    def edit(data):
        data["terms"][0]["cage"] = "race_diameter"  # Pydantic's own check
        data["terms"][1]["kind"] = "centrifugl"  # the term kind
        data["terms"].append({"kind": "expression", "fx": "x.__class__"})  # a term validator

    message = _bad_spec(tmp_path, edit)
    assert not OLD_STYLE.search(message), message
    assert "terms[0] (hertz_contact).cage: must be" in message
    assert "terms[1].kind: unknown term 'centrifugl'" in message
    assert "terms[5] (expression).fx: attribute access" in message


def test_field_path_brackets_indices_and_names_the_term_kind():
    assert field_path(("terms", 2, "unbalance", "bind")) == "terms[2] (unbalance).bind"
    assert field_path(("bearings", 1, "n_balls")) == "bearings[1].n_balls"
    assert field_path(("parameters", "damping", "value")) == "parameters.damping.value"
    assert field_path(("terms", 0)) == "terms[0]"


def test_the_list_of_known_names_is_printed_once(tmp_path):
    def edit(data):
        for typo in ("dampign", "rotor_mas"):
            data["parameters"][typo] = {"value": 1.0, "unit": "kg", "source": "x"}

    message = _bad_spec(tmp_path, edit)
    assert message.count("parameters.dampign: unknown parameter") == 1
    assert message.count("parameters.rotor_mas: unknown parameter") == 1
    assert message.count("(known: ") == 2 and message.count("(known: as above)") == 1
    assert message.count("rotor_mass, ") == 1  # the list itself, once
    # different lists are each kept
    assert lists_once(["a (known: x, y)", "b (known: z)"]) == ["a (known: x, y)",
                                                               "b (known: z)"]


PROBE = """
import sys
from analysis.cli import main
try:
    main(["simulate", sys.argv[1], "-o", sys.argv[2]])
except SystemExit as exc:
    heavy = sorted(m for m in ("xarray", "casadi", "analysis.io", "analysis.integrate")
                   if m in sys.modules)
    print("exit", exc.code, "heavy", ",".join(heavy) or "none")
"""


def test_a_bad_spec_is_refused_before_the_command_loads_its_libraries(tmp_path):
    message = _bad_spec(tmp_path, lambda d: d["terms"][0].update(kind="hertz_contakt"))
    out = tmp_path / "out.nc"
    env = {**os.environ, "PYTHONWARNINGS": "ignore",
           "BEARINGDYN_CACHE": str(tmp_path / "cache")}
    res = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path / "vakharia2015.toml"),
                          str(out)], capture_output=True, text=True, cwd=ROOT, env=env,
                         timeout=300)
    assert res.stdout.strip().splitlines()[-1] == "exit 2 heavy none", res.stdout + res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0] == f"error: {message}"
    assert not out.exists() and not (tmp_path / "cache").exists()
