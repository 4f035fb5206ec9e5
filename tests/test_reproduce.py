"""The paper reproduction, regenerated on a reduced grid."""

from __future__ import annotations

import json

import pytest

from analysis.io import load_dataset
from analysis.model import load_model
from analysis.reports.paper import PAPER_TABLE2, nature_matches
from analysis.reports.report import write_reproduction
from analysis.reports.reproduce import Row, reproduce
from analysis.signal.spectrum import Peak, find_peaks


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro")
    rep = reproduce(out, n_balls=(6, 10), duration=1.2, transient=0.4, revolutions=30,
                    sensitivity={"damping": (200.0, 400.0)})
    return rep, write_reproduction(rep, out)


def test_table_rows_are_recomputable_from_the_stored_runs(report):
    rep, _ = report
    for row in rep.rows:
        ds = load_dataset(row.netcdf)
        assert ds.attrs["n_balls"] == row.n_balls
        again = {v: find_peaks(ds, v) for v in ("x", "y")}
        assert [p.label for p in again["x"]] == [p.label for p in row.peaks["x"]]
        assert row.paper == PAPER_TABLE2[row.n_balls]
        assert row.nature in ("chaotic", "quasi-periodic") or row.nature.startswith("periodic")


def test_report_files_show_paper_and_ours_with_provenance(report):
    rep, paths = report
    text = paths["markdown"].read_text()
    digest = load_model("vakharia2015").spec_sha256
    assert digest in text and "generated/vakharia2015/vakharia2015.c" in text
    assert "| 6 | 2X / " in text  # the paper's major x peak for N_b = 6, then ours
    assert "multi-orbit periodic / " in text  # the paper's verdict for N_b = 10
    assert "contact_stiffness" in text and "assumption, not in the paper" in text
    html = paths["html"].read_text()
    assert html.count("data:image/png;base64,") == 3 and 'src="fig-' not in html
    table = json.loads(paths["json"].read_text())
    assert [r["n_balls"] for r in table["rows"]] == [6, 10]
    assert set(table["ranges_reproducing_table2"]) == {"damping"}
    chart = rep.sensitivity["damping"]
    assert chart.sizes == {"n_balls": 2, "damping": 2}


def test_marks_compare_cell_by_cell():
    def peak(label):
        return Peak("x", 1.0, 1.0, label, None, None)

    row = Row(8, {"x": [peak("X"), peak("2X"), peak("VC-X"), peak("VC"), peak("VC+X")],
                  "y": [peak("X")]}, "chaotic", "", 1.0, 0.1, None, None, PAPER_TABLE2[8])
    assert row.marks() == {"major_x": True, "major_y": True, "others_x": True,
                           "others_y": True, "nature": False}
    assert nature_matches("multi-orbit periodic", "periodic-3")
    assert not nature_matches("multi-orbit periodic", "periodic-1")
