"""The documentation site: it builds strictly, its images exist, its commands are real.

The site is built with ``mkdocs build --strict`` (CI installs the ``docs`` extra and builds it
before the tests too). The other checks read the Markdown sources and the typer app, so they
need no MkDocs.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import typer.main

from analysis.cli import app
from tests.conftest import ROOT
from tests.extras import install_line, require

pytestmark = pytest.mark.xdist_group(__name__)
"""This module's tests on one xdist worker (``--dist loadgroup``: tests/conftest.py), so its
module fixtures run once, not once per worker."""
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))
MODEL_CARDS = sorted((ROOT / "generated").glob("*/MODEL.md"))
GROUP = typer.main.get_command(app)
COMMANDS = {name: cmd for name, cmd in GROUP.commands.items() if not cmd.hidden}
SHELL_LANGUAGES = {"", "bash", "sh", "shell", "console"}

FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|<img[^>]*\ssrc=\"([^\"]+)\"")
INLINE_COMMAND = re.compile(r"(?<!`)`(bearingdyn [^`\n]+)`")


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _missing_docs_tools() -> str | None:
    for module, package in (("mkdocs", "mkdocs"), ("material", "mkdocs-material"),
                            ("mkdocstrings_handlers.python", "mkdocstrings[python]")):
        try:
            found = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:
            found = False
        if not found:
            return package
    return None


# --------------------------------------------------------------------------- the site


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    missing = _missing_docs_tools()
    if missing:
        pytest.skip(f"{missing} is not installed: {install_line('docs')} "
                    "(.ci/run's second stage installs it)")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    res = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                          "--site-dir", str(out)], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, f"mkdocs build --strict failed:\n{res.stdout}\n{res.stderr}"
    return out


@pytest.mark.needs_extra
def test_site_builds_strictly(site):
    assert (site / "index.html").exists()
    assert (site / "getting-started.html").exists()


@pytest.mark.needs_extra
def test_site_has_a_guide_page_with_options_for_every_command(site):
    for name, cmd in COMMANDS.items():
        page = site / "guide" / f"{name}.html"
        assert page.exists(), f"no guide page for `bearingdyn {name}`"
        html = page.read_text(encoding="utf-8")
        assert "bearingdyn:options" not in html
        nested = [cmd, *getattr(cmd, "commands", {}).values()]  # a group: record info
        for param in (p for c in nested for p in c.params):
            for opt in param.opts:
                if opt.startswith("-"):
                    assert opt in html, f"guide/{name}: option {opt} not shown"


@pytest.mark.needs_extra
def test_site_shows_every_model_card(site):
    assert {"mathieu", "rotor_housing", "two_bearing_rotor", "vakharia2015"} <= {
        card.parent.name for card in MODEL_CARDS}
    for card in MODEL_CARDS:
        page = site / "models" / f"{card.parent.name}.html"
        assert page.exists(), f"no page for {_rel(card)}"
        sha = re.search(r"spec sha256: ([0-9a-f]{64})", card.read_text(encoding="utf-8"))
        assert sha and sha.group(1) in page.read_text(encoding="utf-8")


@pytest.mark.needs_extra
def test_site_has_the_api_reference_from_docstrings(site):
    modules = ["analysis.integrate.simulate", "analysis.signal.spectrum",
               "analysis.signal.poincare", "analysis.stability.lyapunov",
               "analysis.stability.periodic", "analysis.stability.continuation",
               "analysis.stability.classify", "analysis.sweeps.grid",
               "analysis.sweeps.diagram", "analysis.sweeps.chart",
               "analysis.sweeps.executors", "analysis.model", "analysis.io", "modelgen.spec",
               "modelgen.assemble", "modelgen.codegen", "modelgen.terms",
               "modelgen.locations"]
    for module in modules:
        page = site / "api" / Path(*module.split(".")).with_suffix(".html")
        assert page.exists(), f"no API page for {module}"
        text = page.read_text(encoding="utf-8")
        assert f'id="{module}"' in text, f"{module} not rendered by mkdocstrings"
    simulate = (site / "api" / "analysis" / "integrate" / "simulate.html").read_text("utf-8")
    assert "Integrate" in simulate and "initial_state" in simulate
    model = (site / "api" / "analysis" / "model.html").read_text("utf-8")
    for name in ("System", "Model", "GeneratedModel", "load_model"):
        assert f'id="analysis.model.{name}"' in model, f"analysis.model.{name} not shown"


@pytest.mark.needs_extra
def test_site_has_the_spec_guide_and_the_reference_from_the_schema(site):
    from modelgen.quantities import QUANTITIES
    from modelgen.terms import TERMS

    reference = (site / "spec-reference.html").read_text("utf-8")
    assert "bearingdyn:spec-reference" not in reference
    for name in [*TERMS, *QUANTITIES, "n_balls", "planar_tilt", "station", "initial"]:
        assert name in reference, f"spec reference: {name} not shown"
    guide = (site / "spec-guide.html").read_text("utf-8")
    assert "bearingdyn:include" not in guide
    assert "pedestal_cubic_stiffness" in guide  # the user model's spec, included
    assert (site / "examples" / "user-model" / "pedestal-rotor.toml").is_file()
    index = (site / "index.html").read_text("utf-8")
    assert 'href="spec-guide.html"' in index and 'href="spec-reference.html"' in index


@pytest.mark.needs_extra
def test_site_math_is_mathml_written_at_build_time(site):
    """No script renders the math (tests/test_docs_browser.py sees it typeset)."""
    html = (site / "model.html").read_text(encoding="utf-8")
    assert 'class="arithmatex"><math xmlns="http://www.w3.org/1998/Math/MathML"' in html
    assert "mathjax" not in html.lower() and "\\(" not in html


# --------------------------------------------------------------------------- sources


def _images(page: Path) -> list[tuple[int, str]]:
    text = page.read_text(encoding="utf-8")
    return [(m.start(), m.group(1) or m.group(2)) for m in IMAGE.finditer(text)]


def test_every_image_referenced_from_the_docs_exists():
    checked = 0
    for page in [*PAGES, *MODEL_CARDS]:
        for _, target in _images(page):
            if re.match(r"^[a-z]+:", target):
                continue
            path = (page.parent / target.split("#")[0]).resolve()
            assert path.is_file(), f"{_rel(page)}: image {target} does not exist"
            assert path.is_relative_to(DOCS), f"{_rel(page)}: image {target} is outside docs/"
            checked += 1
    assert checked > 0


def test_every_figure_follows_the_command_that_makes_it():
    """An image in a page comes after a code block that runs a `bearingdyn` command."""
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for start, target in _images(page):
            before = [body for lang, body, end in _fences(text) if end <= start
                      and lang in SHELL_LANGUAGES]
            assert any(_commands(body) for body in before), (
                f"{_rel(page)}: figure {target} is not preceded by the bearingdyn command "
                "that makes it")


def _fences(text: str) -> list[tuple[str, str, int]]:
    return [(m.group(1).lower(), m.group(2), m.end()) for m in FENCE.finditer(text)]


def _commands(body: str) -> list[list[str]]:
    """The `bearingdyn …` command lines of a shell code block, as token lists."""
    body = re.sub(r"\\\n\s*", " ", body)  # continued lines
    found = []
    for line in body.splitlines():
        line = line.strip().removeprefix("$ ")
        for part in re.split(r"&&|\|\||;", line):
            part = part.strip()
            if not part.startswith("bearingdyn"):
                continue
            try:
                tokens = shlex.split(part, comments=True)
            except ValueError:
                tokens = part.split("#", 1)[0].split()
            if tokens and tokens[0] == "bearingdyn":
                found.append(tokens[1:])
    return found


def _option_names(cmd) -> set[str]:
    names = {"--help"}
    for param in cmd.params:
        names.update(o for o in (*param.opts, *param.secondary_opts) if o.startswith("-"))
    return names


def _check_command(tokens: list[str], where: str) -> str | None:
    """None when ``bearingdyn <tokens>`` names a real command and real options."""
    global_options = _option_names(GROUP)
    while tokens and tokens[0] in global_options:
        tokens = tokens[1:]
    if not tokens or re.match(r"^[<…\[]|^\.\.\.", tokens[0]):
        return None  # `bearingdyn --debug <command> …`: a placeholder
    name, args = tokens[0], tokens[1:]
    if name not in COMMANDS:
        return f"{where}: `bearingdyn {name}` is not a command ({', '.join(COMMANDS)})"
    cmd = COMMANDS[name]
    while hasattr(cmd, "commands") and args and args[0] in cmd.commands:  # a group: record info
        cmd, args = cmd.commands[args[0]], args[1:]
    known = _option_names(cmd)
    for arg in args:
        for alt in arg.strip("[]").split("|"):
            alt = alt.strip("[]").split("=", 1)[0]
            if alt.startswith("-") and not re.match(r"^-\d|^-\.\d", alt) and alt not in known:
                return f"{where}: `bearingdyn {name}` has no option {alt}"
    return None


def test_every_quoted_bearingdyn_command_exists():
    """Every `bearingdyn …` in a shell code block or an inline code span of the docs (and the
    README) names a registered command, with options that command has."""
    errors, checked = [], 0
    for page in [*PAGES, ROOT / "README.md"]:
        if page.name == "bad-inputs.md":  # wrong on purpose; each was run by its own test
            continue
        text = page.read_text(encoding="utf-8")
        for lang, body, _ in _fences(text):
            if lang in SHELL_LANGUAGES:
                for tokens in _commands(body):
                    checked += 1
                    errors.append(_check_command(tokens, _rel(page)))
        prose = FENCE.sub("", text)
        for m in INLINE_COMMAND.finditer(prose):
            for tokens in _commands(m.group(1)):
                checked += 1
                errors.append(_check_command(tokens, _rel(page)))
    errors = [e for e in errors if e]
    assert not errors, "\n".join(errors)
    assert checked > 30


def test_command_checker_catches_wrong_commands_and_options():
    assert _check_command(["simulate", "m", "--n-balls", "6", "-o", "r.nc"], "t") is None
    assert _check_command(["--debug", "<command>", "…"], "t") is None
    assert _check_command(["spectrum", "r.nc", "[--json]", "[-o", "f.png]"], "t") is None
    assert _check_command(["continue", "m", "--from", "-3", "--to", "5"], "t") is None
    assert "not a command" in _check_command(["simulat", "m"], "t")
    assert "no option --n-ball" in _check_command(["simulate", "m", "--n-ball", "6"], "t")
    assert _check_command(["record", "info", "r.mat", "--fs", "12000"], "t") is None
    assert "no option --fz" in _check_command(["record", "info", "r.mat", "--fz", "1"], "t")


def test_guide_pages_name_existing_commands_and_show_their_options():
    guide = sorted((DOCS / "guide").glob("*.md"))
    assert (DOCS / "guide" / "index.md") in guide
    for page in guide:
        if page.stem == "index":
            continue
        assert page.stem in COMMANDS, f"{_rel(page)}: no command `bearingdyn {page.stem}`"
        text = page.read_text(encoding="utf-8")
        assert f"<!-- bearingdyn:options {page.stem} -->" in text, (
            f"{_rel(page)}: the options marker is missing")


def test_getting_started_quotes_the_readmes_two_commands():
    readme = [body.strip() for lang, body, _ in _fences((ROOT / "README.md").read_text())
              if lang == "bash"][:2]
    ours = [body.strip() for lang, body, _ in
            _fences((DOCS / "getting-started.md").read_text(encoding="utf-8")) if lang == "bash"]
    assert len(readme) == 2
    for command in readme:
        assert command in ours, f"getting-started.md does not quote {command!r}"


def test_ci_installs_the_docs_extra_and_builds_the_site_strictly_outside_the_tree():
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"pip install .*\[[\w,]*docs[\w,]*\]", ci)
    assert re.search(r"mkdocs build --strict\b.*--site-dir", ci)
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["docs"]
    assert any(d.startswith("mkdocs-material") for d in extra)
    assert any(d.startswith("mkdocstrings[python]") for d in extra)
    assert "site/" in (ROOT / ".gitignore").read_text().splitlines()
    assert not (DOCS / "models").exists()  # the model pages exist in the built site only


# --------------------------------------------------------------------------- pages that match


def _hooks():
    spec = importlib.util.spec_from_file_location("bearingdyn_docs_hooks", DOCS / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_spec_reference_in_the_repository_equals_the_schema():
    """docs/spec-reference.md is complete without a build: its generated part is what the
    schema gives now (`python3 docs/hooks.py spec-reference` rewrites it)."""
    from modelgen.quantities import QUANTITIES
    from modelgen.spec import Spec
    from modelgen.terms import TERMS

    hooks = _hooks()
    page = (DOCS / "spec-reference.md").read_text(encoding="utf-8")
    assert page == hooks.spec_reference_page(page), (
        "docs/spec-reference.md differs from the schema: run python3 docs/hooks.py "
        "spec-reference")
    body = page.split(hooks.SPEC_REFERENCE_BEGIN)[1].split(hooks.SPEC_REFERENCE_END)[0]
    for name in [*TERMS, *QUANTITIES, *Spec.model_fields]:
        assert name in body, f"spec reference: {name} not shown"
    # a hand edit of the generated part is not the schema's text: it would fail above
    edited = page.replace('kind = "hertz_contact"', 'kind = "hertz"')
    assert edited != page and hooks.spec_reference_page(edited) == page


GUIDE_PROSE_WORDS = 60
"""Words of text a guide page has beyond its code, headings and the command's own help."""


def _prose(text: str, help_text: str) -> list[str]:
    """The paragraphs of a guide page that are text for a reader: not code, not a heading,
    not a marker, not a paragraph of the command's help (``--help``) copied."""
    def plain(t: str) -> str:
        return " ".join(re.sub(r"[`*_]", "", t).split()).lower()

    text = re.sub(r"<!--.*?-->", "", FENCE.sub("", text), flags=re.S)
    help_plain = plain(help_text)
    return [p for p in (q.strip() for q in re.split(r"\n\s*\n", text))
            if p and not p.startswith("#") and plain(p) not in help_plain]


def test_every_command_has_a_guide_page():
    pages = {p.stem for p in (DOCS / "guide").glob("*.md")}
    missing = sorted(set(COMMANDS) - pages)
    assert not missing, f"no docs/guide/<command>.md for: {', '.join(missing)}"


def test_every_guide_page_has_text_beyond_its_help():
    pages = {p.stem: p for p in (DOCS / "guide").glob("*.md") if p.stem in COMMANDS}
    for name, page in sorted(pages.items()):
        words = sum(len(p.split()) for p in _prose(page.read_text(encoding="utf-8"),
                                                      COMMANDS[name].help or ""))
        assert words >= GUIDE_PROSE_WORDS, (
            f"{_rel(page)}: {words} words of text beyond the help and the examples "
            f"(at least {GUIDE_PROSE_WORDS})")


def test_prose_check_sees_a_page_of_help_only():
    help_text = COMMANDS["classify"].help
    page = (f"# `bearingdyn classify`\n\n{help_text}\n\n```bash\nbearingdyn classify r.nc\n"
            "```\n\n<!-- bearingdyn:options classify -->\n")
    assert _prose(page, help_text) == []


def _models_lines(text: str) -> dict[str, str]:
    """Model name: its line with the hash digits masked (a spec edit changes only those)."""
    return {line.split()[0]: re.sub(r"sha256 [0-9a-f]{12}", "sha256 …", line.rstrip())
            for line in text.strip().splitlines()}


def test_getting_started_and_the_models_page_show_todays_models(cli):
    res = cli("models", env={"BEARINGDYN_MODELS": ""})
    assert res.returncode == 0, res.stderr
    today = _models_lines(res.stdout)
    for page in (DOCS / "getting-started.md", DOCS / "guide" / "models.md"):
        text = page.read_text(encoding="utf-8")
        after = text.split("bearingdyn models\n```", 1)[1]
        shown = next(body for lang, body, _ in _fences(after) if lang == "text")
        assert _models_lines(shown) == today, f"{_rel(page)}: not today's `bearingdyn models`"


def test_wide_display_formulas_are_cut_where_a_line_may_break():
    """``docs/hooks.py`` cuts a display formula into pieces that wrap: before relations and
    binary + and −, after commas, never inside braces or ``\\left``…``\\right``; the pieces
    put together are the formula; an aligned environment gives its equations, row by row."""
    hooks = _hooks()
    tex = (r"M_R\ddot{x} = F_x - \sum_{i=1}^{N_b} Q_i\cos\theta_i, \quad "
           r"\delta_i = \left(x + y\right) - \frac{a - b}{2}")
    pieces = hooks.formula_pieces(tex)
    assert pieces == [r"M_R\ddot{x} = F_x", r"{}- \sum_{i=1}^{N_b} Q_i\cos\theta_i, \quad",
                      r"\delta_i = \left(x + y\right)", r"{}- \frac{a - b}{2}"]
    assert "".join(p.removeprefix("{}") for p in pieces).replace(" ", "") == \
        tex.replace(" ", "")
    assert hooks.formula_pieces(r"x = -1") == [r"x = -1"]  # a sign, not a break
    aligned = hooks.formula_pieces(r"\begin{aligned} a &= b, & c &= d, \\ e &= f \end{aligned}")
    assert aligned == [r"a = b, \quad", "c = d,", "\\\\", "e = f"]
    # a long formula breaks inside its parentheses and its long fractions
    long = r"Q = k \max\left(0, " + " + ".join(f"x_{{{k}}}" for k in range(40)) + r"\right)"
    assert len(hooks.formula_pieces(long)) > 30
    for piece in hooks.formula_pieces(long):
        assert piece.count("{") == piece.count("}")


@pytest.mark.needs_extra
def test_every_piece_of_a_cut_formula_is_a_formula_of_its_own():
    """Each piece that ``formula_pieces`` cuts converts to MathML alone (latex2mathml, the
    ``[docs]`` extra)."""
    require("latex2mathml", "docs")
    hooks = _hooks()
    long = r"Q = k \max\left(0, " + " + ".join(f"x_{{{k}}}" for k in range(40)) + r"\right)"
    pieces = hooks.formula_pieces(long)
    for piece in pieces:
        assert "<math" in hooks.tex_to_mathml(piece, display=True)
