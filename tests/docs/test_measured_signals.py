"""docs/measured-signals.md: every command of the page runs on the CWRU records of
``../shared/data/cwru`` (skipped with the reason where they are not) and prints the verdict
the page shows; its figures are written to a temporary folder, not over the page's."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from tests.conftest import ROOT
from tests.docs.pages import page_commands
from tests.measured.cwru import needs_cwru

PAGE = ROOT / "docs" / "measured-signals.md"

EXPECT = {
    "12k_Drive_End_IR007_0_105.mat --channel DE --bearing 6205-cwru -o":
        ["verdict: inner-race", "BPFI theory   162.10 Hz"],
    "12k_Fan_End_OR007@6_0_294.mat": ["verdict: outer-race"],
    "12k_Drive_End_B028_0_3005.mat": ["verdict: ball", "1797.0 rpm from --rpm"],
    "cwru/ --channel": ["12k_Drive_End_IR007_0_105.mat  inner-race",
                        "12k_Fan_End_OR007@6_0_294.mat  none",
                        "12k_Drive_End_B028_0_3005.mat  ball"],
    "record info": ["12000 Hz", "X105_DE_time"],
    "--json": ['"verdict": "inner-race"', '"bsf_convention"'],
}
"""Per command (a piece of its text): what its output must hold."""


def test_the_page_has_its_commands_and_figures():
    commands = page_commands(PAGE.read_text(encoding="utf-8"))
    assert [c[0] for c in commands] == ["record", "diagnose", "diagnose", "diagnose",
                                        "diagnose", "diagnose"]
    figures = [c[c.index("-o") + 1] for c in commands if "-o" in c]
    assert len(figures) == 3
    for figure in figures:
        assert (ROOT / figure).exists(), figure
        assert f"({Path(figure).relative_to('docs')})" in PAGE.read_text(encoding="utf-8")
    for command in commands:
        text = " ".join(command)
        assert any(key in text for key in EXPECT), text


@needs_cwru
def test_measured_signals_commands_run(tmp_path, monkeypatch):
    from analysis.cli import app

    monkeypatch.chdir(ROOT)  # the page's paths: ../shared/data/cwru/ beside the checkout
    for args in page_commands(PAGE.read_text(encoding="utf-8")):
        if "-o" in args:
            i = args.index("-o")
            args = [*args[:i + 1], str(tmp_path / Path(args[i + 1]).name), *args[i + 2:]]
        if "cwru/" in args[1]:
            args = [*args, "--workers", "1"]  # in this process: the test's own core
        res = CliRunner().invoke(app, args)
        text = " ".join(args)
        assert res.exit_code == 0, f"{text}: {res.output}"
        for key, wanted in EXPECT.items():
            if key in text:
                for piece in wanted:
                    assert piece in res.output, f"{text}: {piece!r} not in {res.output}"
        if "-o" in args:
            assert (tmp_path / Path(args[args.index("-o") + 1]).name).stat().st_size > 10_000
