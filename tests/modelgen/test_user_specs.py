"""User specs are first-class: a spec kept in the user's own folder runs by path (CLI and
API) and by name (``BEARINGDYN_MODELS``), its code goes to the user cache or a folder the
user names, its provenance (real path, sha256) is true, and the package is never written."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import tomli_w
import xarray as xr

from analysis.errors import StaleModelError
from analysis.model import load_model
from tests.conftest import ROOT, SPECS

PACKAGE_DIRS = ("modelgen", "generated", "analysis")


def tree_digest(root: Path, folders=PACKAGE_DIRS) -> dict[str, str]:
    """sha256 of every file under ``folders`` of ``root`` (caches of Python excluded)."""
    out = {}
    for folder in folders:
        for path in sorted((root / folder).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                out[str(path.relative_to(root))] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


@pytest.fixture
def user_spec(tmp_path, monkeypatch) -> Path:
    """rotor-housing, renamed and with a lighter housing, in a folder of the user's own;
    the user cache in the temporary folder too."""
    folder = tmp_path / "my-models"
    folder.mkdir()
    data = tomllib.loads((SPECS / "rotor-housing.toml").read_text())
    data["model"]["name"] = "my-rotor"
    data["parameters"]["housing_mass"]["value"] = 1.5
    path = folder / "my-rotor.toml"
    path.write_text(tomli_w.dumps(data))
    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    load_model.cache_clear()
    yield path
    load_model.cache_clear()


def _cli(*args: str, env: dict | None = None, cwd: Path | None = None):
    return subprocess.run([sys.executable, "-m", "analysis.cli", *args], capture_output=True,
                          text=True, cwd=cwd or ROOT, timeout=600,
                          env={**os.environ, "PYTHONWARNINGS": "ignore", **(env or {})})


def test_a_spec_runs_by_path_with_true_provenance_and_the_package_untouched(user_spec,
                                                                           tmp_path):
    before = tree_digest(ROOT)
    digest = hashlib.sha256(user_spec.read_bytes()).hexdigest()
    out = tmp_path / "run.nc"
    res = _cli("simulate", str(user_spec), "-o", str(out), "--duration", "0.01",
               "--transient", "0")
    assert res.returncode == 0, res.stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["model"] == "my-rotor"
        assert ds.attrs["spec_file"] == str(user_spec.resolve())
        assert ds.attrs["spec_sha256"] == digest
        assert ds.attrs["housing_mass"] == 1.5
        assert "x_housing" in ds
    # the API, the same spec: the cached code, the same provenance
    model = load_model(user_spec)
    assert model.spec_file == str(user_spec.resolve()) and model.spec_sha256 == digest
    header = Path(model.module.__file__).read_text()
    assert f"from {user_spec.resolve()}" in header and digest in header
    assert Path(model.module.__file__).is_relative_to(tmp_path / "cache")
    assert tree_digest(ROOT) == before, "a user spec wrote into the package"


def test_a_user_folder_makes_names_known(user_spec, tmp_path):
    env = {"BEARINGDYN_MODELS": str(user_spec.parent)}
    listed = _cli("models", env=env)
    assert listed.returncode == 0, listed.stderr
    assert "my-rotor" in listed.stdout and "vakharia2015" in listed.stdout
    out = tmp_path / "byname.nc"
    res = _cli("simulate", "my-rotor", "-o", str(out), "--duration", "0.005",
               "--transient", "0", env=env)
    assert res.returncode == 0, res.stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["spec_file"] == str(user_spec.resolve())


def test_generate_out_writes_a_loadable_folder_that_knows_when_it_is_stale(user_spec,
                                                                          tmp_path):
    before = tree_digest(ROOT)
    out = tmp_path / "models"
    res = _cli("generate", str(user_spec), "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert tree_digest(ROOT) == before
    for where in (out, out / "my_rotor"):
        load_model.cache_clear()
        model = load_model(where)
        assert model.name == "my-rotor" and model.n_state == 8
    text = (out / "my_rotor" / "__init__.py").read_text()
    assert f"Regenerate: bearingdyn generate {user_spec.resolve()} --out {out.resolve()}" in text
    user_spec.write_text(user_spec.read_text().replace("value = 1.5", "value = 1.25"))
    load_model.cache_clear()
    with pytest.raises(StaleModelError, match="regenerate it"):
        load_model(out)


def test_a_changed_spec_gets_new_code_in_the_cache(user_spec):
    first = load_model(user_spec)
    user_spec.write_text(user_spec.read_text().replace("value = 1.5", "value = 1.25"))
    load_model.cache_clear()
    second = load_model(user_spec)
    assert second.defaults["housing_mass"] == 1.25 and first.defaults["housing_mass"] == 1.5
    assert second.spec_sha256 == hashlib.sha256(user_spec.read_bytes()).hexdigest()


@pytest.mark.slow
def test_a_non_editable_install_runs_a_user_spec_without_writing_itself(user_spec, tmp_path):
    """Installed as a wheel (not editable) into a folder of its own: a user spec runs by path
    and the installed package's files are byte-identical afterwards."""
    site = tmp_path / "site"
    build = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
         "--target", str(site), str(ROOT)], capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stderr
    before = tree_digest(site)
    assert any(k.startswith("generated/") for k in before)
    out = tmp_path / "installed.nc"
    code = ("import analysis, sys\n"
            f"assert analysis.__file__.startswith({str(site)!r}), analysis.__file__\n"
            "from analysis import simulate\n"
            f"ds = simulate({str(user_spec)!r}, duration=0.005, transient=0.0)\n"
            "print(ds.attrs['spec_file'])\n")
    env = {**os.environ, "PYTHONPATH": str(site), "PYTHONWARNINGS": "ignore"}
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, env=env, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == str(user_spec.resolve())
    res = subprocess.run([sys.executable, "-m", "analysis.cli", "simulate", str(user_spec), "-o",
                          str(out), "--duration", "0.005", "--transient", "0"],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600)
    assert res.returncode == 0, res.stderr
    assert tree_digest(site) == before, "the installed package was written"
    shutil.rmtree(site)
