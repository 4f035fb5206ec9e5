"""SymPy equations -> CasADi code: writes ``generated/<model>/`` deterministically.

For each spec it writes
  ``__init__.py``  the model's expressions as CasADi code (generalised forces besides the
                   balls, masses, shaft speed; per bearing the load of one ball, the cage
                   speed and the station map; the helpers of quantities solved by a fixed
                   iteration, ``modelgen/unrolled.py``) plus its state, bodies, bearings and
                   parameter tables; ``build(n_balls)`` makes the CasADi Functions through
                   ``_runtime.py``;
  ``<model>.c``    CasADi's C source of rhs, jac and rk4_step at the spec's default N_b;
  ``MODEL.md``     the model card: equations in LaTeX, parameters with units and sources.
Every header records the spec's path and SHA-256 and the bearingdyn/SymPy/CasADi versions;
the same spec and versions give byte-identical files. Shipped specs are written into the
package's ``generated/``; any other spec into a folder of the caller's (``--out``) or the
user cache (``analysis.model``), never into the package.
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
from modelgen.locations import cached_model_root, is_shipped, manifest_problem
from modelgen.spec import Spec, load_spec, n_balls_range, spec_hash
from modelgen.symbols import Context
from modelgen.terms.base import ROLE_NAMES
from modelgen.tree import write_atomic, write_root, write_text
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
        "Abs": "ca.fabs", "log": "ca.log", "tanh": "ca.tanh", "atan2": "ca.atan2",
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
    for index, (sname, sym) in enumerate(ctx.named.items()):
        if sym in used:
            lines.append(f"    {sname} = z[{index}]")
    for index, (pname, sym) in enumerate(ctx.params.items()):
        if sym in used:
            lines.append(f"    {pname} = p[{index}]")
    for sym, rhs in replacements:
        lines.append(f"    {sym} = {printer.doprint(rhs)}")
    body = [printer.doprint(e) for e in reduced]
    ret = (", ".join(body) + ("," if len(body) == 1 else "")) if returns_tuple else body[0]
    lines.append(f"    return {ret}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class GeneratedFiles:
    """Texts of the files of one generated model, keyed by path relative to the root."""

    files: dict[str, str]


def versions() -> dict[str, str]:
    return {"bearingdyn": modelgen.__version__, "sympy": sp.__version__,
            "casadi": casadi.__version__}


@dataclass(frozen=True)
class Provenance:
    """Where a generated model comes from: the spec's path as cited (shipped specs:
    ``modelgen/specs/NAME.toml``; others: the absolute path), its SHA-256 and the command that
    regenerates it."""

    spec_file: str
    digest: str
    regenerate: str

    def lines(self) -> list[str]:
        v = versions()
        return [
            f"Generated by bearingdyn modelgen from {self.spec_file}; do not edit.",
            f"Regenerate: {self.regenerate}",
            f"spec sha256: {self.digest}",
            f"generator: bearingdyn {v['bearingdyn']}, sympy {v['sympy']}, casadi {v['casadi']}",
        ]


def _tuple(comment: str, items: list[str]) -> str:
    """A tuple literal, one item a line, under a comment line."""
    return f"(\n    # {comment}\n" + "".join(f"    {item},\n" for item in items) + ")"


def parameter_roles(spec: Spec, ctx: Context) -> dict[str, tuple[str, ...]]:
    """Role (``ROLE_NAMES``) -> the parameters that play it, from what the terms read: the
    contact term of each bearing its clearance, ball diameter and Hertz constant, the load
    terms their loads, an expression its forcing period, a shaft's ``unbalance_scale`` (the
    factor on its ``[[shaft.unbalances]]``) the unbalance; in the order of the bodies and
    bearings, each parameter once (a role no term plays: an empty tuple)."""
    owners = spec.owner_names()
    found: dict[str, list[tuple[int, str]]] = {role: [] for role in ROLE_NAMES}
    for term in spec.terms:
        scope = next(iter(spec.attachment(term).values()), "")
        seen = term.bound(ctx.scoped(scope))
        for role, quantity in term.role_quantities().items():
            if seen.has(quantity):
                order = owners.index(scope) if scope in owners else len(owners)
                found[role].append((order, seen.parameter_name(quantity)))
    if spec.shaft is not None and spec.shaft.unbalances and "unbalance_scale" in spec.parameters:
        found["unbalance_force"].append((-1, "unbalance_scale"))  # the shaft's, before terms'
    return {role: tuple(dict.fromkeys(name for _, name in sorted(pairs, key=lambda p: p[0])))
            for role, pairs in found.items()}


def module_source(spec: Spec, eq: Equations, prov: Provenance) -> str:
    ctx = eq.ctx
    loads = {b.name: eq.ball_load_of(b) for b in eq.bearings}
    functions = [
        *helper_sources([*loads.values(), *eq.external_force]),
        _function_source(
            "external_force", "z, t, p",
            "Generalised force on each coordinate besides the ball loads (loads, springs, "
            "damping, supports), N or N·m.",
            eq.external_force, ctx, True),
        _function_source("mass", "p", "Mass (kg) or transverse inertia (kg·m²) of each "
                         "coordinate.", eq.masses, ctx, True),
        _function_source("shaft_speed", "p", "Shaft angular speed ω, rad/s.",
                         [eq.shaft_speed], ctx, False),
    ]
    for bearing in eq.bearings:
        name = bearing.name
        rows = eq.station_map(bearing)
        functions += [
            _function_source(
                f"ball_load_{name}", "c, s, i, n_balls, z, t, p",
                f"Radial load of ball i (1 … n_balls) of bearing '{name}' at (cos θ, sin θ) = "
                "(c, s) on its inner race, N.", [loads[name]], ctx, False),
            _function_source(f"cage_speed_{name}", "p",
                             f"Cage angular speed ω_cage of bearing '{name}', rad/s.",
                             [eq.cage[name]], ctx, False),
            _station_source(name, rows, ctx),
        ]
    functions.append(
        "def build(n_balls=None) -> ModelFunctions:\n"
        '    """CasADi Functions (rhs, jac, rk4_step) for the numbers of balls\n'
        "    of the bearings (a tuple in the order of BEARINGS; default: DEFAULT_N_BALLS).\n"
        '    """\n'
        "    return ModelFunctions(sys.modules[__name__], n_balls or DEFAULT_N_BALLS)\n")
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
    bodies = [repr((b.name, b.motion, b.coordinates)) for b in eq.bodies]
    bearings = [repr((b.name, b.inner, b.outer, b.n_balls, n_balls_range(spec, b)))
                for b in eq.bearings]
    roles = "".join(f"    {role!r}: {names!r},\n"
                    for role, names in parameter_roles(spec, ctx).items())
    constants = [
        f"NAME = {spec.model.name!r}",
        f"TITLE = {spec.model.title!r}",
        f"REFERENCE = {spec.model.reference!r}",
        f"SPEC_FILE = {prov.spec_file!r}",
        f"SPEC_SHA256 = {prov.digest!r}",
        f"GENERATOR = {versions()!r}",
        f"STATE = {eq.state_names!r}",
        f"STATE_UNITS = {spec.state_units()!r}",
        f"BODIES = {_tuple('name, motion, coordinates', bodies)}",
        f"BEARINGS = {_tuple('name, inner, outer, default balls, (fewest, most)', bearings)}",
        f"DEFAULT_N_BALLS = {tuple(b.n_balls for b in eq.bearings)!r}",
        f"SIMULATION = {spec.simulation.times()!r}",
        f"INITIAL_STATE = {spec.initial_state()!r}",
        f"TERMS = (\n{terms})",
        f"PARAMETERS = (\n    # name, default value, unit, source\n{params})",
        f"RANGES = {{\n    # name: (low, high, low inclusive); high is inclusive\n{ranges}}}",
        f"ROLES = {{\n    # role: the parameters that play it (Model.role)\n{roles}}}",
    ]
    if spec.shaft is not None:  # a finite-element rotor: its reduction and node maps
        from modelgen.fe.nonlinear import flexible_constants

        constants += flexible_constants(spec)
    header = "\n".join(prov.lines())
    return (f'"""{spec.model.title}\n\n{header}\n"""\n\n' + "".join(imports) + "\n"
            + "\n".join(constants) + "\n\n\n" + "\n\n".join(functions))


def _station_source(name: str, rows, ctx: Context) -> str:
    """``station_map_<name>(p)``: (state index, ∂X/∂q, ∂Y/∂q) of the bearing's relative
    displacement; constants are printed as integers (the runtime then adds or subtracts the
    ball forces without a multiplication)."""
    printer = CasadiPrinter()
    used = set().union(*(sp.sympify(e).free_symbols for _, ax, ay in rows for e in (ax, ay)))
    lines = [f"def station_map_{name}(p):",
             f'    """(state index, ∂X/∂q, ∂Y/∂q) of bearing \'{name}\': how its races\' '
             'relative displacement (X, Y) moves with each coordinate."""']
    for index, (pname, sym) in enumerate(ctx.params.items()):
        if sym in used:
            lines.append(f"    {pname} = p[{index}]")
    entries = ", ".join(f"({j}, {printer.doprint(ax)}, {printer.doprint(ay)})"
                        for j, ax, ay in rows)
    lines.append(f"    return ({entries},)" if len(rows) == 1 else f"    return ({entries})")
    return "\n".join(lines) + "\n"


def c_source(spec: Spec, module_text: str, prov: Provenance) -> str:
    """CasADi's C code of rhs, jac and rk4_step at the default numbers of balls."""
    with _preview_module(spec.model.module, module_text) as module:
        funcs = module.build()
    with tempfile.TemporaryDirectory() as tmp:
        gen = casadi.CodeGenerator(f"{spec.model.module}.c", {"with_header": False})
        for f in (funcs.rhs, funcs.jac, funcs.rk4_step):
            gen.add(f)
        gen.generate(tmp + "/")
        body = (Path(tmp) / f"{spec.model.module}.c").read_text()
    header = "\n".join(f" * {line}" for line in prov.lines())
    balls = ", ".join(f"{b.name} {b.n_balls}" for b in spec.bearing_list()) or "no bearings"
    return (f"/*\n * {spec.model.title}\n * C source of rhs, jac, rk4_step; balls: "
            f"{balls}\n{header}\n */\n{body}")


@contextlib.contextmanager
def _preview_module(module: str, text: str):
    """Import generated module text in a scratch package, without touching ``generated/``."""
    with tempfile.TemporaryDirectory() as tmp:
        pkg = Path(tmp) / "generated_preview"
        (pkg / module).mkdir(parents=True)
        for path, body in ((pkg / "__init__.py", ""), (pkg / "_runtime.py", runtime_source()),
                           (pkg / module / "__init__.py", text)):
            write_text(path, body)  # an OSError (a full disk, a file-size limit) names it
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


def model_card(spec: Spec, prov: Provenance) -> str:
    eqs = latex_equations(spec)
    header = "\n".join(f"- {line}" for line in prov.lines())
    rows = "\n".join(
        f"| `{n}` | ${spec.quantity(n).latex}$ | {p.value:g} | {p.unit} | {p.source} |"
        for n, p in spec.parameters.items()
    )
    terms = "\n".join(f"{i + 1}. `{t.kind}`{_where(spec, t)}: {t.describe()}"
                      for i, t in enumerate(spec.terms))
    equations = "\n\n".join(f"$$\n{e}\n$$" for e in eqs)
    sim = ", ".join(f"{k} = {v:g}" for k, v in spec.simulation.times().items())
    initial = ", ".join(f"{n} = {v:g}" for n, v in zip(spec.state_names(), spec.initial_state(),
                                                       strict=True))
    bearings = spec.bearing_list()
    if bearings:
        balls = "Rolling elements (structural; any number in range is built at run time " \
                "from the same code): " + "; ".join(
                    f"bearing `{b.name}` between `{b.inner}` and `{b.outer}`, default "
                    f"$N_b = {b.n_balls}$, {lo}…{hi}"
                    for b, (lo, hi) in ((b, n_balls_range(spec, b)) for b in bearings)) + "."
    else:
        balls = "No bearings: the bodies are held by the terms below only."
    state = ", ".join(f"`{n}` ({u})" for n, u in zip(spec.state_names(), spec.state_units(),
                                                      strict=True))
    bodies = "; ".join(f"`{b.name}` ({b.motion}, {', '.join(b.coordinates)})"
                       for b in spec.body_list())
    if spec.shaft is not None:  # the nodes of a finite-element shaft
        bodies = (f"the shaft's nodes `node0` … `node{spec.shaft.node_count - 1}` (body terms "
                  "act at them; see Shaft and reduction)")
    default_balls = ", ".join(f"{b.name} = {b.n_balls}" for b in bearings) or "none"
    shaft = ""
    if spec.shaft is not None:  # a finite-element rotor: the shaft and what was kept
        from modelgen.fe.nonlinear import flexible_card

        shaft = flexible_card(spec)
    return f"""# {spec.model.name}: {spec.model.title}

{header}

Reference: {spec.model.reference}

{spec.model.description}

## Equations of motion

Bodies: {bodies}. State: {state}; $x$ along the radial load. {balls}

{equations}
{shaft}
## Terms

{terms}

## Parameters

| name | symbol | default | unit | source |
|---|---|---|---|---|
{rows}

Simulation defaults: {sim} (SI units); initial state {initial}.

## Files

- `__init__.py`: the expressions above as CasADi code; `build(n_balls)` returns the
  CasADi Functions `rhs`, `jac` and `rk4_step`.
- `{spec.model.module}.c`: CasADi's C source of `rhs`, `jac`, `rk4_step`
  (balls: {default_balls}).

To cite this model, give its name, the spec sha256 above and the bearingdyn version.
"""


def _where(spec: Spec, term) -> str:
    """' (on body rotor)' where a model has several bodies or bearings."""
    if len(spec.owner_names()) <= 2:
        return ""
    return " (" + ", ".join(f"{k} {v}" for k, v in spec.attachment(term).items()) + ")"


def runtime_source() -> str:
    return (resources.files("modelgen") / "templates" / RUNTIME_TEMPLATE).read_text()


def provenance(path: Path, spec: Spec, root: Path | None = None) -> Provenance:
    """The cited path and regenerate command of the spec at ``path``."""
    digest = spec_hash(path)
    if is_shipped(path):
        return Provenance(f"modelgen/specs/{path.name}", digest,
                          f"bearingdyn generate {spec.model.name}")
    resolved = path.resolve()
    out = f" --out {root.resolve()}" if root is not None else ""
    return Provenance(str(resolved), digest, f"bearingdyn generate {resolved}{out}")


def render(name_or_path: str | Path, root: Path | None = None) -> GeneratedFiles:
    """All files of one model as text, keyed by path relative to the generated root
    (``root``: where they go, when the user named it)."""
    spec, path = load_spec(name_or_path)
    prov = provenance(path, spec, root)
    eq = assemble(spec)
    module = spec.model.module
    text = module_source(spec, eq, prov)
    return GeneratedFiles({
        f"{module}/__init__.py": text,
        f"{module}/{module}.c": c_source(spec, text, prov),
        f"{module}/MODEL.md": model_card(spec, prov),
    })


def package_files() -> dict[str, str]:
    return {"__init__.py": PACKAGE_DOC, "_runtime.py": runtime_source()}


def default_root() -> Path:
    """The ``generated/`` package folder next to ``modelgen/``."""
    return Path(modelgen.__file__).resolve().parent.parent / "generated"


def atomic_write_text(target: Path, text: str) -> None:
    """Write ``text`` to ``target`` through a temporary file in the same folder and a
    rename: a reader sees the old file or the new one, never half of one."""
    target.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(target, text)


def _write_tree(root: Path, files: dict[str, str], check: bool, manifest: bool) -> list[str]:
    """The files of ``files`` that differ from ``root`` on disk; written unless ``check``
    (``modelgen.tree.write_root``: each model folder whole, the manifest last)."""
    changed = [rel for rel, text in files.items()
               if not (root / rel).is_file() or (root / rel).read_text() != text]
    if not check and (changed or (manifest and manifest_problem(root) is not None)):
        write_root(root, files, changed, manifest=manifest)
    return changed


def generate(names: list[str | Path], root: Path | None = None,
             check: bool = False) -> list[str]:
    """Write (or, with ``check``, compare) the generated files of the given specs.

    Shipped specs go to the package's ``generated/``; other specs to ``root`` when given,
    else to their folder in the user cache (``modelgen.locations.cached_model_root``): a
    spec from outside never writes into the package. Every file is written atomically, and
    only after every spec has been read and validated. Returns the paths that differ from
    what is on disk (with ``check``) or that were written: relative to the package root or
    ``root``, absolute in the cache.
    """
    rendered: dict[Path, dict[str, str]] = {}
    for name in names:
        _, path = load_spec(name)
        target = root if root is not None else (
            default_root() if is_shipped(path) else cached_model_root(path))
        rendered.setdefault(target, dict(package_files())).update(
            render(name, root if root is not None and not is_shipped(path) else None).files)
    changed = []
    for target, files in rendered.items():
        rels = _write_tree(target, files, check, manifest=target != default_root())
        named = target in (default_root(), root)
        changed += rels if named else [str(target / r) for r in rels]
    return changed
