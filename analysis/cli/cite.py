"""`bearingdyn cite`: how to cite a model (BibTeX or CITATION.cff)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from analysis.cli.common import ModelArgument, any_output, app, reports_errors


@app.command()
@reports_errors
def cite(
    model: ModelArgument,
    format: Annotated[str, typer.Option(
        "--format", help="bibtex (a @misc entry for the model, and the seed paper's when "
                         "the model is built on it) or cff (CITATION.cff, CFF 1.2.0).")
    ] = "bibtex",
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Write the citation to this file (default: print it).",
        callback=any_output)] = None,
):
    """The citation of a model: its title, spec path and SHA-256, the versions that
    generated its code and the paper its equations come from."""
    from analysis.cite import citation
    from analysis.io import atomic_write

    text = citation(model, format)  # type: ignore[arg-type]
    if output is None:
        typer.echo(text, nl=False)
        return
    atomic_write(output, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    typer.echo(f"wrote {output}")
