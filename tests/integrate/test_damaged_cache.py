"""A damaged cached library is built again, never loaded.

Loading a truncated shared library kills the process with SIGBUS before any self-test can
run, so every cached library carries its SHA-256 beside it (``compiled.intact``) and is
checked before it is opened. Each damage below is done to both kinds of cached library
(the CasADi blocks of ``simulate`` and the member kernel of an ensemble) in a separate
process; the next run rebuilds them and gives the same numbers bit for bit.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis.integrate import compiled
from tests.conftest import ROOT

pytestmark = pytest.mark.skipif(shutil.which(compiled.DEFAULT_CC) is None,
                                reason="no C compiler")

PROBE = """
import sys
import numpy as np
from analysis.integrate.ensemble import ensemble
from analysis.integrate.simulate import simulate
from analysis.model import as_system

run = simulate("balanced-rotor", 8, duration=0.02, transient=0.0)
ens = ensemble(as_system("balanced-rotor", 8), np.array([[1e-6, 0, 0, 0], [2e-6, 1e-6, 0, 0]]),
               duration=0.02)
np.savez(sys.argv[1], run=run.x.values, ens=ens.x.values)
"""


def _probe(cache: Path, out: Path) -> dict[str, np.ndarray]:
    env = {**os.environ, "BEARINGDYN_CACHE": str(cache), "PYTHONWARNINGS": "ignore"}
    for name in ("BEARINGDYN_CC", "BEARINGDYN_CFLAGS", "CC"):
        env.pop(name, None)
    res = subprocess.run([sys.executable, "-c", PROBE, str(out)], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, f"exit {res.returncode}: {res.stderr[-2000:]}"
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    return cache, _probe(cache, cache / "reference.npz")


def _libraries(cache: Path) -> list[Path]:
    found = sorted((cache / "compiled").glob("*.so"))
    assert len(found) == 2 and any("members" in p.name for p in found)
    return found


def _truncate(path: Path, other: bytes) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def _empty(path: Path, other: bytes) -> None:
    path.write_bytes(b"")


def _random(path: Path, other: bytes) -> None:
    path.write_bytes(np.random.default_rng(1).bytes(path.stat().st_size))


def _another(path: Path, other: bytes) -> None:
    path.write_bytes(other)  # a real library, of another kernel


@pytest.mark.parametrize("damage", [_truncate, _empty, _random, _another],
                         ids=["truncated", "emptied", "random", "another-kernel"])
def test_a_damaged_library_is_rebuilt_and_gives_the_same_bits(built, tmp_path, damage):
    reference_cache, reference = built
    cache = tmp_path / "cache"
    shutil.copytree(reference_cache, cache)
    first, second = _libraries(cache)
    originals = {p: p.read_bytes() for p in (first, second)}
    damage(first, originals[second])
    damage(second, originals[first])
    assert all(p.read_bytes() != originals[p] for p in (first, second))
    assert not any(compiled.intact(p) for p in (first, second))
    got = _probe(cache, tmp_path / "after.npz")
    for key, want in reference.items():
        np.testing.assert_array_equal(got[key], want)
    assert all(compiled.intact(p) for p in _libraries(cache))  # built again, with checksums


def test_an_intact_library_is_recognised_and_a_missing_checksum_is_not(built, tmp_path):
    cache, _ = built
    for path in _libraries(cache):
        assert compiled.intact(path)
        copy = tmp_path / path.name
        shutil.copyfile(path, copy)
        assert not compiled.intact(copy)  # no checksum beside it: an old cache, rebuilt
