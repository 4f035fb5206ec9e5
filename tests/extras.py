"""Tests that need an optional extra (``[docs]``, ``[ross]``): they carry the ``needs_extra``
marker and skip with the install line when the extra is missing, so that the README's test
command (which installs ``[test]`` only) passes on a fresh machine. ``.ci/run`` then runs
them in a second environment with the extras installed and ``BEARINGDYN_REQUIRE_EXTRAS=1``,
where such a skip is a failure (tests/conftest.py)."""

from __future__ import annotations

import importlib.util
import os
from types import ModuleType

import pytest

REQUIRE = "BEARINGDYN_REQUIRE_EXTRAS"
"""Environment variable: when ``1``, a ``needs_extra`` test that skips fails instead."""


def install_line(extra: str) -> str:
    return f"python3 -m pip install -e '.[{extra}]'"


def extras_required() -> bool:
    return os.environ.get(REQUIRE, "") == "1"


def missing(modules: tuple[str, ...]) -> str | None:
    """The first of ``modules`` that cannot be imported, or None."""
    for module in modules:
        try:
            if importlib.util.find_spec(module) is None:
                return module
        except ModuleNotFoundError:
            return module
    return None


def require(module: str, extra: str) -> ModuleType:
    """Import ``module``, or skip naming the extra's install line."""
    return pytest.importorskip(module, reason=f"{module} is not installed: {install_line(extra)}")


def require_all(modules: tuple[str, ...], extra: str) -> None:
    """Skip naming the extra's install line unless every one of ``modules`` imports."""
    absent = missing(modules)
    if absent:
        pytest.skip(f"{absent} is not installed: {install_line(extra)}")
