"""docs/first-study.md: every command of the page runs, at the smaller sizes of ``SMALL``,
and prints what the page says it prints (issue 32: a walk-through with no default that
misleads)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.docs.pages import page_commands

PAGE = Path(__file__).resolve().parents[2] / "docs" / "first-study.md"

SMALL: dict[str, dict[str, str | None]] = {
    "run": {"--duration": "0.8", "--transient": "0.3"},
    "attractors": {"--samples": "12", "--executor": "serial"},
    "torus": {"--points": "17", "--lyapunov-duration": "0", "--plot": None},
    "simulate vakharia2015": {"--duration": "0.6"},
    "simulate 6205-outer-defect": {"--duration": "0.45", "--transient": "0.15"},
    "spectrum": {"-o": None},
}
"""Per command (its first words): options set to a smaller value, or dropped (None)."""

EXPECT = {
    "run": ["docs/calibration.md", "class (paper)"],
    "attractors": ["attractor(s)", "%"],
    "torus": ["by the invariant circle", "circle tail", "change at N = 34",
              "between the sections"],
    "simulate vakharia2015": ["kept speeds 1000 → 10000 rpm"],
    "waterfall": ["rpm"],
    "spectrum": ["holds the structural resonance at 8000 Hz", "BPFO"],
}
"""Per command: what its output must hold."""


def key_of(args: list[str], table: dict) -> str:
    """The longest key of ``table`` the command starts with ('' for none)."""
    words = " ".join(args[:2])
    return max((k for k in table if words == k or words.startswith(k + " ")
                or args[0] == k), key=len, default="")


def shrink(args: list[str]) -> list[str]:
    """``args`` with ``SMALL``'s options of its command set or dropped."""
    args = list(args)
    for option, value in SMALL.get(key_of(args, SMALL), {}).items():
        if option in args:
            i = args.index(option)
            del args[i:i + 2]
        if value is not None:
            args += [option, value]
    return args


def test_the_page_shrinks_each_command():
    commands = page_commands(PAGE.read_text(encoding="utf-8"))
    assert [c[0] for c in commands] == ["run", "attractors", "torus", "simulate", "waterfall",
                                        "simulate", "spectrum"]
    small = shrink(commands[2])
    assert "--plot" not in small and small[small.index("--points") + 1] == "17"
    assert "--transient" in commands[3] and commands[3][commands[3].index("--transient") + 1] \
        == "0"


@pytest.mark.slow
def test_first_study_commands_run(cli, tmp_path):
    outputs = []
    for args in page_commands(PAGE.read_text(encoding="utf-8")):
        out = cli(*shrink(args), cwd=tmp_path)
        assert out.returncode == 0, f"{args}: {out.stderr[-2000:]}"
        for needle in EXPECT.get(key_of(args, EXPECT), []):
            assert needle in out.stdout, f"{args}: {needle!r} not in {out.stdout[-2000:]}"
        outputs.append(out.stdout)
    assert outputs[0].count("Where the classes differ from the paper's") == 1  # run: one line
    assert "note: the residual is not the error" not in outputs[2]  # the default is no HB
