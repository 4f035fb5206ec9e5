"""MkDocs hooks: the pages that are written from the code at build time, so they cannot drift.

- **User guide.** ``docs/guide/<command>.md`` is written by hand (what the command does, an
  example, the figure it makes). The line ``<!-- bearingdyn:options <command> -->`` in it is
  replaced by the command's usage, arguments and options, produced by typer's own Markdown
  generator (the one behind ``typer analysis.cli utils docs``) from the typer app
  ``analysis.cli.app``: the same source as ``bearingdyn <command> --help``. A command with no
  page of its own gets one made of its help text and options, so every command is in the
  site; a page or marker naming a command that does not exist is a build warning (an error
  under ``--strict``). ``<!-- bearingdyn:commands -->`` becomes the table of all commands.
- **Model cards.** ``generated/<model>/MODEL.md`` is shown as ``models/<model>.md``, copied in
  memory at build time (``generated/`` is not touched), with ``models/index.md`` listing them.
- **Navigation.** Those pages are appended to the "User guide" and "Model cards" sections of
  ``mkdocs.yml``'s nav, and a top-level page of ``docs/`` that the nav does not name is added
  before "User guide" under its first heading, so a new page is never left out.
- **API pages.** ``<!-- bearingdyn:submodules <package> -->`` becomes one mkdocstrings block
  per module of the package (``modelgen.terms``: one module per physical term).
- **Links to the repository.** A page may link a file outside ``docs/`` that exists in the
  repository (``../tests/test_x.py``): right on GitHub, but not part of the site. Such a link
  is shown as the file's path in code instead (``tests/test_x.py``); a link to a file that
  exists nowhere stays a link, and ``--strict`` fails on it.
- **Spec reference.** ``docs/spec-reference.md`` holds, between the lines
  ``<!-- bearingdyn:spec-reference begin … -->`` and ``<!-- bearingdyn:spec-reference end -->``,
  the reference of every section and field of a spec, walked from the pydantic schema
  ``modelgen.spec.Spec`` (field types, defaults, allowed values and ranges, the fields'
  docstrings), every term class of ``modelgen.terms.TERM_CLASSES`` (where it attaches, the
  parameters it needs) and the built-in quantities of ``modelgen.quantities.QUANTITIES``.
  The text is in the repository, readable without a build; ``python3 docs/hooks.py
  spec-reference`` rewrites it from the schema, ``tests/test_docs.py`` fails when it differs
  and a build warns (an error under ``--strict``). ``tests/modelgen/test_spec_guide.py`` fails on a
  field that has no docstring.
- **Included files.** ``<!-- bearingdyn:include PATH -->`` (PATH relative to ``docs/``)
  becomes the file in a code block, so a page shows the example spec as it is.
- **Math.** The ``$…$`` and ``$$…$$`` of the pages become MathML at build time
  (``latex2mathml``), which browsers render natively: the site needs no script and no network
  to show an equation, opened from a server or from disk. A formula latex2mathml cannot
  convert is a build warning (an error under ``--strict``). Browsers do not break MathML
  across lines, so a display formula is cut where a line may break (``formula_pieces``:
  before relations and binary operators, after commas; an aligned environment into its
  equations) and its pieces laid out in a wrapping flex row: they stand on one line when it
  fits and wrap when not, and no equation scrolls (material's ``overflow: auto``, which
  draws scroll arrows, is replaced by an inline style: no stylesheet to add).

The build writes nothing into the repository; ``python3 docs/hooks.py spec-reference``
writes ``docs/spec-reference.md`` (atomically), and nothing else.
"""

from __future__ import annotations

import functools
import itertools
import logging
import re
import sys
from pathlib import Path
from typing import Any, Literal, Union, get_args, get_origin

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # document this tree, not another installed copy
    sys.path.insert(0, str(ROOT))

log = logging.getLogger("mkdocs.hooks.bearingdyn")

GUIDE_SECTION = "User guide"
MODELS_SECTION = "Model cards"
OPTIONS_MARKER = re.compile(r"^<!-- bearingdyn:options (\S+) -->[ \t]*$", re.M)
COMMANDS_MARKER = re.compile(r"^<!-- bearingdyn:commands -->[ \t]*$", re.M)
SUBMODULES_MARKER = re.compile(r"^<!-- bearingdyn:submodules ([\w.]+) -->[ \t]*$", re.M)
SPEC_REFERENCE_BEGIN = ("<!-- bearingdyn:spec-reference begin: written from the schema by "
                        "`python3 docs/hooks.py spec-reference`; do not edit by hand -->")
SPEC_REFERENCE_END = "<!-- bearingdyn:spec-reference end -->"
SPEC_REFERENCE_PAGE = Path(__file__).resolve().parent / "spec-reference.md"
INCLUDE_MARKER = re.compile(r"^<!-- bearingdyn:include (\S+) -->[ \t]*$", re.M)

MATH = re.compile(r'<(span|div) class="arithmatex">(.*?)</\1>', re.S)
"""What ``pymdownx.arithmatex`` (generic mode) makes of ``$…$`` (a span holding ``\\(…\\)``)
and ``$$…$$`` (a div holding ``\\[…\\]``), TeX HTML-escaped."""
TEX_DELIMITERS = {"span": (r"\(", r"\)"), "div": (r"\[", r"\]")}


# --------------------------------------------------------------------------- the CLI


@functools.cache
def cli_group():
    """The click group behind ``bearingdyn`` (typer builds it from ``analysis.cli.app``).

    Cached for one build: ``on_config`` clears the cache and the CLI module is reloaded, so
    ``mkdocs serve`` shows an edited command without a restart."""
    import importlib

    import typer.main

    import analysis.cli

    return typer.main.get_command(importlib.reload(analysis.cli).app)


def cli_commands() -> dict:
    """Command name -> click command, in the order the app registers them."""
    group = cli_group()
    return {name: cmd for name, cmd in group.commands.items() if not cmd.hidden}


def _escape_html_outside_code(text: str) -> str:
    """``<model>`` in help text is a placeholder, not an HTML tag (code spans stay as they are)."""
    parts = re.split(r"(`[^`]*`)", text)
    return "".join(p if p.startswith("`") else p.replace("<", "&lt;") for p in parts)


def options_markdown(name: str) -> str:
    """Usage, arguments and options of ``bearingdyn <name>`` as Markdown, from typer."""
    import typer.cli

    group = cli_group()
    cmd = group.commands[name]
    ctx = group.context_class(group, info_name="bearingdyn")
    text = typer.cli.get_docs_for_click(obj=cmd, ctx=ctx, name=name, call_prefix="bearingdyn")
    # typer's page starts with its own title and the help text: the guide page has both
    start = text.find("**Usage**")
    if start < 0:
        raise RuntimeError(f"typer's docs for {name!r} have no usage section:\n{text}")
    return _escape_html_outside_code(text[start:]).rstrip() + "\n"


def commands_markdown() -> str:
    """The table of all commands (linking their guide pages) and the global options."""
    group = cli_group()
    ctx = group.context_class(group, info_name="bearingdyn")
    rows = ["| command | what it does |", "|---|---|"]
    for name, cmd in cli_commands().items():
        short = " ".join((cmd.help or "").split())
        rows.append(f"| [`{name}`]({name}.md) | {_escape_html_outside_code(short)} |")
    globals_ = []
    for param in group.params:
        record = param.get_help_record(ctx)
        if record:
            globals_.append(f"* `{record[0]}` (before the command): {record[1]}")
    return "\n".join([*rows, "", "Global options:", "", *globals_]) + "\n"


def stub_page(name: str, cmd) -> str:
    """The guide page of a command that has no hand-written one: its help and options."""
    help_text = _escape_html_outside_code(" ".join((cmd.help or "").split()))
    return (f"# `bearingdyn {name}`\n\n{help_text}\n\n## Usage and options\n\n"
            f"<!-- bearingdyn:options {name} -->\n")


# --------------------------------------------------------------------------- API pages


def submodules_markdown(package: str) -> str:
    """One mkdocstrings block per public submodule of ``package`` (``base`` first), so that a
    new module shows up in the API reference without editing its page."""
    folder = ROOT.joinpath(*package.split("."))
    names = sorted(p.stem if p.is_file() else p.name for p in folder.iterdir()
                   if not p.name.startswith("_")
                   and (p.suffix == ".py" or (p / "__init__.py").exists()))
    names.sort(key=lambda n: n != "base")
    return "\n".join(f"::: {package}.{name}\n    options:\n      heading_level: 2\n"
                     for name in names)


# --------------------------------------------------------------------------- spec reference

FIELD_NOTES: dict[str, str] = {
    # The fields whose class gives them no docstring (tests/modelgen/test_spec_guide.py checks
    # that each key is a field without one: a docstring added in the code replaces the note here).
    "Term.kind": "Which term this is.",
}
"""Descriptions of the schema fields that have no docstring in the code."""

CLASS_NOTES: dict[str, str] = {
    "ModelInfo": "`[model]`: the model's name, title and provenance.",
    "SimulationDefaults": "`[simulation]`: default times and initial state of a run.",
    "Parameter": "`[parameters]`: one entry per parameter, "
                 "`name = { value = …, unit = \"…\", source = \"…\" }`. A parameter that is "
                 "not a built-in quantity is declared with its allowed range `low`, `high`.",
}
"""Descriptions of the schema classes that have no docstring in the code."""

TERM_ATTACH_NOTES: dict[str, str] = {
    "expression": "`fx`, `fy`: a body; `ball`: a bearing",
    "viscous_damping": "a body (its velocity), or a bearing (the relative velocity of its "
                       "races)",
}
"""Where a term acts, when its ``attaches`` alone does not say it."""


def _docstring_of(obj: Any) -> str:
    """The object's own docstring (not inherited), cleaned, or ''."""
    import inspect

    doc = obj.__dict__.get("__doc__") if isinstance(obj, type) else obj.__doc__
    return inspect.cleandoc(doc) if doc else ""


@functools.cache
def attribute_docs(cls: type) -> dict[str, str]:
    """The docstrings written under the fields of ``cls`` and its bases (child first)."""
    import ast
    import inspect
    import itertools
    import textwrap

    found: dict[str, str] = {}
    for klass in cls.__mro__:
        if klass.__module__.startswith(("pydantic", "builtins")):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for node, after in itertools.pairwise(body):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                    and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                    and isinstance(after.value.value, str)):
                found.setdefault(node.target.id, inspect.cleandoc(after.value.value))
    return found


def field_description(cls: type, name: str) -> str:
    """A field's description: pydantic's, its docstring in the code, or ``FIELD_NOTES``."""
    info = cls.model_fields[name]
    text = info.description or attribute_docs(cls).get(name)
    if not text:
        for klass in cls.__mro__:
            text = FIELD_NOTES.get(f"{klass.__name__}.{name}")
            if text:
                break
    return text or ""


def _plain(text: str) -> str:
    """Docstring text as one Markdown table cell: ``code`` as `code`, one line, no pipes."""
    text = re.sub(r"``([^`]+)``", r"`\1`", " ".join(text.split()))
    return _escape_html_outside_code(text).replace("|", "\\|")


def _unwrap(annotation: Any) -> tuple[str | None, list[type]]:
    """('table' | 'list' | 'dict' | None, the pydantic classes) of a field's annotation."""
    import types
    from typing import Annotated

    from pydantic import BaseModel

    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _unwrap(args[0])
    if origin in (Union, types.UnionType):
        container, classes = None, []
        for arg in args:
            if arg is not type(None):
                kind, found = _unwrap(arg)
                container, classes = container or kind, [*classes, *found]
        return container, classes
    if origin is list:
        return ("list", _unwrap(args[0])[1]) if _unwrap(args[0])[1] else (None, [])
    if origin is dict:
        return ("dict", _unwrap(args[1])[1]) if _unwrap(args[1])[1] else (None, [])
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "table", [annotation]
    return None, []


def schema_sections() -> list[tuple[str, type]]:
    """(where it is written in TOML, class) of every pydantic class of a spec, walked from
    ``modelgen.spec.Spec`` in the order of its fields."""
    from modelgen.spec import Spec

    sections: list[tuple[str, type]] = [("top level", Spec)]
    seen: set[type] = {Spec}

    def walk(cls: type, where: str | None) -> None:
        for name, info in cls.model_fields.items():
            container, classes = _unwrap(info.annotation)
            for sub in classes:
                if sub in seen:
                    continue
                seen.add(sub)
                if len(classes) > 1 and "kind" in sub.model_fields:
                    here = f'[[{name}]] kind = "{sub.model_fields["kind"].default}"'
                elif where is None:
                    here = {"table": f"[{name}]", "list": f"[[{name}]]",
                            "dict": f"[{name}] <name> = {{ … }}"}[container]
                else:
                    here = f"{where} {name} = {{ … }}"
                sections.append((here, sub))
                walk(sub, here)

    walk(Spec, None)
    return sections


def _toml_type(annotation: Any) -> str:
    import types

    from pydantic import BaseModel

    origin, args = get_origin(annotation), get_args(annotation)
    if origin in (Union, types.UnionType):
        return " or ".join(_toml_type(a) for a in args if a is not type(None))
    if origin is Literal:
        return "text"
    if origin is list:
        return "list of tables" if _unwrap(annotation)[1] else f"list of {_toml_type(args[0])}"
    if origin is dict:
        return f"table of {_toml_type(args[1])}s".replace("tables", "tables")
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "table"
    return {str: "text", int: "integer", float: "number", bool: "true or false"}.get(
        annotation, getattr(annotation, "__name__", str(annotation)))


def _literal_choices(annotation: Any) -> tuple[Any, ...]:
    import types

    origin = get_origin(annotation)
    if origin is Literal:
        return get_args(annotation)
    if origin in (Union, types.UnionType):
        return tuple(c for a in get_args(annotation) for c in _literal_choices(a))
    return ()


def _allowed_text(info: Any) -> str:
    """Choices, bounds, pattern and lengths of a field, as Markdown."""
    parts = []
    choices = _literal_choices(info.annotation)
    if choices:
        parts.append(", ".join(f'`"{c}"`' for c in choices))
    low = high = None
    left, right = "(", ")"
    for rule in info.metadata:
        for attr, bracket in (("gt", "("), ("ge", "[")):
            if getattr(rule, attr, None) is not None:
                low, left = getattr(rule, attr), bracket
        for attr, bracket in (("lt", ")"), ("le", "]")):
            if getattr(rule, attr, None) is not None:
                high, right = getattr(rule, attr), bracket
        if getattr(rule, "pattern", None):
            parts.append(f"`{rule.pattern}`")
        if getattr(rule, "min_length", None) is not None:
            what = "character" if info.annotation is str else "entry"
            parts.append(f"at least {rule.min_length} {what}")
        if getattr(rule, "max_length", None) is not None:
            parts.append(f"at most {rule.max_length} characters")
    if low is not None or high is not None:
        lo = "-inf" if low is None else f"{low:g}"
        hi = "inf" if high is None else f"{high:g}"
        parts.append(f"{left}{lo}, {hi}{right}")
    return "; ".join(parts)


def _default_text(info: Any) -> str:
    from pydantic import BaseModel

    if info.is_required():
        return "**required**"
    value = info.get_default(call_default_factory=True)
    if value is None:
        return "not set"
    if isinstance(value, BaseModel):
        return "its defaults"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, dict) and not value:
        return "`{}`"
    if isinstance(value, float):
        return f"`{value:g}`"
    return f"`{value!r}`"


def fields_table(cls: type) -> str:
    rows = ["| field | type | default | allowed | description |", "|---|---|---|---|---|"]
    for name, info in sorted(cls.model_fields.items(), key=lambda item: item[0] != "kind"):
        rows.append(f"| `{name}` | {_toml_type(info.annotation)} | {_default_text(info)} | "
                    f"{_plain(_allowed_text(info))} | {_plain(field_description(cls, name))} |")
    return "\n".join(rows)


def _term_instance(cls: type, **values: Any) -> Any:
    """A term with its defaults (the first choice of a required option), or None."""
    for name, info in cls.model_fields.items():
        choices = _literal_choices(info.annotation)
        if info.is_required() and choices and name not in values:
            values[name] = choices[0]
    try:
        return cls(**values)
    except Exception:  # a term that cannot be built from options alone (expression)
        return None


def term_parameters(cls: type) -> list[str]:
    """Markdown lines: the parameters the term needs with its default options, and what
    each other option adds or drops."""
    base = _term_instance(cls)
    if base is None:
        return ["- **Parameters:** the names its expressions use (built-in quantities, or "
                "parameters the spec declares)"]
    needed = list(base.required_parameters())
    lines = [f"- **Parameters:** {', '.join(f'`{n}`' for n in needed) or 'none'}"
             + (" (default options)" if _options(cls) else "")]
    for name, choices in _options(cls).items():
        current = getattr(base, name)
        for choice in choices:
            if choice == current:
                continue
            other = _term_instance(cls, **{name: choice})
            if other is None:
                continue
            got = list(other.required_parameters())
            added = [n for n in got if n not in needed]
            dropped = [n for n in needed if n not in got]
            change = [*(f"+ `{n}`" for n in added), *(f"− `{n}`" for n in dropped)]
            if change:
                lines.append(f'    - with `{name} = "{choice}"`: {", ".join(change)}')
    return lines


def _options(cls: type) -> dict[str, tuple[Any, ...]]:
    return {name: choices for name, info in cls.model_fields.items()
            if name != "kind" and len(choices := _literal_choices(info.annotation)) > 1}


def _term_section(where: str, cls: type) -> list[str]:
    kind = cls.model_fields["kind"].default
    attaches = TERM_ATTACH_NOTES.get(kind) or " or ".join(f"a {o}" for o in cls.attaches)
    doc = _docstring_of(cls)
    summary = cls.summary
    lines = [f"### `{where}`", "", f"`{cls.__module__}.{cls.__name__}`: {_plain(summary)}", ""]
    if doc:
        lines += [_plain(doc.split("\n\n")[0]), ""]
    lines += [f"- **Acts on:** {attaches}", *term_parameters(cls), "", fields_table(cls), ""]
    return lines


def quantities_table() -> str:
    from modelgen.quantities import QUANTITIES

    rows = ["| name | unit | allowed | symbol | meaning |", "|---|---|---|---|---|"]
    for q in QUANTITIES.values():
        allowed = q.range_text().removesuffix(f" {q.unit}")
        rows.append(f"| `{q.name}` | `{q.unit}` | {allowed} | ${q.latex}$ | {_plain(q.meaning)} |")
    return "\n".join(rows)


def expression_symbols() -> list[str]:
    from modelgen.expressions import CONSTANTS, FUNCTIONS
    from modelgen.terms.expression import BALL_SYMBOLS, TIME_SYMBOLS

    def names(items) -> str:
        return ", ".join(f"`{n}`" for n in items)

    return [
        f"- every expression: the model's state names, {names(TIME_SYMBOLS)} (time, s; shaft "
        f"speed, rad/s), {names(CONSTANTS)}, the parameters, and the functions "
        f"{names(FUNCTIONS)};",
        f"- `ball` only: {names(BALL_SYMBOLS)}.",
    ]


def motions_table() -> str:
    from modelgen.spec import COORDINATE_UNITS, MOTIONS

    rows = ["| motion | coordinates | units | velocities |", "|---|---|---|---|"]
    for motion, coords in MOTIONS.items():
        units = ", ".join(COORDINATE_UNITS[c][0] for c in coords)
        rows.append(f"| `{motion}` | {', '.join(f'`{c}`' for c in coords)} | {units} | "
                    f"{', '.join(f'`v{c}`' for c in coords)} |")
    return "\n".join(rows)


def spec_reference_markdown() -> str:
    """The reference of every section and field of a spec, from the schema."""
    from modelgen.spec import GROUND, N_BALLS_RANGE
    from modelgen.terms import TERM_CLASSES

    sections = schema_sections()
    terms = [(w, c) for w, c in sections if c in TERM_CLASSES]
    tables = [(w, c) for w, c in sections if c not in TERM_CLASSES]
    out = ["## Sections", "", "| where | class | what it is |", "|---|---|---|"]
    for where, cls in sections:
        what = _docstring_of(cls).split("\n\n")[0] or CLASS_NOTES.get(cls.__name__, "")
        if cls in TERM_CLASSES:
            what = cls.summary
        shown = where if where == "top level" else f"`{where}`"
        out.append(f"| {shown} | `{cls.__name__}` | {_plain(what)} |")
    out += ["", "## Tables", ""]
    for where, cls in tables:
        doc = _docstring_of(cls) or CLASS_NOTES.get(cls.__name__, "")
        title = "The top level" if where == "top level" else f"`{where}`"
        out += [f"### {title}", "", f"`{cls.__module__}.{cls.__name__}`", ""]
        if doc:
            out += [_plain(doc.split("\n\n")[0]), ""]
        out += [fields_table(cls), ""]
    out += ["## Terms", "",
            "Every `[[terms]]` entry has `kind`, and `body = \"…\"` or `bearing = \"…\"` where "
            "it acts (optional when the model has one body or one bearing).", ""]
    for where, cls in terms:
        out += _term_section(where, cls)
    out += ["## Motions", "", motions_table(), "",
            f"A bearing's `outer` may be `{GROUND}`, the fixed frame. `n_balls` is in "
            f"[{N_BALLS_RANGE[0]}, {N_BALLS_RANGE[1]}] and at most the number of balls that fit "
            "on the pitch circle, floor(π / asin(D_b / D_m)).", "",
            "## Names in expressions", "", *expression_symbols(), "",
            "## Built-in quantities", "",
            "A parameter with one of these names has this unit and range (a spec that gives "
            "another unit, or `low`/`high`, is rejected). `<quantity>_<bearing>` (or "
            "`_<body>`) is the same quantity for one bearing or body, with the same unit and "
            "range.", "", quantities_table(), ""]
    return "\n".join(out)


def spec_reference_page(page: str) -> str:
    """``page`` (the text of ``docs/spec-reference.md``) with the part between its begin and
    end lines replaced by ``spec_reference_markdown()``; the page's own text (its title and
    introduction, before the begin line) is kept."""
    head = page.split(SPEC_REFERENCE_BEGIN)[0].split("<!-- bearingdyn:spec-reference")[0]
    return (f"{head.rstrip()}\n\n{SPEC_REFERENCE_BEGIN}\n\n{spec_reference_markdown().strip()}"
            f"\n\n{SPEC_REFERENCE_END}\n")


def write_spec_reference(path: Path = SPEC_REFERENCE_PAGE) -> bool:
    """Rewrite ``path`` from the schema (atomically); True when it changed."""
    import os
    import tempfile

    old = path.read_text(encoding="utf-8")
    new = spec_reference_page(old)
    if new == old:
        return False
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as handle:
        handle.write(new)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)
    return True


def include_markdown(path: str, docs_dir: Path) -> str:
    """A file of ``docs/`` in a code block (the language from its suffix)."""
    target = (docs_dir / path).resolve()
    if not target.is_file() or not target.is_relative_to(docs_dir.resolve()):
        log.warning("bearingdyn:include %s: no such file in docs/", path)
        return ""
    language = {".toml": "toml", ".py": "python"}.get(target.suffix, "text")
    text = target.read_text(encoding="utf-8").rstrip("\n")
    return f'```{language} title="{target.name}"\n{text}\n```\n'


# --------------------------------------------------------------------------- model cards


def model_cards() -> list[tuple[str, str, str]]:
    """(folder, model name, card text) of every generated model, sorted by folder."""
    cards = []
    for card in sorted((ROOT / "generated").glob("*/MODEL.md")):
        text = card.read_text(encoding="utf-8")
        first = text.splitlines()[0] if text else ""
        name = first.removeprefix("# ").split(":", 1)[0].strip() or card.parent.name
        cards.append((card.parent.name, name, text))
    return cards


NAME_CELL = re.compile(r"^\| (`[^`|]+`) \|", re.M)
"""A table row whose first cell is one name in code (the parameters of a model card)."""


def unbroken_names(text: str) -> str:
    """``text`` with the name in the first cell of every table row kept on one line (a
    span with ``white-space: nowrap``): a narrow column then wraps the other cells, never a
    parameter name mid-word (``contact_stiff|ness``)."""
    return NAME_CELL.sub(r'| <span class="bd-name" style="white-space: nowrap">\1</span> |',
                         text)


def model_page(folder: str, name: str, text: str) -> str:
    note = (f"\n\n---\n\n*This page is `generated/{folder}/MODEL.md`, written by "
            f"`bearingdyn generate` from `modelgen/specs/{name}.toml`; see also "
            f"[how to cite a generated model](../index.md#how-to-cite-a-generated-model).*\n")
    return unbroken_names(text.rstrip()) + note


def models_index(cards: list[tuple[str, str, str]]) -> str:
    rows = ["| model | what it is | spec sha256 |", "|---|---|---|"]
    for folder, name, text in cards:
        first = text.splitlines()[0] if text else ""
        title = first.split(":", 1)[1].strip() if ":" in first else ""
        sha = re.search(r"spec sha256: ([0-9a-f]{64})", text)
        rows.append(f"| [`{name}`]({folder}.md) | {_escape_html_outside_code(title)} | "
                    f"`{sha.group(1)[:12] if sha else '?'}…` |")
    return (
        "# Model cards\n\n"
        "Each generated model comes with a model card, `generated/<model>/MODEL.md`, written by "
        "`bearingdyn generate` from the model's spec `modelgen/specs/<model>.toml`: the "
        "equations of motion in LaTeX, the terms, every parameter with its unit, default and "
        "source, and the spec's SHA-256. The pages below show the committed cards as they are.\n\n"
        + "\n".join(rows) + "\n\n"
        "To cite a model, see [how to cite a generated model]"
        "(../index.md#how-to-cite-a-generated-model).\n"
    )


# --------------------------------------------------------------------------- navigation


def _nav_files(nav) -> set[str]:
    found: set[str] = set()
    if isinstance(nav, str):
        found.add(nav)
    elif isinstance(nav, list):
        for item in nav:
            found |= _nav_files(item)
    elif isinstance(nav, dict):
        for value in nav.values():
            found |= _nav_files(value)
    return found


def _section(nav: list, title: str) -> list:
    for item in nav:
        if isinstance(item, dict) and title in item and isinstance(item[title], list):
            return item[title]
    raise KeyError(f"mkdocs.yml: the nav has no section {title!r} (docs/hooks.py fills it)")


def page_title(path: Path) -> str:
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip().replace("`", "")
    return path.stem.replace("-", " ").capitalize()


# --------------------------------------------------------------------------- repository links

LINK = re.compile(r"(?<!!)\[([^\]\n]+)\]\(([^)\s]+)\)")
CODE = re.compile(r"(```.*?```|~~~.*?~~~|`[^`\n]*`)", re.S)
SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def repository_links(markdown: str, src_uri: str, docs_dir: Path) -> str:
    """Links to files of the repository outside docs/ become their path in code."""
    docs_dir = docs_dir.resolve()
    page_dir = (docs_dir / src_uri).parent

    def replace(match: re.Match) -> str:
        text, target = match.groups()
        path = target.split("#", 1)[0]
        if not path or SCHEME.match(target) or target.startswith("/"):
            return match.group(0)
        resolved = (page_dir / path).resolve()
        if (resolved.is_relative_to(docs_dir) or not resolved.is_relative_to(ROOT)
                or not resolved.exists()):
            return match.group(0)  # a docs page (mkdocs checks it) or a broken link: a warning
        rel = resolved.relative_to(ROOT).as_posix()
        log.debug("%s: link to %s shown as its path", src_uri, rel)
        return text if rel in text else f"{text} (`{rel}`)"

    parts = CODE.split(markdown)
    return "".join(part if i % 2 else LINK.sub(replace, part) for i, part in enumerate(parts))


# --------------------------------------------------------------------------- hooks


def on_config(config):
    cli_group.cache_clear()
    nav = config.nav
    if nav is None:
        return config
    guide = _section(nav, GUIDE_SECTION)
    for name in cli_commands():
        guide.append({f"bearingdyn {name}": f"guide/{name}.md"})
    models = _section(nav, MODELS_SECTION)
    for folder, name, _text in model_cards():
        models.append({name: f"models/{folder}.md"})
    named = _nav_files(nav)
    docs_dir = Path(config.docs_dir)
    position = next(i for i, item in enumerate(nav)
                    if isinstance(item, dict) and GUIDE_SECTION in item)
    for page in sorted(docs_dir.glob("*.md")):
        if page.name not in named:
            log.info("docs/%s is not in mkdocs.yml's nav: added as %r", page.name,
                     page_title(page))
            nav.insert(position, {page_title(page): page.name})
            position += 1
    return config


def on_files(files, config):
    from mkdocs.structure.files import File  # here: the reference above imports without MkDocs

    commands = cli_commands()
    guide_dir = Path(config.docs_dir) / "guide"
    for name, cmd in commands.items():
        if not (guide_dir / f"{name}.md").exists():
            log.info("no docs/guide/%s.md: the page shows the command's help only", name)
            files.append(File.generated(config, f"guide/{name}.md",
                                        content=stub_page(name, cmd)))
    for path in sorted(guide_dir.glob("*.md")):
        if path.stem != "index" and path.stem not in commands:
            log.warning("docs/guide/%s.md: there is no command 'bearingdyn %s'",
                        path.name, path.stem)
    cards = model_cards()
    files.append(File.generated(config, "models/index.md", content=models_index(cards)))
    for folder, name, text in cards:
        files.append(File.generated(config, f"models/{folder}.md",
                                    content=model_page(folder, name, text)))
    return files


def on_page_markdown(markdown, page, config, files):
    commands = cli_commands()

    def options(match: re.Match) -> str:
        name = match.group(1)
        if name not in commands:
            log.warning("%s: no command 'bearingdyn %s' for its options", page.file.src_uri, name)
            return ""
        return options_markdown(name)

    markdown = repository_links(markdown, page.file.src_uri, Path(config.docs_dir))
    markdown = SUBMODULES_MARKER.sub(lambda m: submodules_markdown(m.group(1)), markdown)
    if page.file.src_uri == "spec-reference.md":
        if spec_reference_page(markdown) != markdown:
            log.warning("docs/spec-reference.md differs from the schema: run `python3 "
                        "docs/hooks.py spec-reference` to write it again")
        markdown = markdown.replace(SPEC_REFERENCE_BEGIN, "").replace(SPEC_REFERENCE_END, "")
    markdown = INCLUDE_MARKER.sub(
        lambda m: include_markdown(m.group(1), Path(config.docs_dir)), markdown)
    markdown = OPTIONS_MARKER.sub(options, markdown)
    return COMMANDS_MARKER.sub(lambda _m: commands_markdown(), markdown)


def tex_to_mathml(tex: str, display: bool) -> str:
    """MathML for one formula (``\\_`` in ``\\text{…}`` shown as an underscore, as the model
    cards' ``\\text{speed\\_rpm}`` mean it)."""
    from latex2mathml.converter import convert

    mathml = convert(tex.strip(), display="block" if display else "inline")
    return re.sub(r"(<mtext>[^<]*)</mtext>",
                  lambda m: m.group(1).replace("\\_", "_") + "</mtext>", mathml)


RELATIONS = {"=", "<", ">", "approx", "le", "ge", "leq", "geq", "equiv", "sim", "ne",
             "neq", "to", "propto", "simeq", "ll", "gg", "in", "mapsto", "Rightarrow"}
"""Relations a wide display formula may be broken before (TeX's own choice, TeXbook 14)."""
NOT_OPERANDS = {"", "=", "<", ">", "(", "[", ",", "+", "-", "{", "&", "^", "_", "cdot",
                "times", "pm", "mp", "left", "quad", "qquad", *RELATIONS}
"""What a ``+`` or ``−`` may follow and still be a sign, not a binary operator."""
SHORT_SIDE = 20
"""TeX characters of a left side short enough to stay on the line of its relation."""
LONG_FORMULA = 120
"""TeX characters beyond which ``\\left(``…``\\right)`` pairs become plain parentheses, so
that a formula the size of a model card's ball load can break inside them."""
WRAP_STYLE = ("display:flex;flex-wrap:wrap;justify-content:center;align-items:baseline;"
              "overflow:visible")
"""Inline style of a display formula cut into pieces: the pieces flow on as many lines as
the column needs (material's own ``overflow:auto``, which draws scroll arrows, replaced)."""
PIECE_STYLE = "margin:0 !important;padding:0 !important;width:auto !important"


def _plain_delimiters(tex: str) -> str:
    r"""``\left(``…``\right)`` as plain ``(``…``)`` (and ``[ ] | .``): breakable inside."""
    return re.sub(r"\\(?:left|right)\s*(\\[{}|]|[()\[\]|.])",
                  lambda m: "" if m.group(1) == "." else m.group(1), tex)


ARGUMENTS = {"frac": 2, "tfrac": 2, "dfrac": 2, "sqrt": 1, "text": 1, "operatorname": 1,
             "mathrm": 1, "mathbf": 1, "mathit": 1, "mathcal": 1, "boldsymbol": 1, "dot": 1,
             "ddot": 1, "hat": 1, "bar": 1, "vec": 1, "tilde": 1, "overline": 1}
"""TeX commands and the number of brace groups they take (kept whole when a long formula
is made breakable)."""
LONG_FRACTION = 80
"""TeX characters of numerator and denominator beyond which a long formula's fraction is
written A/B on one line (so that it can break inside A)."""


def _group_end(tex: str, start: int) -> int:
    """The index of the ``}`` that closes the ``{`` at ``start``."""
    depth = 0
    for k in range(start, len(tex)):
        depth += {"{": 1, "}": -1}.get(tex[k], 0)
        if depth == 0:
            return k
    raise ValueError(f"unbalanced braces in {tex!r}")


def _argument(tex: str, i: int) -> tuple[str, int]:
    """The argument at ``i`` (spaces skipped): a brace group (with its braces), a command or
    one character; and the index after it."""
    while i < len(tex) and tex[i].isspace():
        i += 1
    if i >= len(tex):
        return "", i
    if tex[i] == "{":
        end = _group_end(tex, i)
        return tex[i:end + 1], end + 1
    m = re.match(r"\\([A-Za-z]+|.)|.", tex[i:], re.S)
    return m.group(0), i + len(m.group(0))


def breakable(tex: str) -> str:
    r"""A long formula with nothing that keeps a line from breaking inside it but what must:
    plain brace groups removed (``\cos{(θ)}`` → ``\cos(θ)``), fractions longer than
    ``LONG_FRACTION`` written ``(A)/(B)``; arguments of commands, superscripts and
    subscripts kept as they are."""
    out, i = [], 0
    while i < len(tex):
        c = tex[i]
        if c == "\\":
            m = re.match(r"\\([A-Za-z]+|.)", tex[i:])
            name, i = m.group(1), i + len(m.group(0))
            args = []
            for _ in range(ARGUMENTS.get(name, 0)):
                arg, i = _argument(tex, i)
                args.append(arg)
            if name in ("frac", "tfrac", "dfrac") and sum(map(len, args)) > LONG_FRACTION:
                num, den = (a[1:-1] if a.startswith("{") else a for a in args)
                den = den if re.fullmatch(r"[\w\\]+(_\{?\w+\}?)?", den) else f"({breakable(den)})"
                out.append(f"({breakable(num)})/{den}")
            else:
                out.append(m.group(0) + "".join(args))
            continue
        if c in "^_":
            arg, i = _argument(tex, i + 1)
            out.append(c + arg)
            continue
        if c == "{":
            end = _group_end(tex, i)
            out.append(breakable(tex[i + 1:end]))
            i = end + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def formula_pieces(tex: str) -> list[str]:
    r"""A display formula cut where a line may break: before a relation (=, \approx, …)
    or a binary + or −, after a comma or a \quad, only outside braces, environments and
    ``\left``…``\right`` pairs (a long formula, ``LONG_FORMULA``, has plain parentheses
    for its pairs first, and is made ``breakable``). An ``aligned`` environment gives one
    piece per equation (its column pairs), each row ending a line (the piece ``"\\"``).
    One piece: the formula whole."""
    body = tex.strip()
    env = re.fullmatch(r"\\begin\{aligned\}(.*)\\end\{aligned\}", body, re.S)
    if env:
        pieces: list[str] = []
        for row in re.split(r"\\\\", env.group(1)):
            cells = row.split("&")
            pairs = [p for p in ("".join(cells[k:k + 2]).strip()
                                 for k in range(0, len(cells), 2)) if p]
            for k, pair in enumerate(pairs):  # the columns' space kept between equations
                pieces += formula_pieces(pair + (r" \quad" if k < len(pairs) - 1 else ""))
            pieces.append("\\\\")
        return pieces[:-1]
    if len(body) > LONG_FORMULA:
        body = breakable(_plain_delimiters(body))
    starts, braces, nested, previous, i = [0], 0, 0, "", 0
    while i < len(body):
        c = body[i]
        if c == "\\":
            m = re.match(r"\\([A-Za-z]+|.)", body[i:])
            name = m.group(1)
            if name in ("begin", "left"):
                nested += 1
            elif name in ("end", "right"):
                nested -= 1
            elif braces == nested == 0 and name in RELATIONS:
                starts.append(i)
            elif braces == nested == 0 and name in ("quad", "qquad"):
                starts.append(i + len(m.group(0)))
            previous = name
            i += len(m.group(0))
            continue
        if c == "{":
            braces += 1
        elif c == "}":
            braces -= 1
        elif braces == nested == 0:
            if c in "=<>" and previous not in ("=", "<", ">"):
                starts.append(i)
            elif c in "+-" and previous not in NOT_OPERANDS:
                starts.append(i)
            elif c == ",":
                starts.append(i + 1)
        if not c.isspace():
            previous = c
        i += 1
    cuts = [*sorted(set(starts)), len(body)]
    pieces: list[str] = []
    for a, b in itertools.pairwise(cuts):
        piece = body[a:b].strip()
        relation = re.match(r"[=<>]|\\([A-Za-z]+)", piece)
        if pieces and re.fullmatch(r"(\\(quad|qquad|[,;: ])\s*)+", piece):
            pieces[-1] += " " + piece  # a space after a comma stays with it
        elif (pieces and relation and (relation.group(1) in RELATIONS or not relation.group(1))
              and len(pieces[-1]) <= SHORT_SIDE and not pieces[-1].endswith((",", "quad"))):
            pieces[-1] += " " + piece  # a short left side stays with its relation
        elif piece:
            pieces.append(piece)
    # a piece that starts with + or − keeps them binary (spaced), not a sign: {}+ …
    return [f"{{}}{p}" if p[0] in "+-" else p for p in pieces]


def wrapped_display(tex: str) -> str | None:
    """The MathML of a display formula as pieces that wrap (``formula_pieces``), or None
    when it is one piece or a piece cannot be converted (then it is shown whole)."""
    pieces = formula_pieces(tex)
    if len(pieces) < 2:
        return None
    out = []
    for piece in pieces:
        if piece == "\\\\":  # a row of an aligned environment ends: a new line
            out.append('<span style="flex-basis:100%;height:0" aria-hidden="true"></span>')
            continue
        try:
            mathml = tex_to_mathml(piece, display=True)
        except Exception:  # latex2mathml raises its own types: show the formula whole
            return None
        out.append(mathml.replace("<math ", f'<math style="{PIECE_STYLE}" ', 1))
    return "".join(out)


def math_to_mathml(html: str, where: str = "") -> str:
    """Every arithmatex span and div of a page's HTML as MathML (see ``MATH``)."""
    import html as html_lib

    def replace(match: re.Match) -> str:
        tag, body = match.groups()
        opening, closing = TEX_DELIMITERS[tag]
        tex = html_lib.unescape(body).strip()
        if not (tex.startswith(opening) and tex.endswith(closing)):
            log.warning("%s: unexpected math markup %r", where, body[:80])
            return match.group(0)
        tex = tex[len(opening):-len(closing)]
        try:
            mathml = tex_to_mathml(tex, display=tag == "div")
        except Exception as exc:  # latex2mathml raises its own types for TeX it cannot read
            log.warning("%s: cannot convert the formula %r to MathML (%s)", where, tex, exc)
            return match.group(0)
        wrapped = wrapped_display(tex) if tag == "div" else None
        if wrapped:
            return f'<div class="arithmatex" style="{WRAP_STYLE}">{wrapped}</div>'
        return f'<{tag} class="arithmatex" style="overflow:visible">{mathml}</{tag}>' \
            if tag == "div" else f'<{tag} class="arithmatex">{mathml}</{tag}>'

    return MATH.sub(replace, html)


def on_page_content(html, page, config, files):
    return math_to_mathml(html, page.file.src_uri)


def on_serve(server, config, builder):
    """``mkdocs serve`` also rebuilds when the model cards or the CLI change."""
    server.watch(str(ROOT / "generated"))
    server.watch(str(ROOT / "analysis" / "cli.py"))
    return server


if __name__ == "__main__":  # python3 docs/hooks.py spec-reference
    if sys.argv[1:] != ["spec-reference"]:
        sys.exit("usage: python3 docs/hooks.py spec-reference (rewrite docs/spec-reference.md "
                 "from the schema)")
    changed = write_spec_reference()
    print(f"{SPEC_REFERENCE_PAGE.relative_to(ROOT)}: "
          + ("written from the schema" if changed else "already equal to the schema"))
