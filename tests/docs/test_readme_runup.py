"""README.md's run-up command keeps the whole ramp (issue 32 §1: the default 1 s transient
silently dropped 1000-3250 rpm). The command is read from the README's "Using it" block, only
its ``--duration`` is shortened, and the speeds are judged from the file it writes."""

from __future__ import annotations

import re
import shlex

import numpy as np

from analysis.integrate.speed_profile import profile_of
from analysis.io import open_result
from tests.conftest import ROOT

SHORT_DURATION = "0.3"
"""The run's length (s) in the test: the README's ramp over a shorter time."""


def readme_runup() -> list[str]:
    """The arguments (after ``bearingdyn``) of the README "Using it" command that simulates a
    ramp (``--speed-rpm LO:HI``), its comment dropped."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Using it", 1)[1]
    block = re.search(r"```bash\n(.*?)```", section, flags=re.S).group(1)
    found = []
    for line in block.splitlines():
        if not line.startswith("bearingdyn simulate") or "--speed-rpm" not in line:
            continue
        args = shlex.split(line.split("#")[0])
        if args[:2] == ["bearingdyn", "simulate"] and "--speed-rpm" in args \
                and ":" in args[args.index("--speed-rpm") + 1]:
            found.append(args[1:])
    assert len(found) == 1, f"one run-up command expected in 'Using it', found {found}"
    return found[0]


def with_option(args: list[str], option: str, value: str) -> list[str]:
    """``args`` with ``option``'s value replaced by ``value`` (the option must be there)."""
    args = list(args)
    args[args.index(option) + 1] = value
    return args


def test_the_readme_command_is_a_ramp_kept_whole():
    args = readme_runup()
    assert args[args.index("--speed-rpm") + 1] == "1000:10000"
    assert "-o" in args and "--duration" in args


def test_readme_runup_keeps_the_whole_ramp(cli, tmp_path):
    args = with_option(readme_runup(), "--duration", SHORT_DURATION)
    out = cli(*args, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lo, hi = (float(v) for v in args[args.index("--speed-rpm") + 1].split(":"))
    written = open_result(tmp_path / args[args.index("-o") + 1])
    t = written["t"].values
    profile = profile_of(written.attrs)
    assert profile is not None, "the run-up's file records no speed profile"
    kept = profile.speed(t, float(SHORT_DURATION))
    one_sample = (hi - lo) / float(SHORT_DURATION) * float(np.median(np.diff(t)))
    assert abs(kept[0] - lo) <= one_sample, (
        f"the file starts at {kept[0]:.0f} rpm, not {lo:.0f}: the ramp's start was dropped")
    assert abs(kept[-1] - hi) <= one_sample, f"the file ends at {kept[-1]:.0f} rpm"
    assert t[-1] >= float(SHORT_DURATION) - float(np.median(np.diff(t)))
    assert f"kept speeds {lo:.0f} → {hi:.0f} rpm" in out.stdout
    assert "dropped" not in out.stdout
