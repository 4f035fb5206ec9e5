"""analysis.provenance, the one writer and reader of result attributes: the attrs of a run,
a chart point's record, a diagram's record and a branch (keys in the order the files have
had them), the one version source, the System rebuilt from attrs, the one state-name reader
and JSON converter, and the layer: io and cite import nothing above them."""

from __future__ import annotations

import ast
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import modelgen
from analysis.cite import model_citation
from analysis.integrate.simulate import simulate
from analysis.model import as_system
from analysis.provenance import (
    PAPER_STATE,
    completed_attrs,
    displacement_names,
    package_version,
    plain,
    provenance,
    run_attrs,
    state_at,
    state_names,
    system_of_attrs,
)

ROOT = Path(__file__).resolve().parents[1]
PAPER_BASE = ["model", "spec_sha256", "spec_file", "n_balls", "bearing_name", "state_names",
              "bearingdyn_version", "generator", "casadi_version", "speed_rpm", "rotor_mass",
              "contact_stiffness", "damping", "radial_clearance", "radial_load",
              "unbalance_force", "inner_race_diameter", "outer_race_diameter",
              "pitch_diameter", "ball_diameter", "shaft_hz", "cage_hz", "vc_hz", "ftf_hz",
              "bpfo_hz", "bpfi_hz", "bsf_hz"]
"""``run_attrs`` of vakharia2015, in the order every result file has them."""
DUFFING_BASE = ["model", "spec_sha256", "spec_file", "n_balls", "state_names",
                "bearingdyn_version", "generator", "casadi_version", "speed_rpm", "rotor_mass",
                "damping", "linear_stiffness", "cubic_stiffness", "forcing_amplitude",
                "shaft_hz", "cage_hz", "vc_hz"]
TIMES = ["method", "dt", "save_every", "duration", "transient"]
STATE0 = ["x0", "y0", "vx0", "vy0"]
DUFFING = {"linear_stiffness": 1.0, "cubic_stiffness": 1.0, "damping": 0.2,
           "forcing_amplitude": 20.0}


@pytest.fixture(scope="module")
def run():
    return simulate("vakharia2015", 6, duration=0.02, transient=0.01, speed_rpm=5000)


def test_a_run_has_its_attrs_in_order(run):
    system = as_system("vakharia2015", 6, speed_rpm=5000)
    assert list(run.attrs) == PAPER_BASE + TIMES + STATE0
    base = run_attrs(system.model, system.structure, dict(system.parameters))
    assert {k: run.attrs[k] for k in base} == base
    assert (run.attrs["method"], run.attrs["dt"], run.attrs["save_every"]) == ("rk4", 1e-5, 1)
    assert [run.attrs[k] for k in STATE0] == [float(v) for v in system.state]
    assert run.attrs == completed_attrs(system, method="rk4", dt=1e-5, save_every=1,
                                        duration=0.02, transient=0.01, initial_state=True)
    assert run.x.attrs == {"units": "m", "long_name": "rotor displacement along the radial load"}
    assert run.vy.attrs["long_name"] == "rotor velocity across the radial load"


def test_a_cvodes_run_ends_with_its_tolerances():
    ds = simulate("duffing", duration=2.0, transient=1.0, dt=1e-3, method="cvodes", **DUFFING)
    assert list(ds.attrs) == DUFFING_BASE + TIMES + STATE0 + ["rtol", "atol"]
    assert (ds.attrs["rtol"], ds.attrs["atol"]) == (1e-10, 1e-16)


def test_a_chart_point_record_and_a_diagram_record_have_the_runs_attrs():
    from analysis.sweeps import diagram, points
    from analysis.sweeps.grid import Setting

    system = as_system("vakharia2015", 6, speed_rpm=5000)
    point = points._prepare(system, 0.05, 0.02, 1e-5, None, False, True)
    assert list(point.attrs) == PAPER_BASE + TIMES
    assert point.attrs["duration"] == 0.05 and point.attrs["transient"] == 0.02
    setting = Setting("vakharia2015", 6, {"speed_rpm": 5000.0}, 0.01, 3, "shaft", 1e-5,
                      False)
    start = diagram.Start((1e-6, 1e-6, 0.0, 0.0), 0.003)
    record = diagram.record_from(setting, setting.system_at(), start)
    assert list(record.attrs) == PAPER_BASE + TIMES + ["t_start"] + STATE0
    assert record.attrs["t_start"] == 0.003 and record.attrs["x0"] == 1e-6
    assert record.x.attrs == {"units": "m",
                              "long_name": "rotor displacement along the radial load"}


def test_a_branch_starts_with_the_systems_attrs():
    from analysis.stability.continuation import continue_orbits

    values = {k: v for k, v in DUFFING.items() if k != "forcing_amplitude"}
    br = continue_orbits("duffing", param="forcing_amplitude", start=7.5, stop=7.6,
                         max_points=3, **values)
    base = [k for k in DUFFING_BASE if k != "forcing_amplitude"]
    own = ["param", "period", "steps_per_period", "t0", "status", "branch"]
    assert list(br.attrs)[:len(base) + len(own)] == [*base, *own]


def test_one_version_everywhere(run):
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert package_version() == modelgen.__version__ == pyproject
    assert run.attrs["bearingdyn_version"] == pyproject
    assert model_citation("vakharia2015").bearingdyn_version == pyproject


def test_system_of_attrs_rebuilds_the_system(run):
    system = as_system("vakharia2015", 6, speed_rpm=5000)
    again = system_of_attrs(run.attrs, state_at(run, 0))
    assert again.model.name == system.model.name and again.structure == system.structure
    assert dict(again.parameters) == dict(system.parameters)
    np.testing.assert_array_equal(again.p, system.p)
    np.testing.assert_array_equal(again.state, [float(run[v][0]) for v in PAPER_STATE])
    assert system_of_attrs(provenance(system)).structure == (6,)


def test_one_reader_of_state_names(run):
    assert state_names(run) == state_names(run.attrs) == PAPER_STATE
    assert state_names({}) == PAPER_STATE  # files older than the attr
    assert state_names({"state_names": "x_rotor y_rotor vx_rotor vy_rotor"})[0] == "x_rotor"
    assert displacement_names(run) == ("x", "y")
    assert state_at(run, -1).shape == (4,)


def test_plain_is_json():
    attrs = {"a": np.float64(1.5), "b": np.int32(3), "c": np.arange(2), "d": b"text",
             "e": np.str_("s"), "f": "plain"}
    assert json.dumps({k: plain(v) for k, v in attrs.items()}) == \
        '{"a": 1.5, "b": 3, "c": [0, 1], "d": "text", "e": "s", "f": "plain"}'
    assert plain(np.float64("nan"), finite=True) is None
    assert plain(math.inf, finite=True) is None
    assert math.isnan(plain(np.float64("nan")))


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, lazy imports included."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
    return found


def test_io_and_cite_import_nothing_above_them():
    io = {m for m in _imports(ROOT / "analysis" / "io.py") if m.startswith("analysis")}
    assert io == {"analysis.errors"}
    cite = {m for m in _imports(ROOT / "analysis" / "cite.py") if m.startswith("analysis")}
    assert "analysis.integrate.simulate" not in cite
    prov = {m for m in _imports(ROOT / "analysis" / "provenance.py") if m.startswith("analysis")}
    assert prov <= {"analysis.errors", "analysis.io", "analysis.model"}


def test_frequencies_per_bearing_from_attrs():
    from analysis.provenance import cage_frequencies, vc_frequencies

    attrs = {"vc_hz_left": 10.0, "vc_hz_right": 20.0, "cage_hz": 4.0}
    assert vc_frequencies(attrs) == {"left": 10.0, "right": 20.0}
    assert cage_frequencies(attrs) == {"": 4.0} and vc_frequencies({"vc_hz": 0.0}) == {}
