"""Generated code is written whole or not at all, and damage found later is repaired.

The disk fills part way through ``bearingdyn generate`` (``os.fsync`` raises ENOSPC or
EFBIG after the first files): the command ends in one line naming the file, exit code 1,
and leaves no model folder, a half-written one or a changed one. Then a cache entry is
damaged by hand (its C file removed, its module truncated): the next command says so in one
line, generates it again, and its run equals a clean run's bit for bit.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.io import open_result
from analysis.model import load_model
from modelgen.locations import cached_model_root, manifest_problem
from tests.conftest import SPECS, run_cli

RUN = ("--duration", "1", "--transient", "0", "--no-compile")


@pytest.fixture
def spec(tmp_path, monkeypatch) -> Path:
    """duffing as a user spec ``myduff.toml`` in ``tmp_path``, with an empty user cache."""
    path = tmp_path / "myduff.toml"
    path.write_text((SPECS / "duffing.toml").read_text().replace('name = "duffing"',
                                                                 'name = "myduff"'))
    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    load_model.cache_clear()
    yield path
    load_model.cache_clear()


def _generate(*args: str):
    """``bearingdyn generate …`` in this process (so the disk can be made to fill)."""
    return CliRunner().invoke(app, ["generate", *args])


def _fill_disk_after(monkeypatch, files: int, code: int) -> None:
    """Every ``os.fsync`` after the first ``files`` fails as a full disk does."""
    real, calls = os.fsync, []

    def fsync(fd: int) -> None:
        calls.append(fd)
        if len(calls) > files:
            raise OSError(code, os.strerror(code))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)


def _entries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EFBIG], ids=["ENOSPC", "EFBIG"])
def test_a_disk_that_fills_during_generate_leaves_no_model_folder(spec, monkeypatch, code):
    before = _entries(spec.parent)
    _fill_disk_after(monkeypatch, 2, code)
    for args in ((str(spec), "--out", "gen"), (str(spec),)):
        res = _generate(*args)
        assert res.exit_code == 1, res.output
        line = res.output.strip()
        assert "\n" not in line and os.strerror(code) in line, line
        assert "/myduff" in line or "__init__.py" in line, "the line names the file"
    assert _entries(spec.parent) == sorted({*before, "cache"}) or \
        _entries(spec.parent) == before
    assert _entries(spec.parent / "cache" / "models") == [], "no half-written cache entry"


def test_a_full_disk_during_regeneration_keeps_the_old_folder(spec, monkeypatch, tmp_path):
    assert _generate(str(spec), "--out", "gen").exit_code == 0
    old = {p.relative_to(tmp_path): p.read_bytes() for p in (tmp_path / "gen").rglob("*")
           if p.is_file()}
    spec.write_text(spec.read_text().replace('title = "', 'title = "Edited: '))
    _fill_disk_after(monkeypatch, 1, errno.ENOSPC)
    res = _generate(str(spec), "--out", "gen")
    assert res.exit_code == 1 and "No space left on device" in res.output
    now = {p.relative_to(tmp_path): p.read_bytes() for p in (tmp_path / "gen").rglob("*")
           if p.is_file()}
    assert now == old, "the old model folder, byte for byte"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
    assert [p.name for p in (tmp_path / "gen").iterdir() if p.name.startswith(".")] == []


def test_a_damaged_cache_entry_is_said_regenerated_and_equals_a_clean_run(spec, tmp_path):
    env = {"BEARINGDYN_CACHE": str(tmp_path / "cache"), "PYTHONWARNINGS": "default"}
    clean = run_cli("simulate", str(spec), "-o", "clean.nc", *RUN, cwd=tmp_path, env=env)
    assert clean.returncode == 0, clean.stderr
    root = cached_model_root(spec)
    assert manifest_problem(root) is None
    module = root / "myduff"
    for damage in (lambda: (module / "myduff.c").unlink(),
                   lambda: (module / "__init__.py").write_text("NAME = 'myd")):
        damage()
        res = run_cli("simulate", str(spec), "-o", "again.nc", *RUN, cwd=tmp_path, env=env)
        assert res.returncode == 0, res.stderr
        warned = [line for line in res.stderr.splitlines() if line.strip()]
        assert len(warned) == 1 and "the cached code of myduff.toml is damaged" in warned[0]
        assert "generating it again" in warned[0]
        assert manifest_problem(root) is None
        a, b = open_result(tmp_path / "clean.nc"), open_result(tmp_path / "again.nc")
        for name in ("x", "y", "vx", "vy"):
            np.testing.assert_array_equal(a[name].values, b[name].values)
        assert {k: v for k, v in a.attrs.items() if k != "created"} == \
            {k: v for k, v in b.attrs.items() if k != "created"}


def test_a_damaged_out_folder_is_refused_in_one_line(spec, tmp_path):
    assert _generate(str(spec), "--out", "gen").exit_code == 0
    (tmp_path / "gen" / "myduff" / "__init__.py").write_text("")
    res = run_cli("simulate", "gen", "-o", "r.nc", *RUN, cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert "model: gen is damaged (myduff/__init__.py was changed" in res.stderr
    assert not (tmp_path / "r.nc").exists()
