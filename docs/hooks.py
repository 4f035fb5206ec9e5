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
- ``javascripts/mathjax.js``: MathJax's configuration for ``pymdownx.arithmatex`` (with
  ``textmacros``, so that the model cards' ``\\text{speed\\_rpm}`` shows an underscore).

Nothing here writes into the repository.
"""

from __future__ import annotations

import functools
import logging
import re
import sys
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # document this tree, not another installed copy
    sys.path.insert(0, str(ROOT))

log = logging.getLogger("mkdocs.hooks.bearingdyn")

GUIDE_SECTION = "User guide"
MODELS_SECTION = "Model cards"
OPTIONS_MARKER = re.compile(r"^<!-- bearingdyn:options (\S+) -->[ \t]*$", re.M)
COMMANDS_MARKER = re.compile(r"^<!-- bearingdyn:commands -->[ \t]*$", re.M)
SUBMODULES_MARKER = re.compile(r"^<!-- bearingdyn:submodules ([\w.]+) -->[ \t]*$", re.M)

MATHJAX_CONFIG = """\
window.MathJax = {
  loader: {load: ["[tex]/textmacros"]},
  tex: {
    packages: {"[+]": ["textmacros"]},
    inlineMath: [["\\\\(", "\\\\)"]],
    displayMath: [["\\\\[", "\\\\]"]],
    processEscapes: true,
    processEnvironments: true
  },
  options: {
    ignoreHtmlClass: ".*|",
    processHtmlClass: "arithmatex"
  }
};

document$.subscribe(() => {
  if (window.MathJax.typesetPromise) {
    MathJax.startup.output.clearCache();
    MathJax.typesetClear();
    MathJax.texReset();
    MathJax.typesetPromise();
  }
});
"""


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


def model_page(folder: str, name: str, text: str) -> str:
    note = (f"\n\n---\n\n*This page is `generated/{folder}/MODEL.md`, written by "
            f"`bearingdyn generate` from `modelgen/specs/{name}.toml`; see also "
            f"[how to cite a generated model](../index.md#how-to-cite-a-generated-model).*\n")
    return text.rstrip() + note


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
    files.append(File.generated(config, "javascripts/mathjax.js", content=MATHJAX_CONFIG))
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
    markdown = OPTIONS_MARKER.sub(options, markdown)
    return COMMANDS_MARKER.sub(lambda _m: commands_markdown(), markdown)


def on_serve(server, config, builder):
    """``mkdocs serve`` also rebuilds when the model cards or the CLI change."""
    server.watch(str(ROOT / "generated"))
    server.watch(str(ROOT / "analysis" / "cli.py"))
    return server
