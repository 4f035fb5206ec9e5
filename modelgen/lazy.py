"""SymPy on first use: what validates a spec (``modelgen.spec`` and the term classes) never
needs SymPy, so a spec that fails validation fails before SymPy is imported (about 0.3 s;
issue 32: a bad spec fails in about the time a bad option does). Standard library only.

``from modelgen.lazy import sympy as sp`` stands for ``import sympy as sp``: the first
attribute read (``sp.Symbol``) imports SymPy, after which every read is a plain attribute
lookup. ``LazyTable`` is a mapping whose values (SymPy objects) are made on first read.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from typing import Any


class LazyModule:
    """A module imported on its first attribute read."""

    def __init__(self, name: str) -> None:
        self.__dict__["__lazy_name__"] = name

    def __getattr__(self, attr: str) -> Any:
        module = importlib.import_module(self.__dict__["__lazy_name__"])
        self.__dict__.update(vars(module))  # later reads: no __getattr__
        return getattr(module, attr)

    def __repr__(self) -> str:
        return f"<lazy module {self.__dict__['__lazy_name__']!r}>"


sympy: Any = LazyModule("sympy")
"""SymPy, imported on first use."""


class LazyTable(Mapping):
    """A mapping with fixed keys whose values are made by ``makers[key]()`` on first read
    (the keys, e.g. the names allowed in an expression, are known without SymPy)."""

    def __init__(self, makers: Mapping[str, Callable[[], Any]]) -> None:
        self._makers = dict(makers)
        self._values: dict[str, Any] = {}

    def __getitem__(self, key: str) -> Any:
        if key not in self._values:
            self._values[key] = self._makers[key]()
        return self._values[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._makers)

    def __len__(self) -> int:
        return len(self._makers)

    def __contains__(self, key: object) -> bool:
        return key in self._makers
