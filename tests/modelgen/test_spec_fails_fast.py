"""A spec that fails validation fails before the heavy libraries load (issue 32, §4: in
about the time a bad option takes): validating a spec needs neither SymPy nor CasADi
(``modelgen.lazy``), and the commands judge a spec of their own while their arguments are
read. Each check runs a fresh interpreter and looks at what it imported."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib

import pytest
import tomli_w

from tests.conftest import ROOT, SPECS

HEAVY = ("sympy", "casadi", "xarray", "scipy")


@pytest.fixture
def bad_spec(tmp_path):
    data = tomllib.loads((SPECS / "vakharia2015.toml").read_text())
    data["terms"][0]["kind"] = "hertz_contakt"
    path = tmp_path / "vakharia2015.toml"
    path.write_text(tomli_w.dumps(data))
    return path


def test_validating_a_spec_imports_neither_sympy_nor_casadi(bad_spec):
    code = (
        "import sys\n"
        "from modelgen.spec import SpecError, load_spec\n"
        f"try:\n    load_spec({str(bad_spec)!r})\n"
        "except SpecError as exc:\n    print('refused:', exc)\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert res.returncode == 0, res.stderr
    refused, loaded = res.stdout.strip().splitlines()
    assert "unknown term 'hertz_contakt'" in refused
    assert loaded == "[]", f"validation imported {loaded}"


@pytest.mark.parametrize("args", [
    ("simulate", "vakharia2015.toml", "-o", "r.nc"),
    ("generate", "vakharia2015.toml", "--out", "gen"),
    ("run", "--model", "vakharia2015.toml", "-o", "out"),
], ids=["simulate", "generate", "run"])
def test_a_bad_spec_fails_before_the_command_loads_its_libraries(bad_spec, args):
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "analysis.cli", *args],
                         capture_output=True, text=True, cwd=bad_spec.parent, timeout=120)
    assert res.returncode == 2
    errors = [line for line in res.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "unknown term 'hertz_contakt'" in errors[0]
    imported = set(re.findall(r"^import time:.*\|\s+(\S+)$", res.stderr, re.MULTILINE))
    assert not imported & set(HEAVY), sorted(imported & set(HEAVY))
    assert sorted(p.name for p in bad_spec.parent.iterdir()) == ["vakharia2015.toml"]
