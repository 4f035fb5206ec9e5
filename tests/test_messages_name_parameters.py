"""Library messages name parameters, not command-line options (issue 39).

An error the library raises begins with the parameter it is about (``band: …``) and carries
it as its ``field``; the command line turns the field into the running command's option
(``--band: …``, ``analysis.cli.common.as_option``) without reading the text back. This test
reads every module under ``analysis/`` except ``analysis/cli/`` with ``ast`` and fails on an
``InputError``, ``DeviceError`` or ``ValueError`` whose message (an f-string's first
constant part, the left end of a ``+``) starts with ``--``, and on a ``check_count`` whose
field does, listing ``file:line``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "analysis"
ERRORS = {"InputError", "DeviceError", "ValueError"}
"""The errors whose first argument is the message the user reads."""
CHECKS = {"check_count"}
"""Checks whose first argument is the field their message begins with."""

STILL_CONVERTING: dict[str, str] = {}
"""Files whose flag messages are still being converted (none now)."""

NOT_GIVEN: dict[tuple[str, str], str] = {
    ("analysis/signal/envelope.py", 'f"--band: no band of at least'):
        "the band search of spectrum --envelope without --band",
    ("analysis/linear/unbalance.py", '"--unbalance: the model has no [[shaft.unbalances]]'):
        "unbalance without --unbalance and a model without one",
    ("analysis/measured/records.py", 'f"--{field}: this record has'):
        "a record of several channels, --channel not given",
    ("analysis/measured/diagnose.py", 'f"--fs: the sampling rate must be'):
        "the rate may be the file's",
    ("analysis/measured/diagnose.py", 'f"--rpm: the shaft speed must be'):
        "the speed may be the file's or the tacho's",
    ("analysis/measured/diagnose.py", 'f"--fs: {fs:g} Hz cannot hold a band'):
        "the rate may be the file's",
    ("analysis/measured/diagnose.py", '"--rpm: the record holds no shaft speed'):
        "neither --rpm nor --tacho given",
    ("analysis/measured/diagnose.py", 'f"--rpm: the record\'s shaft speed must be'):
        "the speed is the record's, --rpm not given",
}
"""Messages about a value the command line may not have been given: ``as_option`` names
only an option that holds a value, so these keep naming the option until the command line
can name an empty one (``(file, start of the message's source)``: why)."""


def _name(func: ast.expr) -> str | None:
    if isinstance(func, ast.Name):
        return func.id
    if isinstance(func, ast.Attribute):
        return func.attr
    return None


def _head(node: ast.expr) -> str | None:
    """The constant text a message starts with (a literal, an f-string's first constant
    part, the left end of a ``+``), or None when it starts with something computed."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr) and node.values:
        return _head(node.values[0])
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _head(node.left)
    return None


def flag_messages(source: str) -> list[tuple[int, str]]:
    """``(line, source of the message)`` of each message in ``source`` that starts with
    ``--``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call) or not node.args or \
                _name(node.func) not in ERRORS | CHECKS:
            continue
        head = _head(node.args[0])
        if head is not None and head.startswith("--"):
            first = node.args[0]
            while isinstance(first, ast.BinOp):
                first = first.left
            found.append((node.lineno, ast.get_source_segment(source, first) or head))
    return found


def _modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py")
                  if p.relative_to(PACKAGE).parts[0] != "cli")


def _kept(name: str, text: str) -> bool:
    return any(name == file and text.startswith(start) for file, start in NOT_GIVEN)


def test_the_scan_reads_the_library_without_the_command_line():
    modules = _modules()
    assert len(modules) > 100
    assert PACKAGE / "errors.py" in modules
    assert not any(p.relative_to(PACKAGE).parts[0] == "cli" for p in modules)


@pytest.mark.parametrize(("source", "lines"), [
    ('raise InputError(f"--band: got {x}")', [1]),
    ('raise InputError("--band: " + text)', [1]),
    ('raise ValueError("--x: bad")', [1]),
    ('check_count("--workers", x)', [1]),
    ('raise InputError(f"band: got {x}", field="band")', []),
    ('raise InputError(f"{where}: got {x}")', []),
    ('check_count("workers", x)', []),
    ('label = "--band: "', []),
])
def test_the_scan_finds_a_flag_where_a_message_starts(source, lines):
    assert [line for line, _ in flag_messages(source)] == lines


def test_library_messages_name_parameters():
    found = []
    for path in _modules():
        name = path.relative_to(ROOT).as_posix()
        if name in STILL_CONVERTING:
            continue
        found += [f"{name}:{line}: {text}"
                  for line, text in flag_messages(path.read_text(encoding="utf-8"))
                  if not _kept(name, text)]
    assert not found, ("messages that name a command-line option instead of a parameter "
                       "(raise InputError('name: …', field='name')):\n" + "\n".join(found))


def test_the_lists_hold_only_messages_still_there():
    stale = [name for name in STILL_CONVERTING
             if not (ROOT / name).exists() or not flag_messages((ROOT / name).read_text())]
    stale += [f"{file}: {start}" for file, start in NOT_GIVEN
              if not any(text.startswith(start)
                         for _, text in flag_messages((ROOT / file).read_text()))]
    assert not stale, f"no such flag message any more; take it off the lists: {stale}"


COMMAND_FIELDS = {
    "spectrum": ("band", "noise", "noise_seed", "var", "channel", "rpm", "tacho", "fs"),
    "plot": ("var", "node", "channel", "rpm", "tacho", "fs"),
    "waterfall": ("var", "window", "samples_per_rev", "channel", "tacho", "rpm", "fs"),
    "campbell": ("speeds", "modes"),
    "unbalance": ("node", "speeds", "unbalances"),
    "simulate": ("speed_rpm",),
    "lyapunov": ("speed_rpm",),
    "diagnose": ("channel", "rpm", "tacho", "fs", "prewhiten", "model", "workers"),
    "compare": ("channel", "var", "rpm", "fs", "max_order"),
    "record info": ("fs", "rpm", "tacho", "scale", "units"),
    "record save": ("channel", "fs", "rpm", "tacho", "scale", "units"),
    "calibrate": ("target", "prior", "executor", "workers", "scheduler"),
    "uncertainty": ("dist", "executor", "workers", "scheduler"),
    "sweep": ("executor", "workers", "scheduler"),
}
"""The fields the library's messages carry, by a command that reaches them: each must be
the python name of an option of that command, so the command line names the option."""


def test_each_field_is_an_option_of_the_commands_that_raise_it():
    import typer

    from analysis.cli import app

    group = typer.main.get_command(app)
    missing = []
    for path, fields in COMMAND_FIELDS.items():
        command = group
        for word in path.split():
            command = command.commands[word]
        options = {p.name for p in command.params if p.param_type_name == "option"}
        missing += [f"{path}: {f}" for f in fields if f not in options]
    assert not missing, f"fields that name no option of their command: {missing}"


def test_a_speed_table_given_as_rpm_names_rpm(tmp_path):
    """A record's speed table is read as simulate's is, and its errors name the parameter
    that gave it (``rpm``), not ``speed_rpm``."""
    import numpy as np

    from analysis.errors import InputError
    from analysis.measured.records import read_record

    record = tmp_path / "rec.csv"
    np.savetxt(record, np.sin(np.arange(64.0))[:, None], delimiter=",", header="DE",
               comments="")
    (tmp_path / "table.csv").mkdir()
    with pytest.raises(InputError, match=r"^rpm: the speed table '.*table\.csv' is a folder"
                       ) as err:
        read_record(record, fs=1000.0, rpm=str(tmp_path / "table.csv"))
    assert err.value.field == "rpm"
