"""What the command loads before it does anything (issue 39, item 6): registering the
commands and reading the command line (``--help``, a command's help, a refused option or
value) imports none of the numerical libraries; the command modules import them inside the
commands. And a netCDF write does not pay for xarray's probe of a dask cluster that cannot
be running (``analysis.io``): the file is the same, byte for byte.

Each check runs a fresh interpreter and looks at what it imported; the time this saves is
measured by ``benchmarks/bench_startup.py``, not here."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from tests.conftest import ROOT

HEAVY = ("numpy", "scipy", "xarray", "matplotlib", "casadi", "sympy", "dask")

LINES = {
    "help": (["--help"], 0, "Commands"),
    "chart-help": (["chart", "--help"], 0, "Usage:"),
    "refused-option": (["chart", "--bogus"], 2, "No such option: --bogus"),
    "refused-value": (["simulate", "vakharia2015", "--dt", "abc"], 2, "'--dt'"),
    "refused-value-after-output": (["simulate", "vakharia2015", "-o", "r.nc", "--dt", "abc"], 2,
                                   "'--dt'"),
}
"""name -> (command line, exit code, text of its output). The last one checks the output
option first (``analysis.io.check_output``), then refuses ``--dt``."""

ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
"""The checks run in a temporary folder, on this checkout's packages."""

PROBE = """
import contextlib, io, json, sys
from analysis.cli import _register
_register()
from analysis.cli import main
out, err = io.StringIO(), io.StringIO()
code = 0
with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
    try:
        main(sys.argv[1:])
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "output": out.getvalue() + err.getvalue(),
                  "loaded": sorted(m for m in HEAVY if m in sys.modules)}))
""".replace("HEAVY", repr(HEAVY))


@pytest.fixture(scope="module")
def loaded(tmp_path_factory) -> dict[str, dict]:
    """name -> {"code", "output", "loaded"} of each command line of ``LINES``, each read by
    a fresh interpreter."""
    cwd = tmp_path_factory.mktemp("startup")
    found = {}
    for name, (args, _, _) in LINES.items():
        res = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True,
                             text=True, cwd=cwd, timeout=300, env=ENV)
        assert res.returncode == 0, res.stderr
        found[name] = json.loads(res.stdout.strip().splitlines()[-1])
    return found


@pytest.mark.parametrize("name", list(LINES))
def test_reading_the_command_line_does_what_it_did(loaded, name):
    _, code, text = LINES[name]
    assert loaded[name]["code"] == code, loaded[name]
    assert text in loaded[name]["output"], loaded[name]


@pytest.mark.parametrize("name", list(LINES))
def test_reading_the_command_line_loads_no_numerical_library(loaded, name):
    heavy = [m for m in loaded[name]["loaded"] if m != "numpy"]
    assert heavy == [], f"{LINES[name][0]} imported {heavy}"


@pytest.mark.parametrize("name", list(LINES))
def test_reading_the_command_line_loads_no_numpy(loaded, name):
    assert "numpy" not in loaded[name]["loaded"], f"{LINES[name][0]} imported numpy"


WRITE = """
import json, sys
import numpy as np, xarray as xr
from analysis.io import save_dataset
import xarray.backends.locks as locks
probe = locks.get_dask_scheduler if hasattr(locks, "get_dask_scheduler") else locks._get_scheduler
ds = xr.Dataset({"x": (("t", "k"), np.arange(12.0).reshape(6, 2)),
                 "label": ("k", np.array(["a", "b"]))},
                coords={"t": np.linspace(0.0, 1.0, 6)}, attrs={"model": "m", "n": 3})
save_dataset(ds, "ours.nc")
distributed = "distributed" in sys.modules
restored = (locks.get_dask_scheduler if hasattr(locks, "get_dask_scheduler")
            else locks._get_scheduler) is probe
ds.to_netcdf("xarrays.nc", engine="h5netcdf")
same = open("ours.nc", "rb").read() == open("xarrays.nc", "rb").read()
print(json.dumps({"distributed": distributed, "restored": restored, "same": same}))
"""


def test_a_netcdf_write_skips_the_cluster_probe_and_writes_the_same_bytes(tmp_path):
    res = subprocess.run([sys.executable, "-c", WRITE], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300, env=ENV)
    assert res.returncode == 0, res.stderr
    found = json.loads(res.stdout.strip().splitlines()[-1])
    assert found == {"distributed": False, "restored": True, "same": True}
