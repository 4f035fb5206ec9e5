"""Force expressions written as text in a spec, read safely into SymPy.

A custom term (``kind = "expression"``) gives its forces as strings such as
``"-k3*x**3"``. The string is parsed by Python's ``ast`` module, which only builds a syntax
tree and runs nothing, and the tree is then walked against a whitelist:

- numbers (int or float literals), the constant ``pi``;
- names the caller declares (state, ball symbols, parameters);
- ``+ - * / **``, unary ``-`` and ``+``, parentheses;
- calls of the functions in ``FUNCTIONS`` by their bare name, positional arguments only.

Everything else (attribute access, calls of anything else, subscripts, lambdas,
comprehensions, comparisons, strings, names starting with ``_`` …) is rejected with an
``ExpressionError`` that quotes the offending fragment. The text never reaches ``eval``,
``exec``, ``sympify`` or ``parse_expr``. Limits keep hostile input cheap: at most
``MAX_LENGTH`` characters, ``MAX_DEPTH`` levels of nesting, numeric exponents within
``MAX_EXPONENT``, and every number of the result a finite double.
"""

from __future__ import annotations

import ast
import difflib
import math
from collections.abc import Callable, Mapping

from modelgen.lazy import LazyTable
from modelgen.lazy import sympy as sp

MAX_LENGTH = 2000
"""Longest expression string, characters."""
MAX_DEPTH = 40
"""Deepest nesting of the syntax tree (operators, calls, parentheses)."""
MAX_EXPONENT = 100
"""Largest |exponent| of a power whose exponent is a number."""
MAX_ARGS = 16
"""Most arguments of Max and Min."""
_MAX_NUMBER_BITS = 4096
"""Largest number (in bits) that exact arithmetic on literals may build before it is
rejected; any result outside the double range is rejected anyway."""


def _heaviside(arg: sp.Expr) -> sp.Expr:
    """Unit step with H(0) = 0, as the CasADi code computes it (``x > 0``)."""
    return sp.Heaviside(arg, 0)


FUNCTIONS: Mapping[str, tuple[Callable[..., sp.Expr], int | None]] = LazyTable({
    "sin": lambda: (sp.sin, 1), "cos": lambda: (sp.cos, 1), "exp": lambda: (sp.exp, 1),
    "sqrt": lambda: (sp.sqrt, 1), "abs": lambda: (sp.Abs, 1),
    "Heaviside": lambda: (_heaviside, 1), "Max": lambda: (sp.Max, None),
    "Min": lambda: (sp.Min, None),
})
"""Allowed functions: name -> (SymPy function, number of arguments; None: 2…MAX_ARGS);
the names are known without SymPy (``modelgen.lazy``)."""
CONSTANTS: Mapping[str, sp.Expr] = LazyTable({"pi": lambda: sp.pi})
"""Named constants every expression may use."""

_OPERATORS: dict[type, Callable[[sp.Expr, sp.Expr], sp.Expr]] = {
    ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b, ast.Div: lambda a, b: a / b,
}
_FORBIDDEN_OPERATORS = {
    ast.BitXor: "'^' is not a power here; use '**'", ast.FloorDiv: "'//' is not allowed",
    ast.Mod: "'%' is not allowed", ast.MatMult: "'@' is not allowed",
    ast.LShift: "'<<' is not allowed", ast.RShift: "'>>' is not allowed",
    ast.BitOr: "'|' is not allowed", ast.BitAnd: "'&' is not allowed",
}
_FORBIDDEN_NODES = {
    ast.Attribute: "attribute access is not allowed",
    ast.Subscript: "subscripts are not allowed",
    ast.Lambda: "lambdas are not allowed",
    ast.ListComp: "comprehensions are not allowed", ast.SetComp: "comprehensions are not allowed",
    ast.DictComp: "comprehensions are not allowed",
    ast.GeneratorExp: "comprehensions are not allowed",
    ast.Compare: "comparisons are not allowed (use Heaviside, Max or Min)",
    ast.BoolOp: "'and'/'or' are not allowed", ast.IfExp: "'if … else' is not allowed",
    ast.NamedExpr: "assignments are not allowed", ast.Starred: "'*' unpacking is not allowed",
    ast.JoinedStr: "strings are not allowed", ast.Tuple: "tuples are not allowed",
    ast.List: "lists are not allowed", ast.Dict: "dicts are not allowed",
    ast.Set: "sets are not allowed", ast.Await: "'await' is not allowed",
    ast.Yield: "'yield' is not allowed", ast.YieldFrom: "'yield' is not allowed",
    ast.Slice: "slices are not allowed",
}
_CONSTANT_KINDS = {str: "strings", bytes: "strings", bool: "True/False", complex: "complex numbers",
                   type(None): "None", type(...): "'...'"}


class ExpressionError(ValueError):
    """An expression string is not a safe, well-formed force expression."""

    def __init__(self, reason: str, fragment: str = "", quote: bool = True):
        self.reason = reason
        self.fragment = fragment
        super().__init__(f"{reason}: '{_shorten(fragment)}'" if fragment and quote else reason)


def _shorten(text: str, limit: int = 60) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _fragment(text: str, node: ast.AST) -> str:
    return ast.get_source_segment(text, node) or type(node).__name__


def _syntax_tree(text: object) -> ast.Expression:
    if not isinstance(text, str):
        raise ExpressionError(f"must be a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"too long: {len(text)} characters, at most {MAX_LENGTH}",
                              text)
    if not text.strip():
        raise ExpressionError("empty expression")
    depth = 0
    for char in text:  # cheap guard before the parser sees deep nesting
        depth += (char in "([{") - (char in ")]}")
        if depth > MAX_DEPTH:
            raise ExpressionError(f"nested deeper than {MAX_DEPTH} levels", text)
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"not a valid expression ({exc.msg})", text) from None
    except (ValueError, RecursionError, MemoryError):  # null bytes, absurd nesting
        raise ExpressionError("not a valid expression", text) from None
    _check_depth(tree, text)
    return tree


def _check_depth(tree: ast.AST, text: str) -> None:
    stack = [(tree, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH + 1:  # + 1: the Expression root
            raise ExpressionError(f"nested deeper than {MAX_DEPTH} levels", text)
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))


def check_expression(text: object) -> frozenset[str]:
    """Check ``text`` against the whitelist without building anything; return the names it
    uses (besides functions and constants). Raises ``ExpressionError``."""
    tree = _syntax_tree(text)
    assert isinstance(text, str)
    names: set[str] = set()
    callees = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    for node in ast.walk(tree.body):
        _check_node(node, text)
        if isinstance(node, ast.Name) and node.id not in CONSTANTS and id(node) not in callees:
            names.add(node.id)
    return frozenset(names)


def _check_node(node: ast.AST, text: str) -> None:
    """Reject one node that is not on the whitelist (children are checked separately)."""
    if type(node) in _FORBIDDEN_NODES:
        raise ExpressionError(_FORBIDDEN_NODES[type(node)], _fragment(text, node))
    if isinstance(node, ast.Name):
        if node.id.startswith("_"):
            raise ExpressionError("names starting with '_' are not allowed", node.id)
    elif isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ExpressionError(f"{_CONSTANT_KINDS.get(type(value), 'constants')} are not "
                                  "allowed; only real numbers", _fragment(text, node))
    elif isinstance(node, ast.BinOp):
        if type(node.op) in _FORBIDDEN_OPERATORS:
            raise ExpressionError(_FORBIDDEN_OPERATORS[type(node.op)], _fragment(text, node))
    elif isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.USub, ast.UAdd)):
            raise ExpressionError("only unary '-' and '+' are allowed", _fragment(text, node))
    elif isinstance(node, ast.Call):
        _check_call(node, text)
    elif not isinstance(node, (ast.operator, ast.unaryop, ast.expr_context)):
        raise ExpressionError(f"{type(node).__name__} is not allowed", _fragment(text, node))


def _check_call(node: ast.Call, text: str) -> None:
    if type(node.func) in _FORBIDDEN_NODES:  # x.f(), (lambda: 0)(), f[0]()
        raise ExpressionError(_FORBIDDEN_NODES[type(node.func)], _fragment(text, node.func))
    if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
        called = _fragment(text, node.func)
        raise ExpressionError(f"calls to '{_shorten(called, 30)}' are not allowed; functions: "
                              f"{', '.join(FUNCTIONS)}", _fragment(text, node))
    if any(keyword.arg is None for keyword in node.keywords):
        raise ExpressionError("'**' unpacking is not allowed", _fragment(text, node))
    if node.keywords:
        raise ExpressionError("keyword arguments are not allowed", _fragment(text, node))
    for arg in node.args:  # the star, before a count of arguments it would make wrong
        if isinstance(arg, ast.Starred):
            raise ExpressionError(_FORBIDDEN_NODES[ast.Starred], _fragment(text, arg))
    _, arity = FUNCTIONS[node.func.id]
    n = len(node.args)
    if (arity is not None and n != arity) or (arity is None and not 2 <= n <= MAX_ARGS):
        wanted = f"{arity}" if arity is not None else f"2 to {MAX_ARGS}"
        raise ExpressionError(f"{node.func.id} takes {wanted} argument(s), got {n}",
                              _fragment(text, node))


def parse_expression(text: object, symbols: Mapping[str, sp.Expr]) -> sp.Expr:
    """The SymPy expression of ``text`` with its names replaced by ``symbols``.

    Raises ``ExpressionError`` for anything outside the whitelist, unknown names (with a
    suggestion), and results that are not finite real numbers (1/0, sqrt(-1), 1e999).
    """
    tree = _syntax_tree(text)
    assert isinstance(text, str)
    for node in ast.walk(tree.body):
        _check_node(node, text)
    expr = _Converter(text, symbols).convert(tree.body)
    return _finite_real(expr, text)


class _Converter:
    """Builds SymPy from an already whitelisted tree (recursion depth <= MAX_DEPTH)."""

    def __init__(self, text: str, symbols: Mapping[str, sp.Expr]):
        self.text = text
        self.symbols = symbols

    def convert(self, node: ast.AST) -> sp.Expr:
        try:
            result = self._build(node)
        except (ValueError, TypeError, ArithmeticError) as exc:  # SymPy refusing, e.g.
            if isinstance(exc, ExpressionError):  # Max of an infinity: "not comparable"
                raise
            raise ExpressionError("cannot be evaluated", _fragment(self.text, node)) from None
        if result.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            raise ExpressionError("division by zero or an infinite value",
                                  _fragment(self.text, node))
        return result

    def _build(self, node: ast.AST) -> sp.Expr:
        if isinstance(node, ast.Constant):
            return self._number(node)
        if isinstance(node, ast.Name):
            return self._name(node)
        if isinstance(node, ast.UnaryOp):
            operand = self.convert(node.operand)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            left, right = self.convert(node.left), self.convert(node.right)
            if isinstance(node.op, ast.Pow):
                return self._power(left, right, node)
            return _OPERATORS[type(node.op)](left, right)
        if isinstance(node, ast.Call):
            function, _ = FUNCTIONS[node.func.id]  # type: ignore[attr-defined]
            return function(*(self.convert(a) for a in node.args))
        raise ExpressionError(f"{type(node).__name__} is not allowed",  # pragma: no cover
                              _fragment(self.text, node))

    def _number(self, node: ast.Constant) -> sp.Expr:
        value = node.value
        if isinstance(value, int) and abs(value) <= 2**53:
            return sp.Integer(value)
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if not math.isfinite(number):
            raise ExpressionError("number outside the floating-point range",
                                  _fragment(self.text, node))
        return sp.Float(number)

    def _name(self, node: ast.Name) -> sp.Expr:
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in self.symbols:
            return self.symbols[node.id]
        close = difflib.get_close_matches(node.id, list(self.symbols), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ExpressionError(f"unknown name '{node.id}'{hint}; allowed names: "
                              f"{', '.join([*self.symbols, *CONSTANTS])}", node.id, quote=False)

    def _power(self, base: sp.Expr, exponent: sp.Expr, node: ast.BinOp) -> sp.Expr:
        if exponent.is_number:
            value = _as_float(exponent)
            if not abs(value) <= MAX_EXPONENT:
                raise ExpressionError(f"exponent out of range [-{MAX_EXPONENT}, "
                                      f"{MAX_EXPONENT}]", _fragment(self.text, node))
            if base.is_number and base != 0:
                bits = abs(value) * abs(math.log2(abs(_as_float(base)) or 1e-300))
                if bits > _MAX_NUMBER_BITS:
                    raise ExpressionError("number outside the floating-point range",
                                          _fragment(self.text, node))
        return base**exponent


def _finite_real(expr: sp.Expr, text: str) -> sp.Expr:
    """Reject infinities, NaN and complex values; make large exact numbers floats."""
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
        raise ExpressionError("division by zero or an infinite value", text)
    if expr.has(sp.I):
        raise ExpressionError("complex value (e.g. sqrt of a negative number)", text)
    for node in sp.preorder_traversal(expr):
        if isinstance(node, sp.Pow) and node.exp.is_number and \
                not abs(_as_float(node.exp)) <= MAX_EXPONENT:
            raise ExpressionError(f"exponent out of range [-{MAX_EXPONENT}, {MAX_EXPONENT}] "
                                  f"once the powers are combined ({node.exp})", text)
        if node.is_number and not isinstance(node, sp.Number) and \
                not math.isfinite(_as_float(node)):
            raise ExpressionError("number outside the floating-point range", text)
    replace = {}
    for number in expr.atoms(sp.Number):
        if not math.isfinite(_as_float(number)):
            raise ExpressionError("number outside the floating-point range", text)
        if isinstance(number, sp.Rational) and max(abs(number.p), number.q) > 2**53:
            replace[number] = sp.Float(float(number))
    return expr.xreplace(replace) if replace else expr


def _as_float(number: sp.Expr) -> float:
    """``float(number)``, or inf when it is not a real number in the double range."""
    try:
        if not number.is_real:
            return math.inf
        return float(number)
    except (OverflowError, TypeError, ValueError, RecursionError):  # mpmath overflows too
        return math.inf
