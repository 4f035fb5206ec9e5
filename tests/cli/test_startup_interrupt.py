"""Ctrl-C in the first fraction of a second: ``analysis.cli.entry`` installs its handler
before anything of the command is imported, so an interrupt while the command loads ends
with one line and exit code 130, never a ``KeyboardInterrupt`` traceback.

What remains is the interpreter's own start, before our first statement runs (Python's
initialisation, ``site`` and its ``.pth`` files, the package ``__init__`` files that only
import ``importlib`` and ``typing``): a traceback is allowed only when every frame in it is
there. On a loaded machine most early delays land in that window, so the test also
requires that some interrupt was caught by our handler (a delay long enough to be in our
code)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

from tests.conftest import ROOT

BEFORE_OUR_CODE = {ROOT / "analysis" / "__init__.py", ROOT / "analysis" / "cli" / "__init__.py",
                   ROOT / "analysis" / "cli" / "__main__.py"}
"""Files of ours that run before ``analysis.cli.entry``'s first statement (``python -m
analysis.cli`` imports the two packages, then ``__main__`` imports the entry)."""
DELAYS = (0.0, 0.02, 0.05, 0.1, 0.3, 0.6, 1.0)
"""Seconds between the start and SIGINT: the brief's five, and two that reach our code on a
loaded machine."""
COMMAND = ("simulate", "vakharia2015", "-o", "r.nc", "--duration", "0.01", "--transient", "0",
           "--no-compile")


def _interrupted(delay: float, cwd) -> subprocess.CompletedProcess:
    proc = subprocess.Popen([sys.executable, "-m", "analysis.cli", *COMMAND], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


ENTRY = ROOT / "analysis" / "cli" / "entry.py"
HANDLED_FROM = next(i for i, line in enumerate(ENTRY.read_text().splitlines(), 1)
                    if line.strip().startswith("signal.signal(signal.SIGINT"))
"""The line of the entry that installs the handler: frames before it are Python's window."""


ENVIRONMENT = (sys.prefix, sys.base_prefix)
"""The interpreter's environment: its files (``site``, the editable install's ``.pth``
finder) are Python's start even where the environment lies inside the repository (CI makes
``.venv-ci`` there)."""


def _ours_ran(traceback: str) -> list[str]:
    """The frames of a traceback in files of this repository once the entry's handler was
    installed (an interrupt our handler should have caught); files of the interpreter's
    environment are not the repository's."""
    frames = re.findall(r'File "([^"]+)", line (\d+)', traceback)
    return [f"{f}:{n}" for f, n in frames if f.startswith(str(ROOT))
            and not any(f.startswith(prefix + "/") for prefix in ENVIRONMENT)
            and f not in {str(p) for p in BEFORE_OUR_CODE}
            and not (f == str(ENTRY) and int(n) < HANDLED_FROM)]


def test_ctrl_c_while_the_command_starts_is_one_line_and_exit_130(tmp_path):
    caught = 0
    for delay in DELAYS:
        res = _interrupted(delay, tmp_path)
        if "Traceback" in res.stderr:  # Python's own start: allowed, nothing of ours ran
            assert not _ours_ran(res.stderr), (delay, res.stderr)
            continue
        if res.returncode == -signal.SIGINT:  # before Python's own handler: killed, silent
            assert res.stderr == "", (delay, res.stderr)
            continue
        assert res.returncode in (130, 0), (delay, res.returncode, res.stderr)
        if res.returncode == 130:
            assert res.stderr.startswith("interrupted") and res.stderr.count("\n") == 1, \
                (delay, res.stderr)
            caught += 1
    assert caught >= 1, "no interrupt reached the command's own handler"
