"""`bearingdyn calibrate` end to end (tiny): the JSON layout of issue 30, the netCDF file, the
corner figure with provenance; a stored round is reused, not recomputed."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.inference.abc import prepare, run
from analysis.inference.simulate import RunSettings
from analysis.io import open_result
from analysis.sweeps.store import PointStore

TINY = ("--samples", "4", "--rounds", "2", "--transient-revolutions", "10",
        "--revolutions", "40", "--block", "2")


def test_cli_json_layout_file_and_figure(cli, tmp_path):
    out, png = tmp_path / "cal.nc", tmp_path / "cal.png"
    res = cli("calibrate", "vakharia2015", "--target", "paper-table2",
              "--prior", "rotor_mass:0.3:3:log", "--prior", "damping:100:1000:log", *TINY,
              "-o", str(out), "--json", "--plot", str(png))
    assert res.returncode == 0, res.stderr
    assert "40 runs" in res.stderr and "RK4 steps" in res.stderr  # the estimate, first
    doc = json.loads(res.stdout)
    assert {"target", "accepted", "best_matched", "share_of_prior", "provenance"} <= set(doc)
    assert doc["target"]["name"] == "paper-table2"
    assert list(doc["share_of_prior"]) == ["5", "4", "3", "2", "1", "0"]
    assert sum(doc["share_of_prior"].values()) == pytest.approx(1.0)
    assert doc["accepted"] and sum(a["weight"] for a in doc["accepted"]) == pytest.approx(1.0)
    for acc in doc["accepted"]:
        assert set(acc["parameters"]) == {"rotor_mass", "damping"}
        assert 0.3 <= acc["parameters"]["rotor_mass"] <= 3
        assert len(acc["rows"]) == 5
        assert acc["matched"] == sum(r["class_ok"] for r in acc["rows"])
        assert all({"class", "lambda1"} <= set(r) for r in acc["rows"])
    assert doc["best_matched"] == max(b["matched"] for b in doc["best"])
    assert doc["provenance"]["spec_sha256"] and doc["provenance"]["target"] == "paper-table2"
    ds = open_result(out)
    assert ds.sizes["member"] == 8 and ds.sizes["row"] == 5
    assert ds.rotor_mass.attrs["units"] == "kg"
    assert float(ds.weight.sum()) == pytest.approx(1.0)
    assert not (tmp_path / "cal.nc.parts").exists()
    from PIL import Image

    assert "vakharia2015" in str(Image.open(png).info)


def test_stored_blocks_are_reused(tmp_path):
    problem = prepare("vakharia2015", "paper-table2", ["damping:100:1000:log"], samples=4,
                      rounds=1, block=2,
                      settings=RunSettings(transient_revolutions=10, revolutions=40))
    store = PointStore(tmp_path / "cal.nc", problem.definition(), lock=True)
    first = run(problem, store=store)
    assert sorted(store.done()) == ["r0-b0", "r0-b2"]

    class Refuses:
        name = "refuses"

        def run(self, fn, tasks):
            for _ in tasks:
                raise AssertionError("a stored block was computed again")
            return iter(())

        def close(self):
            pass

    again = run(problem, store=store, executor=Refuses())
    store.remove()
    assert np.array_equal(first.posterior.discrepancy, again.posterior.discrepancy)
    assert [[r.nature for r in m] for m in first.posterior.rows] == \
        [[r.nature for r in m] for m in again.posterior.rows]
