"""The paper reproduction, regenerated on a reduced grid."""

from __future__ import annotations

import hashlib
import json

import pytest
import xarray as xr

from analysis.model import load_model
from analysis.provenance import load_dataset, provenance
from analysis.reports.paper import PAPER_TABLE2, nature_matches
from analysis.reports.report import write_reproduction
from analysis.reports.reproduce import Row, reproduce
from analysis.signal.spectrum import Peak, find_peaks
from tests.conftest import SPECS


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro")
    rep = reproduce(out, n_balls=(6, 10), duration=1.2, transient=0.4, revolutions=30,
                    sensitivity={"damping": (200.0, 400.0)}, quick=True)
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
    spec_digest = hashlib.sha256((SPECS / "vakharia2015.toml").read_bytes()).hexdigest()
    for row, entry in zip(rep.rows, table["rows"], strict=True):  # each row names its run
        with xr.open_dataset(row.netcdf, engine="h5netcdf") as ds:
            assert entry["provenance"] == json.loads(json.dumps(provenance(ds)))
            assert ds.attrs["n_balls"] == entry["provenance"]["n_balls"] == row.n_balls
        assert entry["provenance"]["spec_sha256"] == spec_digest
    assert set(table["ranges_reproducing_table2"]) == {"damping"}
    chart = rep.sensitivity["damping"]
    assert chart.sizes == {"n_balls": 2, "damping": 2}


def test_marks_compare_cell_by_cell():
    def peak(label):
        return Peak("x", 1.0, 1.0, label, None, None)

    row = Row(8, {"x": [peak("X"), peak("2X"), peak("VC-X"), peak("VC"), peak("VC+X")],
                  "y": [peak("X")]}, "chaotic", "", 1.0, 0.1, None, None, PAPER_TABLE2[8])
    # the paper lists no other y peak for N_b = 8: that cell is not counted
    assert row.marks() == {"major_x": True, "major_y": True, "others_x": True,
                           "others_y": None, "nature": False}
    assert row.differences() == {"nature": (["quasi-periodic"], ["chaotic"])}
    assert nature_matches("multi-orbit periodic", "periodic-3")
    assert not nature_matches("multi-orbit periodic", "periodic-1")


def test_a_differing_cell_names_what_is_missing_and_what_is_extra():
    def peak(label):
        return Peak("x", 1.0, 1.0, label, None, None)

    row = Row(6, {"x": [peak("VC"), peak("X"), peak("VC-X"), peak("3VC")],
                  "y": [peak("X"), peak("VC")]}, "chaotic", "", 1.0, 0.1, None, None,
              PAPER_TABLE2[6])
    m = row.marks()
    assert m["major_x"] is False and m["others_x"] is False and m["others_y"] is False
    d = row.differences()
    assert d["major_x"] == (["2X"], ["VC"])
    # the paper's X, VC-X, 2X, VC, VC+X for N_b = 6 against our VC (major), X, VC-X, 3VC
    assert d["others_x"] == (["2X", "VC+X"], ["3VC"])
    assert d["others_y"] == (["VC-X"], [])
    from analysis.reports.report import _mark
    assert _mark(m["others_x"], d["others_x"]) == " ✗ (missing: 2X, VC+X; extra: 3VC)"
    assert _mark(None) == "" and _mark(True) == " ✓"


def test_quick_report_says_smoke_test_at_the_top_and_counts_only_paper_cells(report):
    rep, paths = report
    text = paths["markdown"].read_text()
    head = text.splitlines()[:4]
    assert any("Smoke test" in line for line in head), head
    assert "smoke test" in paths["html"].read_text().split("</title>")[0]
    assert json.loads(paths["json"].read_text())["smoke_test"] is True
    counted = sum(1 for r in rep.rows for v in r.marks().values() if v is not None)
    paper_cells = sum(1 for r in rep.rows for key in ("major_x", "major_y", "others_x",
                                                      "others_y", "nature")
                      if getattr(r.paper, key))
    assert counted == paper_cells == 9  # N_b = 10 has no other y peaks in the paper
    assert f"of {counted} comparable cells" in text
    assert "multi-orbit periodic" in text and "periodic-n for n ≥ 2" in text
    for row in rep.rows:
        for key, (missing, extra) in row.differences().items():
            assert row.marks()[key] is False and (missing or extra)


def test_sensitivity_axes_show_the_values_tried_with_units(report):
    from analysis.reports.plots import sensitivity_figure

    rep, _ = report
    chart = rep.sensitivity["damping"]
    fig = sensitivity_figure(chart, "N*s/m")
    fig.canvas.draw()
    for ax in fig.axes[:2]:
        assert ax.get_xlabel() == "damping (N*s/m)"
        assert [t.get_text() for t in ax.get_xticklabels()] == ["200", "400"]
        assert [t.get_text() for t in ax.get_yticklabels()] == ["6", "10"]
        low, high = ax.get_xlim()
        assert (low, high) == (-0.5, 1.5)  # the two cells tried, nothing beyond
