"""docs/model-vs-measurement.md: every command of the page runs (the simulation shorter) on
the CWRU record, and prints what the page says; its Python example runs too. Skipped where
the records are not beside the checkout (``../shared/data/cwru``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.docs.pages import page_commands

PAGE = ROOT / "docs" / "model-vs-measurement.md"
DATA = Path(ROOT).parent / "shared" / "data" / "cwru"
RECORD = "../shared/data/cwru/12k_Drive_End_IR007_0_105.mat"
needs_data = pytest.mark.skipif(not (DATA / Path(RECORD).name).exists(),
                                reason=f"the CWRU records are not in {DATA}")

SMALL = {"simulate": {"--duration": "1.2"}}
"""Per command: options set to a smaller value (1 s kept instead of 2)."""
EXPECT = [
    ["verdict: inner-race"],
    ["saved at 12000 Hz: every 42 steps"],
    ["BPFI                5.401", "both", "record only", "6205-cwru"],
    ["verdict: inner-race", "model check: 6205-inner-defect", "BPFI                5.401"],
]
"""Per command of the page, in its order: what its output must hold."""


def shrink(args: list[str]) -> list[str]:
    args = [str(DATA / Path(a).name) if a == RECORD else a for a in args]
    for option, value in SMALL.get(args[0], {}).items():
        args[args.index(option) + 1] = value
    return args


def test_the_page_names_its_commands():
    commands = page_commands(PAGE.read_text(encoding="utf-8"))
    assert [c[0] for c in commands] == ["diagnose", "simulate", "compare", "diagnose"]
    assert commands[3][-2:] == ["--model", "auto"]
    assert "--sample-rate" in commands[1] and "housing_resonance_hz=3000" in commands[1]
    assert commands[2][1] == RECORD and "figures/compare-cwru-inner.png" in \
        PAGE.read_text(encoding="utf-8")


@needs_data
def test_the_page_commands_run(cli, tmp_path):
    commands = page_commands(PAGE.read_text(encoding="utf-8"))
    for args, expected in zip(commands, EXPECT, strict=True):
        done = cli(*shrink(args), cwd=tmp_path)
        assert done.returncode == 0, (args, done.stderr)
        for words in expected:
            assert words in done.stdout, (args[0], words, done.stdout)
    assert (tmp_path / "compare-cwru-inner.png").stat().st_size > 10_000


@needs_data
def test_the_page_python_example_runs(monkeypatch, capsys):
    code = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), flags=re.S)
    assert len(code) == 1
    monkeypatch.chdir(ROOT)
    exec(compile(code[0].replace(RECORD, str(DATA / Path(RECORD).name)), str(PAGE), "exec"),
         {})
    printed = capsys.readouterr().out
    assert "'BPFI'" in printed and "'BPFI-X'" in printed, printed
