"""Functions defined by an equation that the generated code solves by a fixed iteration.

Some quantities of a model have no closed form: the ellipticity of a Hertz contact (a
transcendental equation in complete elliptic integrals) or the inner-race load of a ball
squeezed between two races with a centrifugal force (a scalar nonlinear equation). They stay
runtime quantities, differentiable by CasADi, when the solver is a *fixed number of
iterations from a good start*: straight-line code with no loop and no branch on the data.

An ``Unrolled`` subclass is a SymPy function with three faces:

- in equations and LaTeX (model cards) it is one compact symbol, e.g. ``K_i(D_b, D_m, …)``;
- in generated code it is a call of a helper function (``code_name``) whose straight-line
  CasADi source ``helper_source()`` writes by tracing the algorithm (``TRACE`` backend);
- ``lambdify`` evaluates it with NumPy through the same algorithm (``_imp_``).

The algorithm is written once, against an ``Ops`` backend. (An explicit SymPy expression of
the iteration is not an option: every Newton step repeats the previous iterate several times,
and SymPy compares and traverses such trees in exponential time.)
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

from modelgen.lazy import sympy as sp


@dataclass(frozen=True)
class Ops:
    """The operations an unrolled algorithm may use, for one backend."""

    sqrt: Callable[[Any], Any]
    log: Callable[[Any], Any]
    power: Callable[[Any, Any], Any]
    """power(x, y) = x**y for x > 0."""
    minimum: Callable[[Any, Any], Any]
    hertz15: Callable[[Any], Any]
    """max(0, u)^{3/2} (``hertz15`` of the runtime: finite derivatives at u = 0)."""
    if_positive: Callable[[Any, Any, Any], Any]
    """if_positive(u, a, b) = a where u > 0, else b; the other branch is discarded (may be
    NaN there), its derivative too."""
    rational: Callable[[int, int], Any]
    """rational(p, q) = p/q."""
    pi: Any


def _np() -> Any:
    """NumPy, imported on first use: reading a spec (which imports this module through the
    term classes) must not pay for it."""
    import numpy

    return numpy


def _numpy_if_positive(u: Any, then: Any, otherwise: Any) -> Any:
    np = _np()
    return np.where(np.asarray(u) > 0, then, otherwise)


NUMPY = Ops(
    sqrt=lambda x: _np().sqrt(x), log=lambda x: _np().log(x),
    power=lambda x, y: _np().power(x, y), minimum=lambda x, y: _np().minimum(x, y),
    hertz15=lambda u: _np().maximum(u, 0.0) ** 1.5, if_positive=_numpy_if_positive,
    rational=lambda p, q: p / q, pi=math.pi,
)
"""Evaluate an algorithm on floats or NumPy arrays (NumPy's functions, called through a
first-use import; ``pi`` is ``math.pi``, the same double as ``numpy.pi``)."""


def numpy_call(algorithm: Callable[..., Any], *args: Any) -> Any:
    """``algorithm`` on NumPy values; the discarded side of ``if_positive`` may divide 0 by 0
    where it is not used, which is not worth a warning."""
    with _np().errstate(invalid="ignore", divide="ignore"):
        return algorithm(*args, NUMPY)


class _Trace:
    """Records the operations of one run of an algorithm as lines of CasADi code."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def emit(self, text: str) -> Traced:
        name = f"v{len(self.lines)}"
        self.lines.append(f"    {name} = {text}")
        return Traced(self, name)


class Traced:
    """A value of a traced algorithm: the name of the line that computed it."""

    __slots__ = ("name", "trace")

    def __init__(self, trace: _Trace, name: str) -> None:
        self.trace, self.name = trace, name

    def _op(self, op: str, other: Any, reverse: bool = False) -> Traced:
        if (op, other) in (("*", 1), ("+", 0)) or (op, other, reverse) in (
                ("-", 0, False), ("/", 1, False), ("**", 1, False)):
            return self  # x*1, x+0, x-0, x/1, x**1: no line
        left, right = (_text(other), self.name) if reverse else (self.name, _text(other))
        return self.trace.emit(f"{left} {op} {right}")

    def __add__(self, other: Any) -> Traced:
        return self._op("+", other)

    def __radd__(self, other: Any) -> Traced:
        return self._op("+", other, reverse=True)

    def __sub__(self, other: Any) -> Traced:
        return self._op("-", other)

    def __rsub__(self, other: Any) -> Traced:
        return self._op("-", other, reverse=True)

    def __mul__(self, other: Any) -> Traced:
        return self._op("*", other)

    def __rmul__(self, other: Any) -> Traced:
        return self._op("*", other, reverse=True)

    def __truediv__(self, other: Any) -> Traced:
        return self._op("/", other)

    def __rtruediv__(self, other: Any) -> Traced:
        return self._op("/", other, reverse=True)

    def __pow__(self, other: Any) -> Traced:
        return self._op("**", other)

    def __neg__(self) -> Traced:
        return self.trace.emit(f"-{self.name}")


def _text(value: Any) -> str:
    """Source text of an operand: a traced name or a number literal in parentheses."""
    if isinstance(value, Traced):
        return value.name
    if isinstance(value, int | float):
        return f"({value!r})"
    raise TypeError(f"cannot trace operand {value!r}")


def _call(function: str, *args: Any) -> Traced:
    trace = next(a.trace for a in args if isinstance(a, Traced))
    return trace.emit(f"{function}({', '.join(_text(a) for a in args)})")


TRACE = Ops(
    sqrt=lambda x: _call("ca.sqrt", x), log=lambda x: _call("ca.log", x),
    power=lambda x, y: x ** y,
    minimum=lambda a, b: _call("ca.fmin", a, b), hertz15=lambda u: _call("hertz15", u),
    if_positive=lambda u, a, b: u.trace.emit(
        f"ca.if_else({u.name} > 0, {_text(a)}, {_text(b)})"),
    rational=lambda p, q: p / q, pi=None,
)
"""Write an algorithm as straight-line CasADi code (``pi`` is bound per trace)."""


@functools.cache
def unrolled_base() -> type:
    """The class ``Unrolled`` (made on first use: a SymPy ``Function`` subclass needs SymPy,
    and validating a spec does not; ``modelgen.lazy``)."""

    class Unrolled(sp.Function):
        """A SymPy function computed by ``algorithm(*args, ops)``; compact in equations.

        Subclasses set ``nargs``, ``code_name`` (the helper function of the generated code),
        ``arg_names``, ``doc`` and ``algorithm`` (a staticmethod taking the arguments and an
        ``Ops``), and may override ``latex_name``.
        """

        code_name: ClassVar[str]
        arg_names: ClassVar[tuple[str, ...]]
        doc: ClassVar[str]
        algorithm: ClassVar[Callable[..., Any]]

        def __init_subclass__(cls, **kwargs: Any) -> None:
            super().__init_subclass__(**kwargs)
            if "algorithm" in cls.__dict__:
                algorithm = cls.__dict__["algorithm"].__func__
                # lambdify evaluates the function by calling _imp_ on NumPy values
                cls._imp_ = staticmethod(lambda *args: numpy_call(algorithm, *args))

        def latex_name(self) -> str:
            return self.code_name

        def latex_args(self, printer: Any) -> str:
            return ", ".join(printer._print(a) for a in self.args)

        def _latex(self, printer: Any, exp: str | None = None) -> str:
            text = rf"{self.latex_name()}\left({self.latex_args(printer)}\right)"
            return rf"\left({text}\right)^{{{exp}}}" if exp else text

        def _sympystr(self, printer: Any) -> str:
            """A call of the helper: what the CasADi printer (a ``StrPrinter``) writes."""
            return f"{self.code_name}({', '.join(printer._print(a) for a in self.args)})"

        def _eval_evalf(self, prec: int) -> sp.Expr | None:
            if not all(a.is_number for a in self.args):
                return None
            return sp.Float(float(type(self)._imp_(*(float(a) for a in self.args))), 15)

        @classmethod
        def helper_source(cls) -> str:
            """Python source of the helper: the algorithm traced as straight-line CasADi code."""
            trace = _Trace()
            args = [Traced(trace, name) for name in cls.arg_names]
            ops = Ops(**{**TRACE.__dict__, "pi": Traced(trace, "math.pi")})
            result = _text(cls.algorithm(*args, ops))
            lines = [f"def {cls.code_name}({', '.join(cls.arg_names)}):", f'    """{cls.doc}"""',
                     *_live(trace.lines, result), f"    return {result}"]
            return "\n".join(lines) + "\n"

    Unrolled.__module__, Unrolled.__qualname__ = __name__, "Unrolled"
    return Unrolled


def __getattr__(name: str) -> Any:
    """``Unrolled``, made on first use (``unrolled_base``)."""
    if name == "Unrolled":
        return unrolled_base()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _live(lines: list[str], result: str) -> list[str]:
    """The lines the result depends on (a last iteration computes some values it drops)."""
    needed, kept = set(_NAME.findall(result)), []
    for line in reversed(lines):
        name, _, text = line.strip().partition(" = ")
        if name in needed:
            kept.append(line)
            needed.update(_NAME.findall(text))
    return kept[::-1]


_NAME = re.compile(r"\bv\d+\b")


def helper_sources(exprs: Iterable[sp.Basic]) -> list[str]:
    """Sources of the helpers the expressions call, each once, in a fixed order."""
    classes = {type(f) for e in exprs for f in sp.sympify(e).atoms(unrolled_base())}
    return [cls.helper_source() for cls in sorted(classes, key=lambda c: c.code_name)]
