"""A spec of your own judged while the command line is read, before any command imports its
numerical libraries (xarray, CasADi, the integrators): a spec that fails validation then fails
in about the time a bad option does (issue 32: 5–11 s against 2–3 s before).

Only what will be generated is judged here: a spec whose code is already in the cache passed
validation when it was generated, so it costs nothing more (this module imports neither SymPy
nor pydantic until a spec needs judging).
"""

from __future__ import annotations

from pathlib import Path

MAX_EARLY_BYTES = 1_000_000
"""Larger files are left to the command (``load_spec`` refuses them with their size)."""


def needs_judging(model: str) -> Path | None:
    """The spec file behind the MODEL argument ``model`` when it is a ``.toml`` file of your
    own whose generated code is not cached yet; None otherwise (a shipped name, a folder, a
    missing file, a cached spec: the command handles those as before)."""
    from modelgen.locations import cached_model_root, is_shipped, manifest_problem

    path = Path(model).expanduser()
    if not model.endswith(".toml") or is_shipped(path):
        return None
    try:
        if not path.is_file() or path.stat().st_size > MAX_EARLY_BYTES:
            return None
        root = cached_model_root(path)
    except OSError:
        return None
    if root.is_dir() and manifest_problem(root) is None:
        return None
    return path


def judge_spec_early(model: str) -> str:
    """Validate the spec behind ``model`` now if it will be generated (``needs_judging``);
    raises ``SpecError`` (its one line lists every problem). Returns ``model`` unchanged."""
    path = needs_judging(model)
    if path is not None:
        from modelgen.spec import load_spec

        load_spec(path)
    return model
