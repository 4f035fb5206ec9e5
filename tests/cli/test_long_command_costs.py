"""Costs said before they are paid (issue 32 §3): `chart` and `sweep` print their estimate
(RK4 steps and expected time) as the first line on stderr, before any progress line, then
progress up to every point; `--quiet` prints neither."""

from __future__ import annotations

import pytest

CHART = ("chart", "vakharia2015", "--x", "speed_rpm:4000:5000:2", "--y", "n_balls:8:8",
         "--transient", "0.05", "--revolutions", "10", "--no-lyapunov", "--executor", "serial",
         "-o", "c.nc")
SWEEP = ("sweep", "vakharia2015", "--n-balls", "8", "--param", "speed_rpm", "--from", "4000",
         "--to", "5000", "--num", "3", "--transient", "0.05", "--samples", "30",
         "--executor", "serial", "-o", "d.nc")
COMMANDS = {"chart": (CHART, 2, "chart: "), "sweep": (SWEEP, 3, "sweep speed_rpm: ")}
"""Per command: its arguments, its points, and how its progress lines start."""


@pytest.mark.parametrize("name", COMMANDS)
def test_the_estimate_is_the_first_line_before_any_progress(cli, tmp_path, name):
    args, points, progress = COMMANDS[name]
    res = cli(*args, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines()  # a loaded machine adds a note
             if not line.startswith("note: the machine was loaded")]
    assert lines and lines[0].startswith(f"estimate: {points} points x "), res.stderr
    assert "RK4 steps" in lines[0] and "expected" in lines[0]
    assert sum(line.startswith("estimate:") for line in lines) == 2
    assert lines[1].startswith("estimate: in all ") and "start-up and probes" in lines[1] \
        and "the file" in lines[1], "the whole command (issue 41)"
    shown = [i for i, line in enumerate(lines) if line.startswith(progress)]
    assert shown and shown[0] > 0, f"no progress line after the estimate: {res.stderr}"
    assert lines[shown[-1]].startswith(f"{progress}{points}/{points} points"), res.stderr


@pytest.mark.parametrize("name", COMMANDS)
def test_quiet_prints_no_estimate_and_no_progress(cli, tmp_path, name):
    args, _, progress = COMMANDS[name]
    res = cli(*args, "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("wrote ")
    said = [line for line in res.stderr.splitlines()
            if line.startswith(("estimate:", progress))]
    assert said == [], res.stderr
