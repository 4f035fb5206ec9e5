"""bearingdyn model generator: equation spec (TOML) -> SymPy equations -> CasADi code.

Nothing here is needed to *run* a generated model: ``generated/<model>/`` imports only
casadi and numpy.

``__version__`` is bearingdyn's one version (results, citations and generated code all
state it): the ``version`` of the source tree's ``pyproject.toml`` when this package runs
from a source tree, else the installed distribution's.
"""

from __future__ import annotations


def _version() -> str:
    """The version of bearingdyn: the source tree's pyproject.toml (when this package sits
    in one that names bearingdyn), else the installed metadata, else ``0+unknown``."""
    from pathlib import Path

    pyproject = Path(__file__).resolve().parent.parent / "pyproject.toml"
    if pyproject.is_file():
        import tomllib

        try:
            project = tomllib.loads(pyproject.read_text(encoding="utf-8")).get("project", {})
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            project = {}
        if project.get("name") == "bearingdyn" and isinstance(project.get("version"), str):
            return project["version"]
    from importlib import metadata

    try:
        return metadata.version("bearingdyn")
    except metadata.PackageNotFoundError:
        return "0+unknown"


__version__ = _version()
