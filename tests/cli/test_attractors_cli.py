"""`bearingdyn basins` and `bearingdyn attractors` as a user runs them: files written and
read back, JSON with provenance, figures rendered to PNG, and bad input refused in one line
(exit 2) before any work, leaving the folder as it was."""

from __future__ import annotations

import json
import math
import re

import pytest

from analysis.io import open_result
from analysis.provenance import provenance
from analysis.stability.attractors.mapper import SPECIAL_LABELS

DUFFING = ["--set", "linear_stiffness=1", "--set", "cubic_stiffness=0.5", "--set",
           "damping=0.1", "--set", "forcing_amplitude=0.3", "--speed-rpm", "13.369"]


def test_basins_writes_the_grid_the_table_and_a_named_figure(cli, tmp_path):
    res = cli("basins", "duffing", *DUFFING, "--x", "x:-3:3:12", "--y", "vx:-3:3:10",
              "-o", "b.nc", "--plot", "b.png", "--json", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    ds = open_result(tmp_path / "b.nc")
    assert ds.attrs["kind"] == "basins" and ds.basin.shape == (10, 12)
    assert out["provenance"] == provenance(tmp_path / "b.nc")
    assert out["provenance"]["spec_sha256"] == ds.attrs["spec_sha256"]
    rows = {a["id"]: a for a in out["attractors"]}
    assert set(rows) == set(ds.attractor.values.tolist()) == {1, 2}
    for i, row in rows.items():  # the JSON is the file's table
        assert row["class"] == "periodic-1" and row["period"] == 1
        assert row["fraction"] == pytest.approx(float((ds.basin == i).mean()))
        assert set(row["amplitude"]) == {"x", "y", "vx", "vy"}
    assert (tmp_path / "b.png").read_bytes()[:4] == b"\x89PNG"


def test_attractors_json_layout_for_fractions_and_for_a_continuation(cli, tmp_path):
    res = cli("attractors", "duffing", *DUFFING, "--samples", "40", "--box", "x:-3:3",
              "--box", "vx:-3:3", "--seed", "4", "--json", "-o", "a.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    rows = json.loads(res.stdout)["attractors"]
    assert {tuple(sorted(r)) for r in rows} == {tuple(sorted(
        ["id", "class", "period", "fraction", "fraction_stderr", "lambda1", "lambda1_ci95",
         "amplitude"]))}
    assert sum(r["fraction"] for r in rows) == pytest.approx(1.0)
    again = cli("attractors", "duffing", *DUFFING, "--samples", "40", "--box", "x:-3:3",
                "--box", "vx:-3:3", "--seed", "4", "--json", "-o", "b.nc", cwd=tmp_path)
    assert json.loads(again.stdout)["attractors"] == rows  # the seed makes it reproducible

    res = cli("attractors", "duffing", *DUFFING[:-2], "--samples", "20", "--box", "x:-3:3",
              "--box", "vx:-3:3", "--param", "speed_rpm:12.5:15.5:3", "--json",
              "-o", "c.nc", "--plot", "c.png", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert [list(v) for v in out["values"]] == [["speed_rpm", "attractors", "transitions",
                                                  "notes"]] * 3
    ids = [[a["id"] for a in v["attractors"]] for v in out["values"]]
    assert ids[0] == [1, 2] and ids[1] == [1, 2]  # kept from value to value
    ds = open_result(tmp_path / "c.nc")
    for k, v in enumerate(out["values"][:-1]):  # each basin's states go somewhere
        labels = {str(a["id"]) for a in v["attractors"]}
        assert labels <= set(v["transitions"]) | {"-2", "-1"}
        for row in v["transitions"].values():
            assert sum(row.values()) == pytest.approx(1.0)
        assert ds.transition.isel(value=k).sum("to").dropna("attractor").values == \
            pytest.approx(1.0)
    assert out["values"][-1]["transitions"] == {}
    assert ds.attrs["match_distance"] == 0.25
    assert (tmp_path / "c.png").read_bytes()[:4] == b"\x89PNG"


ROW = re.compile(r"^\s+(?P<id>-?\d+)\s+\S+\s+(?P<pct>\d+\.\d) % ± (?P<se>\d+\.\d)",
                 flags=re.M)
"""A table row of `attractors` (no --param): id, class, fraction % ± standard error %."""
SHARE = re.compile(r"(?P<label>\w+) (?P<pct>\d+\.\d) ± (?P<se>\d+\.\d)")
"""One 'label fraction ± stderr' of a continuation's value line (in %)."""
VALUE_LINE = re.compile(r"^    (?P<value>\S+): (?P<shares>.*)$", flags=re.M)


def _check_share(fraction: float, stderr: float, pct: str, se: str, n: int) -> None:
    """A printed fraction and standard error (%, one decimal) are the stored ones, and the
    stored standard error is √(p(1−p)/n) of the stored fraction p over the ``n`` states."""
    assert f"{100 * fraction:.1f}" == pct and f"{100 * stderr:.1f}" == se, \
        (fraction, stderr, pct, se)
    assert fraction * n == pytest.approx(round(fraction * n)), "p is not a count over n"
    assert stderr == pytest.approx(math.sqrt(fraction * (1 - fraction) / n), rel=1e-12)


def test_attractors_text_prints_each_fraction_with_its_standard_error(cli, tmp_path):
    args = ["attractors", "duffing", *DUFFING, "--samples", "40", "--box", "x:-3:3",
            "--box", "vx:-3:3", "--seed", "4"]
    res = cli(*args, "-o", "t.nc", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    ds = open_result(tmp_path / "t.nc")
    n = int(ds.attrs["samples"])
    assert n == 40
    rows = {int(m["id"]): m for m in ROW.finditer(res.stdout)}
    assert sorted(rows) == sorted(ds.attractor.values.tolist()) and rows
    for i, m in rows.items():
        _check_share(float(ds.fraction.sel(attractor=i)),
                     float(ds.fraction_stderr.sel(attractor=i)), m["pct"], m["se"], n)
    again = cli(*args, "--json", "-o", "j.nc", cwd=tmp_path)  # same seed: the same study
    for row in json.loads(again.stdout)["attractors"]:
        _check_share(row["fraction"], row["fraction_stderr"], rows[row["id"]]["pct"],
                     rows[row["id"]]["se"], n)


def test_attractor_continuation_prints_fractions_with_standard_errors(cli, tmp_path):
    res = cli("attractors", "duffing", *DUFFING[:-2], "--samples", "20", "--box", "x:-3:3",
              "--box", "vx:-3:3", "--param", "speed_rpm:12.5:15.5:3", "-o", "c.nc",
              "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    ds = open_result(tmp_path / "c.nc")
    n = int(ds.attrs["samples"])
    assert f"{n} states per value" in res.stdout
    ids = {name: k for k, name in SPECIAL_LABELS.items()}
    lines = [m for m in VALUE_LINE.finditer(res.stdout) if SHARE.search(m["shares"])]
    assert [float(m["value"]) for m in lines] == pytest.approx(ds.value.values.tolist())
    for k, line in enumerate(lines):
        here = ds.isel(value=k)
        shares = list(SHARE.finditer(line["shares"]))
        assert len(shares) == int(here.present.sum()) > 0
        for m in shares:
            i = ids.get(m["label"]) or int(m["label"])
            assert bool(here.present.sel(attractor=i))
            _check_share(float(here.fraction.sel(attractor=i)),
                         float(here.fraction_stderr.sel(attractor=i)), m["pct"], m["se"], n)


BAD = [
    (["basins", "duffing", "--x", "q:-3:3:10", "--y", "vx:-3:3:10"],
     "--x: 'q' is not a state of model 'duffing'; states: x, y, vx, vy"),
    (["basins", "duffing", "--x", "x:3:-3:10", "--y", "vx:-3:3:10"],
     "--x: LO must be < HI, got x:3:-3"),
    (["basins", "duffing", "--x", "x:-3:3:0", "--y", "vx:-3:3:10"],
     "--x: N must be a whole number >= 1, got 0"),
    (["basins", "duffing", "--x", "x:-3:3", "--y", "vx:-3:3:10"],
     "--x: must be COORD:LO:HI:N, got 'x:-3:3'"),
    (["basins", "duffing", "--x", "x:-3:3:100000", "--y", "vx:-3:3:100000"],
     "initial states would need about"),
    (["basins", "duffing", "--x", "x:-3:3:4", "--y", "x:-3:3:4"],
     "--y: must be another coordinate than --x's, got 'x' twice"),
    (["basins", "two-bearing-rotor", "--x", "x:-1e-5:1e-5:4", "--y", "y:-1e-5:1e-5:4"],
     "period: model 'two-bearing-rotor' has bearings"),
    (["attractors", "duffing", "--samples", "0", "--box", "x:-3:3"],
     "samples: must be a whole number >= 1, got 0"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--seed", "1.5"],
     "--seed"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3:4"],
     "--box: must be COORD:LO:HI, got 'x:-3:3:4'"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--box", "x:0:1"],
     "--box: coordinate x given twice"),
    (["attractors", "duffing", "--samples", "10", "--box", "vq:-3:3"],
     "--box: 'vq' is not a state of model 'duffing'"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--param",
      "speed_rpm:12:15:0"], "--param: N must be a whole number >= 1, got 0"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--param",
      "omega:1:2:3"], "param: 'omega' is not a parameter of model 'duffing'"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--param",
      "speed_rpm:12:15:3", "--match-threshold", "0"],
     "match-threshold: must be a number > 0 (orbit sizes), got 0.0"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--param",
      "speed_rpm:12:15:3", "--match-threshold", "nan"], "match-threshold: must be a number"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--revisits", "0"],
     "revisits: must be a whole number >= 1, got 0"),
    (["attractors", "duffing", "--samples", "10", "--box", "x:-3:3", "--branch",
      "missing.nc"], "missing.nc"),
]


@pytest.mark.parametrize(("args", "message"), BAD, ids=[" ".join(a[:4]) for a, _ in BAD])
def test_bad_input_is_one_line_exit_2_and_leaves_nothing(cli, tmp_path, args, message):
    before = sorted(p.name for p in tmp_path.iterdir())
    res = cli(*args, "-o", "out.nc", "--plot", "out.png", cwd=tmp_path)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], res.stderr
    assert "Traceback" not in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before
