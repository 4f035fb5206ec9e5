"""`bearingdyn cite` and ``analysis.cite.citation``: the BibTeX parses back with a real
parser (bibtexparser), the CFF validates against the Citation File Format 1.2.0 JSON schema
(tests/data/cff-schema-1.2.0.json: the Citation File Format project's schema, CC-BY-4.0, as
cffconvert ships it), and both state the sha256
of the spec file's bytes (hashlib here, independent of the generator) and its real path."""

from __future__ import annotations

import hashlib
import json
import tomllib
from pathlib import Path

import bibtexparser
import jsonschema
import pytest
import tomli_w
import yaml

from analysis.cite import SEED_PAPER_TITLE, citation
from analysis.model import load_model
from tests.conftest import ROOT, SPECS, run_cli

# pyparsing 3.3 warns about the calls bibtexparser 1 makes
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

SCHEMA = json.loads((ROOT / "tests" / "data" / "cff-schema-1.2.0.json").read_text())


def _entries(text: str) -> dict[str, dict]:
    parser = bibtexparser.bparser.BibTexParser(common_strings=False,
                                               ignore_nonstandard_types=False)
    db = bibtexparser.loads(text, parser=parser)
    return {e["ID"]: e for e in db.entries}


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _validate_cff(text: str) -> dict:
    data = yaml.safe_load(text)
    jsonschema.validate(data, SCHEMA)
    return data


@pytest.mark.parametrize("name", sorted(p.stem for p in SPECS.glob("*.toml")))
def test_bibtex_of_every_shipped_model_parses_and_states_the_spec_hash(name):
    entries = _entries(citation(name, "bibtex"))
    entry = entries[f"bearingdyn-{name}"]
    assert entry["ENTRYTYPE"] == "misc"
    assert entry["sha256"] == _sha(SPECS / f"{name}.toml")
    assert entry["specfile"] == f"modelgen/specs/{name}.toml"
    assert load_model(name).module.TITLE.split(",")[0] in entry["title"]
    for tool in ("sympy 1.14.0", "casadi 3.8.2"):
        assert tool in entry["generator"]
    text = (SPECS / f"{name}.toml").read_text()
    on_seed_paper = "Vakharia" in tomllib.loads(text)["model"].get("reference", "")
    assert ("vakharia-ball-bearings" in entries) == on_seed_paper
    if on_seed_paper:
        paper = entries["vakharia-ball-bearings"]
        assert paper["title"].strip("{}") == SEED_PAPER_TITLE
        assert paper["author"] == "Vakharia, V. and Gupta, V. K. and Kankar, P. K."
        assert entry["related"] == "vakharia-ball-bearings"


@pytest.mark.parametrize("name", ["vakharia2015", "mathieu", "vakharia2015-two-contact"])
def test_cff_of_a_model_is_valid_cff_1_2_0(name):
    data = _validate_cff(citation(name, "cff"))
    digest = _sha(SPECS / f"{name}.toml")
    assert data["identifiers"][0]["value"] == f"sha256:{digest}"
    assert f"modelgen/specs/{name}.toml" in data["identifiers"][0]["description"]
    assert digest in data["abstract"] and "casadi 3.8.2" in data["abstract"]
    titles = [r["title"] for r in data.get("references", [])]
    assert (SEED_PAPER_TITLE in titles) == (name != "mathieu")


def test_the_top_level_citation_file_is_valid_and_names_the_package_version():
    data = _validate_cff((ROOT / "CITATION.cff").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert data["version"] == project["version"]
    assert data["license"] == "MIT" == project["license"]
    assert project["license-files"] == ["LICENSE"]
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    assert data["references"][0]["title"] == SEED_PAPER_TITLE


UNSTATED_KEYS = ("journal", "doi", "year", "volume", "issue", "start", "end", "pages",
                 "publisher", "date-published", "conference", "collection-title", "url")
"""CFF reference keys of what the seed text does not state (a venue, a date, a DOI)."""


def test_the_top_level_citation_file_cites_the_seed_paper_as_cite_does():
    """CITATION.cff's reference to the seed paper is the one `bearingdyn cite --format cff`
    prints: type ``generic`` with its note, nothing the seed does not state (issue 32)."""
    root = _validate_cff((ROOT / "CITATION.cff").read_text())["references"]
    done = run_cli("cite", "vakharia2015", "--format", "cff")
    assert done.returncode == 0, done.stderr
    cited = _validate_cff(done.stdout)["references"]
    seed, = (r for r in root if r["title"] == SEED_PAPER_TITLE)
    said, = (r for r in cited if r["title"] == SEED_PAPER_TITLE)
    assert seed["type"] == said["type"] == "generic"
    assert seed["notes"] == said["notes"] and "no venue" in seed["notes"]
    for key in UNSTATED_KEYS:
        assert key not in seed and key not in said, key
    assert seed == said


@pytest.fixture
def user_spec(tmp_path, monkeypatch) -> Path:
    """The Mathieu spec renamed, in a folder of the user's own whose path holds '_'."""
    folder = tmp_path / "my_models"
    folder.mkdir()
    data = tomllib.loads((SPECS / "mathieu.toml").read_text())
    data["model"]["name"] = "my-oscillator"
    data["model"]["reference"] = "my notes & yours, 100 % mine"
    path = folder / "my-oscillator.toml"
    path.write_text(tomli_w.dumps(data))
    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    load_model.cache_clear()
    yield path
    load_model.cache_clear()


def test_a_user_spec_by_path_is_cited_by_its_real_path_and_hash(user_spec, tmp_path):
    out = tmp_path / "cite.bib"
    done = run_cli("cite", str(user_spec), "-o", str(out))
    assert done.returncode == 0, done.stderr
    entry = _entries(out.read_text())["bearingdyn-my-oscillator"]
    assert entry["specfile"] == str(user_spec.resolve())
    assert entry["sha256"] == _sha(user_spec)
    assert r"my notes \& yours, 100 \% mine" in entry["note"]  # escaped for LaTeX
    assert "vakharia-ball-bearings" not in _entries(out.read_text())
    done = run_cli("cite", str(user_spec), "--format", "cff")
    assert done.returncode == 0, done.stderr
    data = _validate_cff(done.stdout)
    assert data["identifiers"][0]["value"] == f"sha256:{_sha(user_spec)}"
    assert str(user_spec.resolve()) in data["abstract"]


def test_cli_prints_what_the_api_returns_and_rejects_a_bad_format():
    done = run_cli("cite", "vakharia2015")
    assert done.returncode == 0 and done.stdout == citation("vakharia2015")
    done = run_cli("cite", "vakharia2015", "--format", "ris")
    assert done.returncode == 2
    assert done.stderr.strip() == "error: format: must be one of bibtex, cff, got 'ris'"
