"""The needs_extra rule: a test that needs an optional extra skips with its install line on
the README's test command, and fails where .ci/run's second stage requires the extras."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.conftest import ROOT

PROBE = '''
import pytest
from tests.extras import require

@pytest.mark.needs_extra
def test_needs_a_missing_extra():
    require("bearingdyn_no_such_module", "docs")

def test_plain_skip():
    pytest.skip("not an extra")
'''


def _run(tmp_path, require: str) -> subprocess.CompletedProcess:
    probe = ROOT / "tests" / f"_probe_extras_{os.getpid()}_{require or 'no'}.py"
    probe.write_text(PROBE)
    try:
        env = {**os.environ, "BEARINGDYN_REQUIRE_EXTRAS": require}
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                               "-rs", str(probe)], cwd=ROOT, env=env, capture_output=True,
                              text=True, timeout=120)
    finally:
        probe.unlink()


def test_a_missing_extra_skips_with_its_install_line(tmp_path):
    res = _run(tmp_path, "")
    assert res.returncode == 0, res.stdout
    assert "2 skipped" in res.stdout
    assert "python3 -m pip install -e '.[docs]'" in res.stdout


def test_a_missing_extra_fails_where_the_extras_are_required(tmp_path):
    res = _run(tmp_path, "1")
    assert res.returncode == 1, res.stdout
    assert "1 failed, 1 skipped" in res.stdout  # the plain skip stays a skip
    assert "BEARINGDYN_REQUIRE_EXTRAS=1 but the test skipped" in res.stdout
