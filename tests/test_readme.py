"""The README's commands are the ones CI runs; the tree is lint-clean."""

from __future__ import annotations

import re
import subprocess
import sys

from tests.conftest import ROOT


def _bash_blocks() -> list[str]:
    return re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), re.S)


def test_ci_runs_the_readmes_two_commands_first_in_a_fresh_environment():
    """.ci/run's first stage is the README's two commands, verbatim and in order, in a
    virtual environment made just before them with nothing installed in between; the
    extras come after, in an environment of their own."""
    main_command, test_command = (b.strip() for b in _bash_blocks()[:2])
    assert "pytest" in test_command
    lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
             if line.strip() and not line.strip().startswith(("#", "echo"))]
    first = lines.index(main_command)
    assert lines[first + 1] == test_command
    before = lines[:first]
    venv = max(i for i, line in enumerate(before) if line.startswith("python3 -m venv"))
    assert not any("pip install" in line for line in before[venv:])
    after = lines[first + 2:]
    extras_venv = next(i for i, line in enumerate(after) if line.startswith("python3 -m venv"))
    assert any("pip install" in line and "docs" in line for line in after[extras_venv:])
    assert any("-m needs_extra" in line and "BEARINGDYN_REQUIRE_EXTRAS=1" in line
               for line in after[extras_venv:])


def test_readme_main_command_installs_and_runs():
    assert _bash_blocks()[0].strip() == "python3 -m pip install -e . && bearingdyn run"


def test_ruff_is_clean():
    res = subprocess.run([sys.executable, "-m", "ruff", "check", str(ROOT)],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr
