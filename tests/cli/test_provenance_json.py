"""Every `--json` output carries a ``provenance`` object with the content of the netCDF
attrs of the same run: the model, spec path and sha256, balls, every parameter value, the
frequencies and the versions. Checked through the real CLI (``run_cli``) against the file
each run writes, read back with xarray; the spec hash also against hashlib on the spec."""

from __future__ import annotations

import hashlib
import json

import pytest

from analysis.io import open_result
from analysis.model import load_model
from analysis.provenance import provenance
from tests.conftest import SPECS, run_cli

SIMULATE_ONLY = {"method", "dt", "save_every", "duration", "transient", "rtol", "atol"}
"""Attrs of a `simulate` file that are the run's own settings, not its provenance."""
DUFFING = ["--set", "linear_stiffness=1", "--set", "cubic_stiffness=1",
           "--set", "damping=0.2", "--set", "forcing_amplitude=20"]


def _json(*args: str, cwd=None) -> dict:
    res = run_cli(*args, cwd=cwd)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def _simulated(tmp_path, name: str, *args: str) -> dict:
    """The attrs of ``bearingdyn simulate name args`` (the run's own settings dropped)."""
    out = tmp_path / f"{name}.nc"
    res = run_cli("simulate", name, *args, "-o", str(out))
    assert res.returncode == 0, res.stderr
    attrs = provenance(open_result(out))
    return {k: v for k, v in attrs.items()
            if k not in SIMULATE_ONLY and not (k.endswith("0") and k[:-1] in
                                               attrs["state_names"].split())}


def _check_core(prov: dict, model: str, varied: str = "") -> None:
    """The fields the design names, against the spec file and the model's parameters (all
    but the ``varied`` one, a branch's coordinate)."""
    digest = hashlib.sha256((SPECS / f"{model}.toml").read_bytes()).hexdigest()
    assert prov["model"] == model and prov["spec_sha256"] == digest
    assert prov["spec_file"] == f"modelgen/specs/{model}.toml"
    assert set(load_model(model).parameter_names) - {varied} <= set(prov)
    assert {"bearingdyn_version", "generator", "casadi_version"} <= set(prov)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    """A balanced rotor run (periodic: classify decides from the section alone)."""
    out = tmp_path_factory.mktemp("prov") / "run.nc"
    res = run_cli("simulate", "balanced-rotor", "--n-balls", "8", "--set", "radial_load=50",
                  "--duration", "0.6", "--transient", "0.4", "-o", str(out))
    assert res.returncode == 0, res.stderr
    return out


@pytest.mark.parametrize("command", [["spectrum"], ["classify"], ["poincare", "--section",
                                                                    "vc"]])
def test_json_of_a_run_file_carries_the_file_attrs(run_file, command):
    data = _json(command[0], str(run_file), *command[1:], "--json")
    assert data["provenance"] == json.loads(json.dumps(provenance(open_result(run_file))))
    _check_core(data["provenance"], "balanced-rotor")
    assert data["provenance"]["radial_load"] == 50.0 and data["provenance"]["n_balls"] == 8


def test_floquet_json_carries_what_simulate_writes_for_the_same_setting(tmp_path):
    args = ["--n-balls", "8", "--set", "radial_load=50"]
    data = _json("floquet", "balanced-rotor", *args, "--json")
    expected = _simulated(tmp_path, "balanced-rotor", *args, "--duration", "0.01",
                          "--transient", "0")
    assert data["provenance"] == expected
    _check_core(data["provenance"], "balanced-rotor")


def test_lyapunov_json_carries_what_simulate_writes_for_the_same_setting(tmp_path):
    args = ["--n-balls", "7", "--speed-rpm", "4000", "--set", "damping=150"]
    data = _json("lyapunov", "vakharia2015", *args, "--duration", "0.05", "--transient",
                 "0.05", "--json")
    expected = _simulated(tmp_path, "vakharia2015", *args, "--duration", "0.01",
                          "--transient", "0")
    prov = data["provenance"]
    assert {k: prov[k] for k in expected} == expected
    assert prov["speed_rpm"] == 4000.0 and prov["damping"] == 150.0 and prov["n_balls"] == 7
    assert prov["renorm_every"] == 100 and prov["dt"] == data["dt"]  # its own settings too
    _check_core(prov, "vakharia2015")


def test_continue_json_carries_each_branch_file_attrs(tmp_path):
    out = tmp_path / "branch.nc"
    data = _json("continue", "duffing", "--param", "speed_rpm", "--from", "10.03", "--to",
                 "10.5", "--period", "shaft", "--dt", "0.01", *DUFFING, "--max-points", "5",
                 "--quiet", "--json", "-o", str(out))
    (branch,) = data["branches"]
    attrs = json.loads(json.dumps(provenance(open_result(out))))
    assert branch["provenance"] == attrs
    _check_core(branch["provenance"], "duffing", varied="speed_rpm")
    assert branch["provenance"]["damping"] == 0.2 and "speed_rpm" not in branch["provenance"]
