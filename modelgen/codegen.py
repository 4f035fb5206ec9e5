"""SymPy equations -> CasADi code: writes ``generated/<model>/`` deterministically.

For each spec it writes
  ``__init__.py``  the model's expressions as CasADi code (per-ball load, rotor force, mass,
                   shaft and cage speed, and the helpers of quantities solved by a fixed
                   iteration, ``modelgen/unrolled.py``) plus its parameter table;
                   ``build(n_balls)`` makes the CasADi Functions through
                   ``generated/_runtime.py``;
  ``<model>.c``    CasADi's C source of rhs, jac and rk4_step at the spec's default N_b;
  ``MODEL.md``     the model card: equations in LaTeX, parameters with units and sources.
Every header records the spec's SHA-256 and the bearingdyn/SymPy/CasADi versions; the same
spec and versions give byte-identical files.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import sys
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import ClassVar

import casadi
import sympy as sp
from sympy.printing.str import StrPrinter

import modelgen
from modelgen.assemble import Equations, assemble, latex_equations
from modelgen.spec import N_BALLS_RANGE, Spec, load_spec, spec_hash
from modelgen.symbols import Context
from modelgen.unrolled import helper_sources

RUNTIME_TEMPLATE = "runtime.py.tmpl"
PACKAGE_DOC = (
    '"""Generated rotor-bearing models: output of bearingdyn modelgen, never edited by hand.'
    "\n\nRegenerate with `bearingdyn generate`; check with `bearingdyn generate --check`."
    '\n"""\n'
)


class CasadiPrinter(StrPrinter):
    """Prints SymPy expressions as Python code over ``ca`` (CasADi) and ``math``."""

    _functions: ClassVar[dict[str, str]] = {
        "sin": "ca.sin", "cos": "ca.cos", "exp": "ca.exp", "tan": "ca.tan",
        "Abs": "ca.fabs", "log": "ca.log", "tanh": "ca.tanh",
    }

    def _print_Function(self, expr: sp.Function) -> str:
        name = type(expr).__name__
        if name not in self._functions:
            raise NotImplementedError(f"no CasADi form for function {name}")
        return f"{self._functions[name]}({', '.join(self._print(a) for a in expr.args)})"

    def _minmax(self, expr: sp.Expr, fn: str) -> str:
        args = [self._print(a) for a in expr.args]
        out = args[0]
        for a in args[1:]:
            out = f"{fn}({out}, {a})"
        return out

    def _print_Max(self, expr: sp.Max) -> str:
        return self._minmax(expr, "ca.fmax")

    def _print_Min(self, expr: sp.Min) -> str:
        return self._minmax(expr, "ca.fmin")

    def _print_Heaviside(self, expr: sp.Heaviside) -> str:
        return f"ca.if_else({self._print(expr.args[0])} > 0, 1, 0)"

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        base, exp = expr.args
        if exp == sp.Rational(3, 2) and isinstance(base, sp.Max) and 0 in base.args:
            other = [a for a in base.args if a != 0]
            return f"hertz15({self._print(sp.Max(*other))})"
        if exp == sp.Rational(1, 2):
            return f"ca.sqrt({self._print(base)})"
        if exp == -sp.Rational(1, 2):
            return f"1 / ca.sqrt({self._print(base)})"
        if exp == -1:
            return f"1 / ({self._print(base)})"
        return super()._print_Pow(expr, rational)

    def _print_Exp1(self, expr: sp.Expr) -> str:
        return "math.e"

    def _print_Pi(self, expr: sp.Expr) -> str:
        return "math.pi"

    def _print_Float(self, expr: sp.Float) -> str:
        return repr(float(expr))

    def _print_Rational(self, expr: sp.Rational) -> str:
        return f"({expr.p}/{expr.q})"


def _function_source(name: str, args: str, doc: str, exprs: list[sp.Expr],
                     ctx: Context, returns_tuple: bool) -> str:
    """A Python function computing ``exprs`` with shared subexpressions (CSE)."""
    printer = CasadiPrinter()
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("w"), order="canonical")
    used = set().union(*(e.free_symbols for e in [*reduced, *(r for _, r in replacements)]))
    lines = [f"def {name}({args}):", f'    """{doc}"""']
    for index, (pname, sym) in enumerate(ctx.params.items()):
        if sym in used:
            lines.append(f"    {pname} = p[{index}]")
    for sym, rhs in replacements:
        lines.append(f"    {sym} = {printer.doprint(rhs)}")
    body = [printer.doprint(e) for e in reduced]
    ret = ", ".join(body) if returns_tuple else body[0]
    lines.append(f"    return {ret}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class GeneratedFiles:
    """Texts of the files of one generated model, keyed by path relative to the root."""

    files: dict[str, str]


def versions() -> dict[str, str]:
    return {"bearingdyn": modelgen.__version__, "sympy": sp.__version__,
            "casadi": casadi.__version__}


def _header_lines(spec: Spec, digest: str, spec_file: str) -> list[str]:
    v = versions()
    return [
        f"Generated by bearingdyn modelgen from modelgen/specs/{spec_file}; do not edit.",
        f"Regenerate: bearingdyn generate {spec.model.name}",
        f"spec sha256: {digest}",
        f"generator: bearingdyn {v['bearingdyn']}, sympy {v['sympy']}, casadi {v['casadi']}",
    ]


def module_source(spec: Spec, eq: Equations, digest: str, spec_file: str) -> str:
    ctx = eq.ctx
    state_args = "x, y, vx, vy, t, p"
    functions = [
        *helper_sources([eq.ball_load, *eq.rotor_force]),
        _function_source(
            "ball_load", f"c, s, {state_args}",
            "Radial load of one ball at (cos θ, sin θ) = (c, s) on the rotor, N.",
            [eq.ball_load], ctx, False),
        _function_source(
            "rotor_force", state_args,
            "Force of the loads and damping on the rotor, (F_x, F_y) in N.",
            list(eq.rotor_force), ctx, True),
        _function_source("rotor_mass", "p", "Rotor mass M_R, kg.", [eq.mass], ctx, False),
        _function_source("shaft_speed", "p", "Shaft angular speed ω, rad/s.",
                         [eq.shaft_speed], ctx, False),
        _function_source("cage_speed", "p", "Cage angular speed ω_cage, rad/s.",
                         [eq.cage_speed], ctx, False),
        "def build(n_balls: int = DEFAULT_N_BALLS) -> ModelFunctions:\n"
        '    """CasADi Functions (rhs, jac, rk4_step, simulator) for n_balls balls."""\n'
        "    return ModelFunctions(sys.modules[__name__], n_balls)\n",
    ]
    code = "\n\n".join(functions)
    imports = ["import math\n" if "math." in code else "", "import sys\n\n",
               "import casadi as ca\n\n" if "ca." in code else "",
               "from .._runtime import ModelFunctions"
               + (", hertz15\n" if "hertz15(" in code else "\n")]
    params = "".join(f"    ({name!r}, {par.value!r}, {par.unit!r}, {par.source!r}),\n"
                     for name, par in spec.parameters.items())
    ranges = "".join(
        f"    {name!r}: ({q.low!r}, {q.high!r}, {q.low_inclusive!r}),\n"
        for name, q in ((n, spec.quantity(n)) for n in spec.parameters))
    terms = "".join(f"    {t.describe()!r},\n" for t in spec.terms)
    constants = [
        f"NAME = {spec.model.name!r}",
        f"TITLE = {spec.model.title!r}",
        f"REFERENCE = {spec.model.reference!r}",
        f"SPEC_FILE = {spec_file!r}",
        f"SPEC_SHA256 = {digest!r}",
        f"GENERATOR = {versions()!r}",
        f"DEFAULT_N_BALLS = {spec.n_balls}",
        f"N_BALLS_RANGE = {N_BALLS_RANGE if spec.n_balls else (0, 0)!r}",
        f"SIMULATION = {spec.simulation.model_dump()!r}",
        f"TERMS = (\n{terms})",
        f"PARAMETERS = (\n    # name, default value, unit, source\n{params})",
        f"RANGES = {{\n    # name: (low, high, low inclusive); high is inclusive\n{ranges}}}",
    ]
    header = "\n".join(_header_lines(spec, digest, spec_file))
    return (f'"""{spec.model.title}\n\n{header}\n"""\n\n' + "".join(imports) + "\n"
            + "\n".join(constants) + "\n\n\n" + "\n\n".join(functions))


def c_source(spec: Spec, module_text: str, digest: str, spec_file: str) -> str:
    """CasADi's C code of rhs, jac and rk4_step at the default number of balls."""
    with _preview_module(spec.model.module, module_text) as module:
        funcs = module.build(spec.n_balls)
    with tempfile.TemporaryDirectory() as tmp:
        gen = casadi.CodeGenerator(f"{spec.model.module}.c", {"with_header": False})
        for f in (funcs.rhs, funcs.jac, funcs.rk4_step):
            gen.add(f)
        gen.generate(tmp + "/")
        body = (Path(tmp) / f"{spec.model.module}.c").read_text()
    header = "\n".join(f" * {line}" for line in _header_lines(spec, digest, spec_file))
    return (f"/*\n * {spec.model.title}\n * C source of rhs, jac, rk4_step for n_balls = "
            f"{spec.n_balls}\n{header}\n */\n{body}")


@contextlib.contextmanager
def _preview_module(module: str, text: str):
    """Import generated module text in a scratch package, without touching ``generated/``."""
    with tempfile.TemporaryDirectory() as tmp:
        pkg = Path(tmp) / "generated_preview"
        (pkg / module).mkdir(parents=True)
        (pkg / "__init__.py").write_text("")
        (pkg / "_runtime.py").write_text(runtime_source())
        (pkg / module / "__init__.py").write_text(text)
        name = f"_bearingdyn_preview_{module}"
        spec = importlib.util.spec_from_file_location(
            name, pkg / "__init__.py", submodule_search_locations=[str(pkg)])
        pkg_mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = pkg_mod
        spec.loader.exec_module(pkg_mod)
        try:
            yield importlib.import_module(f"{name}.{module}")
        finally:
            for key in [k for k in sys.modules if k.startswith(name)]:
                del sys.modules[key]


def model_card(spec: Spec, digest: str, spec_file: str) -> str:
    eqs = latex_equations(spec)
    header = "\n".join(f"- {line}" for line in _header_lines(spec, digest, spec_file))
    rows = "\n".join(
        f"| `{n}` | ${spec.quantity(n).latex}$ | {p.value:g} | {p.unit} | {p.source} |"
        for n, p in spec.parameters.items()
    )
    terms = "\n".join(f"{i + 1}. `{t.kind}`: {t.describe()}" for i, t in enumerate(spec.terms))
    equations = "\n\n".join(f"$$\n{e}\n$$" for e in eqs)
    sim = ", ".join(f"{k} = {v:g}" for k, v in spec.simulation.model_dump().items())
    balls = (f"Default number of balls $N_b = {spec.n_balls}$ (structural; any $N_b$ in "
             f"{N_BALLS_RANGE[0]}…{N_BALLS_RANGE[1]} is built at run time from the same code)."
             if spec.n_balls else "No balls: the rotor is held by the terms below only.")
    return f"""# {spec.model.name}: {spec.model.title}

{header}

Reference: {spec.model.reference}

{spec.model.description}

## Equations of motion

State $[x, y, \\dot x, \\dot y]$: rotor centre displacement (m) and velocity (m/s); $x$ along the
radial load. {balls}

{equations}

## Terms

{terms}

## Parameters

| name | symbol | default | unit | source |
|---|---|---|---|---|
{rows}

Simulation defaults: {sim} (SI units).

## Files

- `__init__.py`: the expressions above as CasADi code; `build(n_balls)` returns the
  CasADi Functions `rhs`, `jac`, `rk4_step` and `simulator`.
- `{spec.model.module}.c`: CasADi's C source of `rhs`, `jac`, `rk4_step`
  ($N_b = {spec.n_balls}$).

To cite this model, give its name, the spec sha256 above and the bearingdyn version.
"""


def runtime_source() -> str:
    return (resources.files("modelgen") / "templates" / RUNTIME_TEMPLATE).read_text()


def render(name_or_path: str | Path) -> GeneratedFiles:
    """All files of one model as text, keyed by path relative to the generated root."""
    spec, path = load_spec(name_or_path)
    digest = spec_hash(path)
    eq = assemble(spec)
    module = spec.model.module
    text = module_source(spec, eq, digest, path.name)
    return GeneratedFiles({
        f"{module}/__init__.py": text,
        f"{module}/{module}.c": c_source(spec, text, digest, path.name),
        f"{module}/MODEL.md": model_card(spec, digest, path.name),
    })


def package_files() -> dict[str, str]:
    return {"__init__.py": PACKAGE_DOC, "_runtime.py": runtime_source()}


def default_root() -> Path:
    """The ``generated/`` package folder next to ``modelgen/``."""
    return Path(modelgen.__file__).resolve().parent.parent / "generated"


def generate(names: list[str | Path], root: Path | None = None,
             check: bool = False) -> list[str]:
    """Write (or, with ``check``, compare) the generated files of the given specs.

    Returns the relative paths that differ from what is on disk (with ``check``) or that
    were written.
    """
    root = root or default_root()
    wanted = dict(package_files())
    for name in names:
        wanted.update(render(name).files)
    changed = []
    for rel, text in wanted.items():
        target = root / rel
        current = target.read_text() if target.exists() else None
        if current != text:
            changed.append(rel)
            if not check:
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_text(text)
    return changed
