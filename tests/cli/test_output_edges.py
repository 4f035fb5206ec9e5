"""Standard output's edges: strict JSON (no bare NaN) and a reader that goes away."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from analysis.cli.common import NULL_NOTE, echo_json
from tests.conftest import ROOT


def _strict(text: str):
    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_json_output_is_strict_with_nan_as_null_and_a_note(capsys):
    echo_json({"a": float("nan"), "b": [1.0, np.float64("inf"), np.array([2.0, np.nan])],
               "c": {"d": np.float32(-np.inf), "e": 3}})
    data = _strict(capsys.readouterr().out)
    assert data["a"] is None and data["b"] == [1.0, None, [2.0, None]]
    assert data["c"] == {"d": None, "e": 3}
    assert data["notes"] == [NULL_NOTE]


def test_json_without_nan_is_unchanged_and_has_no_note(capsys):
    payload = {"x": [1.5, 2], "name": "run", "nested": {"y": np.float64(0.25)}}
    echo_json(payload)
    assert _strict(capsys.readouterr().out) == {"x": [1.5, 2], "name": "run",
                                                "nested": {"y": 0.25}}


@pytest.mark.parametrize("args", [("devices", "--json"), ("models",)])
def test_a_closed_pipe_ends_quietly(args):
    """`bearingdyn … | head -0`: the reader closes before the command writes; it ends with
    exit code 0 and says nothing (it said `cannot use: Broken pipe`, exit 1)."""
    proc = subprocess.Popen([sys.executable, "-m", "analysis.cli", *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 0
    assert err == ""
