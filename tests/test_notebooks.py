"""The example notebooks (docs/notebooks/) run top to bottom in a fresh Jupyter kernel
(nbclient), each within its time budget, and show what they say: the model card (its spec
hash against hashlib), the labelled peaks, figures, the Floquet and Lyapunov results. The
model card itself (``Model._repr_html_``) is checked against the spec file (tomllib)."""

from __future__ import annotations

import hashlib
import os
import time
import tomllib
from pathlib import Path

import pytest

from analysis.model import load_model
from tests.conftest import ROOT, SPECS
from tests.html_rows import table_rows

NOTEBOOKS = ROOT / "docs" / "notebooks"
BUDGET_S = 60.0
"""Most wall time a notebook may take (the machine may be shared: generous on purpose)."""


def _run(name: str, tmp_path: Path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH") or str(ROOT))  # this tree
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    start = time.perf_counter()
    client.execute()
    wall = time.perf_counter() - start
    outputs = [out for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    text += "".join(o.get("data", {}).get("text/plain", "") for o in outputs
                    if o.output_type in ("execute_result", "display_data"))
    html = "".join(o.get("data", {}).get("text/html", "") for o in outputs
                   if o.output_type in ("execute_result", "display_data"))
    images = sum("image/png" in o.get("data", {}) for o in outputs
                 if o.output_type in ("execute_result", "display_data"))
    return wall, text, html, images


def test_the_paper_case_notebook(tmp_path, monkeypatch):
    wall, text, html, images = _run("paper-case.ipynb", tmp_path, monkeypatch)
    assert wall < BUDGET_S, f"{wall:.1f} s"
    digest = hashlib.sha256((SPECS / "vakharia2015.toml").read_bytes()).hexdigest()
    assert digest in html and "contact_stiffness" in html  # the model card
    assert digest in text  # the run's attrs
    assert "N_b = 6: VC 199.3 Hz" in text and "N_b = 10:" in text
    assert images == 2


def test_the_stability_study_notebook(tmp_path, monkeypatch):
    wall, text, html, images = _run("stability-study.ipynb", tmp_path, monkeypatch)
    assert wall < BUDGET_S, f"{wall:.1f} s"
    assert text.count("spectral radius") == 12 and "stable" in text
    assert "N_b = 6: λ = [" in text and "chaotic" in text and "N_b = 10: λ = [" in text
    assert "balanced-rotor" in html
    assert images == 1


@pytest.mark.parametrize("name", ["vakharia2015", "two-bearing-rotor", "mathieu"])
def test_the_model_card_in_a_notebook_lists_every_parameter_of_the_spec(name):
    spec = tomllib.loads((SPECS / f"{name}.toml").read_text())
    table = {row[0]: row[1:] for row in table_rows(load_model(name)._repr_html_())}
    assert table["spec sha256"] == [hashlib.sha256((SPECS / f"{name}.toml").read_bytes())
                                    .hexdigest()]
    assert table["spec"] == [f"modelgen/specs/{name}.toml"]
    for param, entry in spec["parameters"].items():
        value, unit, source = table[param]
        assert float(value) == pytest.approx(entry["value"], rel=1e-5)
        assert unit == entry["unit"] and source == entry["source"]
