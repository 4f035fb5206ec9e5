"""Variants of the shipped specs, generated into a scratch package and loaded like a model.

``variant(tmp_path, "vakharia2015-two-contact", name="x", terms=[...], parameters={...})``
copies the shipped spec, changes its terms and parameters, writes it as TOML, generates its
code with ``bearingdyn generate``'s function into ``tmp_path`` and returns the model
(``analysis.model.Model``) and its spec.
"""

from __future__ import annotations

import copy
import importlib
import sys
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from analysis.model import Model
from modelgen.codegen import generate
from modelgen.spec import Spec, load_spec
from tests.conftest import SPECS


def spec_data(base: str) -> dict[str, Any]:
    """The shipped spec ``base`` as TOML data."""
    return tomllib.loads((SPECS / f"{base}.toml").read_text())


def variant(tmp_path: Path, base: str, name: str, terms: list[dict] | None = None,
            parameters: dict[str, dict] | None = None,
            drop: tuple[str, ...] = ()) -> tuple[Model, Spec]:
    """Generate and load ``base`` with new ``terms``, added/replaced and dropped parameters."""
    data = copy.deepcopy(spec_data(base))
    data["model"]["name"] = name
    if terms is not None:
        data["terms"] = terms
    for key in drop:
        data["parameters"].pop(key)
    data["parameters"].update(parameters or {})
    path = tmp_path / f"{name}.toml"
    path.write_text(tomli_w.dumps(data))
    package = f"variants_{name.replace('-', '_')}"
    generate([path], root=tmp_path / package)
    if str(tmp_path) not in sys.path:
        sys.path.insert(0, str(tmp_path))
    module = importlib.import_module(f"{package}.{name.replace('-', '_')}")
    return Model(module), load_spec(path)[0]


def parameter(value: float, unit: str, source: str = "test") -> dict[str, Any]:
    return {"value": value, "unit": unit, "source": source}
