"""Counting calls in tests: how many times each check of a command or a plan ran.

``count_calls`` replaces a function where the code under test finds it (the attribute of
each module or class named, by the function's own name) with a wrapper that adds one to a
``Counter`` at each call and calls the original; ``monkeypatch`` puts every original back
after the test. ``count_judged`` does it for the device's judgement (``placement.judge``),
which every study plan makes once. ``invoke`` runs a command in this process (typer's
runner), where those wrappers see its calls."""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Callable
from typing import Any

import pytest

Key = str | Callable[..., str]
"""The key a call adds one to: a name, or a function of the call's arguments giving it."""


def counting(calls: Counter, key: Key, fn: Callable) -> Callable:
    """``fn``, adding one to ``calls[key]`` before each call (``calls[key(*args,
    **kwargs)]`` where ``key`` is a function: a key that depends on the arguments)."""
    @functools.wraps(fn)
    def call(*args, **kwargs):
        calls[key(*args, **kwargs) if callable(key) else key] += 1
        return fn(*args, **kwargs)
    return call


def count_calls(monkeypatch: pytest.MonkeyPatch, calls: Counter, key: Key, fn: Callable,
                *owners: Any, name: str | None = None) -> Callable:
    """Replace the attribute ``name`` (default: ``fn.__name__``) of each of ``owners``
    (modules that import ``fn`` by name, its class for a method) with one wrapper of ``fn``
    that counts its calls in ``calls`` under ``key`` (``counting``), for the test; the
    wrapper is returned."""
    wrapped = counting(calls, key, fn)
    for owner in owners:
        monkeypatch.setattr(owner, name or fn.__name__, wrapped)
    return wrapped


def by_device(device: str, *args: Any, **kwargs: Any) -> str:
    """The key ``"judge <device>"`` of a call of ``placement.judge``: counted by the
    device named."""
    return f"judge {device}"


def count_judged(monkeypatch: pytest.MonkeyPatch, calls: Counter,
                 key: Key = "judge") -> Counter:
    """Count the device's judgements (``placement.judge``: every judgement goes through its
    module attribute) in ``calls`` under ``key`` (``by_device``: one count per device
    named); ``calls`` is returned."""
    from analysis.integrate.kernels import placement

    count_calls(monkeypatch, calls, key, placement.judge, placement)
    return calls


def invoke(*args: str):
    """``bearingdyn ARGS`` run in this process (typer's ``CliRunner``), so the counting
    wrappers see its calls; its ``Result`` (``exit_code``, ``output``, ``stdout``,
    ``stderr``)."""
    from typer.testing import CliRunner

    from analysis.cli import app

    return CliRunner().invoke(app, list(args))
