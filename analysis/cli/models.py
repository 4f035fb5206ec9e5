"""`bearingdyn generate` and `bearingdyn models`: code from specs, and the list of models."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import (
    app,
    check_out_dir,
    reports_errors,
)
from analysis.errors import BearingdynError


@app.command()
@reports_errors
def generate(
    specs: Annotated[list[str] | None, typer.Argument(
        help="Spec names (shipped or in BEARINGDYN_MODELS) or .toml paths (default: every "
             "shipped spec).")] = None,
    check: Annotated[bool, typer.Option(
        "--check", help="Only compare; exit 1 when the generated code is stale.")] = False,
    out: Annotated[Path | None, typer.Option(
        help="Folder to write a loadable model into (give it to any command in place of a "
             "model name). Default: generated/ for shipped specs, the user cache for others "
             "(never the package).")] = None,
):
    """Generate a model's code from its equation spec (deterministic).

    Shipped specs go to the package's generated/; any other spec goes to the user cache
    (where `bearingdyn simulate SPEC.toml` finds it), or to --out DIR.
    """
    from modelgen.locations import cached_model_root, is_shipped
    from modelgen.spec import load_spec, shipped_spec_names

    names = specs or shipped_spec_names()
    if out is not None:
        check_out_dir(out, "--out")
    paths = [load_spec(name)[1] for name in names]  # every spec judged before SymPy loads
    from modelgen.codegen import default_root
    from modelgen.codegen import generate as run_generate

    changed = run_generate(names, root=out, check=check)
    targets: dict[Path, list[str]] = {}
    for name, path in zip(names, paths, strict=True):
        target = out if out is not None else (
            default_root() if is_shipped(path) else cached_model_root(path))
        targets.setdefault(Path(target), []).append(str(name))
    if check:
        _say_checked(changed, targets, default_root())
    else:
        _say_written(changed, targets, default_root(), out)


def _say_checked(changed: list[str], targets: dict[Path, list[str]], package: Path) -> None:
    """`generate --check`: the stale files (exit code 1), or where the code matches."""
    if changed:
        typer.echo("stale generated files (run `bearingdyn generate`):\n  "
                   + "\n  ".join(changed), err=True)
        raise typer.Exit(1)
    inside = [n for t, ns in targets.items() if t == package for n in ns]
    if inside:
        typer.echo(f"generated/ matches its specs ({', '.join(inside)})")
    for target, ns in targets.items():
        if target != package:
            typer.echo(f"{target} matches its specs ({', '.join(ns)})")


def _say_written(changed: list[str], targets: dict[Path, list[str]], package: Path,
                 out: Path | None) -> None:
    """`generate`: the files written, and where each model went."""
    typer.echo(f"wrote {len(changed)} file(s)" + (": " + ", ".join(changed) if changed
                                                 else " (all up to date)"))
    for target, ns in targets.items():
        if target == package:
            typer.echo(f"{', '.join(ns)}: in the package's generated/")
        elif out is not None:
            typer.echo(f"{', '.join(ns)}: in {target.resolve()} (load it by giving that folder "
                       "as the model, e.g. `bearingdyn simulate " + str(target) + " -o run.nc`)")
        else:
            typer.echo(f"{', '.join(ns)}: in the user cache, {target} (commands given the "
                       "spec's path or name load it from there)")


@app.command()
@reports_errors
def models():
    """List the shipped models and the specs in BEARINGDYN_MODELS folders: origin, state
    size n, bearings with their default balls, spec hash and title (and a spec that has a
    shipped model's name, whose name is then refused, as shadowed)."""
    import warnings

    from analysis.model import (
        available_models,
        load_model,
        model_origin,
        shadowed_specs,
        shipped_spec,
        shown_path,
    )
    from modelgen.errors import SpecError

    shadowed = shadowed_specs()
    for name in available_models():
        origin = model_origin(name)
        try:  # a shadowed name: the shipped model, by its spec's path
            with warnings.catch_warnings():  # a shadowed spec: said in its own line below
                warnings.filterwarnings("ignore", message=".*has the name of the shipped")
                m = load_model(shipped_spec(name) if name in shadowed else name)
        except (BearingdynError, SpecError) as exc:
            typer.echo(f"{name:26s} {origin}: cannot load ({exc})")
            continue
        bearings = ", ".join(f"{b.name} {b.default_n_balls} balls" for b in m.bearings) \
            or "no bearings"
        typer.echo(f"{name:26s} {origin:8s} n = {m.n_state:2d}  {bearings:30s} "
                   f"sha256 {m.spec_sha256[:12]}  {m.module.TITLE}")
        if name in shadowed:
            typer.echo(f"{'':26s} shadowed: {shown_path(shadowed[name])} has this name too, so "
                       f"'{name}' is refused; rename that spec (model.name and the file) "
                       "or give its .toml path")
