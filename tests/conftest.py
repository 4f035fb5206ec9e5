"""Shared fixtures: shipped specs and the project root."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.extras import REQUIRE, extras_required

ROOT = Path(__file__).resolve().parent.parent
SPECS = ROOT / "modelgen" / "specs"


def run_cli(*args: str, cwd: Path | None = None,
            env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """Run the real ``bearingdyn`` command (as a user does) and capture its output
    (``env``: variables set for it on top of this process's)."""
    env = {**os.environ, "PYTHONWARNINGS": "ignore", **(env or {})}
    return subprocess.run([sys.executable, "-m", "analysis.cli", *args], capture_output=True,
                          text=True, cwd=cwd or ROOT, env=env, timeout=600)


@pytest.fixture
def cli():
    return run_cli


@pytest.fixture
def user_cache(tmp_path, monkeypatch):
    """An empty user cache (``BEARINGDYN_CACHE``) for the test, with ``load_model``'s memo
    cleared before and after; yields ``tmp_path``."""
    from analysis.model import load_model

    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    load_model.cache_clear()
    yield tmp_path
    load_model.cache_clear()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under ``BEARINGDYN_REQUIRE_EXTRAS=1`` (.ci/run's second stage, where the extras are
    installed) a ``needs_extra`` test that skips has failed: its extra did not install."""
    outcome = yield
    report = outcome.get_result()
    if report.skipped and extras_required() and item.get_closest_marker("needs_extra"):
        report.outcome = "failed"
        report.longrepr = f"{REQUIRE}=1 but the test skipped: {report.longrepr}"



def pytest_configure(config: pytest.Config) -> None:
    """On xdist's workers (``-n N``), its default ``--dist load`` becomes ``loadgroup``: the
    tests marked ``xdist_group`` (a module whose fixtures run a catalogue of commands or a
    long study) run on one worker, so those fixtures run once, not once per worker (the
    bad-input catalogue's commands ran twice: 4 minutes each); every other test is spread
    one by one, as with ``load`` (an explicit ``--dist load`` too: the two look alike here;
    any other ``--dist`` given is kept). A worker parses the command line again, so it
    learns the mode from its ``workerinput`` (``pytest_configure_node``) and names its
    grouped tests as ``loadgroup`` does."""
    if getattr(config.option, "dist", "no") == "load" and not config.option.distload:
        config.option.dist = "loadgroup"
    if getattr(config, "workerinput", {}).get(LOADGROUP):
        config.option.loadgroup = True


LOADGROUP = "bearingdyn_loadgroup"
"""The ``workerinput`` key that tells an xdist worker the controller runs ``loadgroup``."""


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node) -> None:
    """xdist's controller, before each worker starts: pass it the distribution mode."""
    node.workerinput[LOADGROUP] = node.config.option.dist == "loadgroup"
