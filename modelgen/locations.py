"""Where specs and generated models live (standard library only: cheap to import).

- **Shipped specs**: ``modelgen/specs/NAME.toml``; their code is committed in the package's
  ``generated/``.
- **User specs**: any ``.toml`` path, and the specs in the folders of ``BEARINGDYN_MODELS``
  (a path list, ``os.pathsep``-separated), found by name like shipped ones (a shipped name
  wins). Their code is generated on first use into the user cache,
  ``$BEARINGDYN_CACHE/models`` (default ``platformdirs.user_cache_dir("bearingdyn")/models``),
  in a folder keyed by the spec's SHA-256 and its path, or into a folder the user names
  (``bearingdyn generate SPEC --out DIR``). Nothing of a user spec is ever written into the
  package.
"""

from __future__ import annotations

import hashlib
import os
from importlib import resources
from pathlib import Path

SPEC_DIR = "specs"
MODELS_ENV = "BEARINGDYN_MODELS"
CACHE_ENV = "BEARINGDYN_CACHE"
GENERATED_LAYOUT = "4"
"""Version of the generated code's layout; part of the cache key, so code cached by a
bearingdyn with another layout is never loaded (3: with a manifest of hashes; 4: the
runtime's ``derivative`` is public, so a cached root of layout 3, whose runtime names it
``_derivative``, is generated anew instead of failing in statics and tori)."""
MANIFEST = "MANIFEST.json"
"""The file of a generated root (user cache, ``generate --out``) that holds the SHA-256 of
every other file, checked when the root is loaded."""


def module_name(model: str) -> str:
    """The Python module (and C file) name of a model: '-' as '_', and ``model_`` before a
    name that starts with a digit (``6205-outer-defect`` -> ``model_6205_outer_defect``)."""
    module = model.replace("-", "_")
    return f"model_{module}" if module[:1].isdigit() else module


def shipped_spec_dir() -> Path:
    return Path(str(resources.files("modelgen") / SPEC_DIR))


def user_spec_dirs() -> list[Path]:
    """The folders of ``BEARINGDYN_MODELS``, in order (missing ones are skipped)."""
    text = os.environ.get(MODELS_ENV, "")
    return [Path(p).expanduser() for p in text.split(os.pathsep) if p.strip()]


def user_specs() -> dict[str, Path]:
    """Spec files of the ``BEARINGDYN_MODELS`` folders by model name (file stem); the first
    folder that has a name wins."""
    found: dict[str, Path] = {}
    for folder in user_spec_dirs():
        if folder.is_dir():
            for path in sorted(folder.glob("*.toml")):
                found.setdefault(path.stem, path.resolve())
    return found


def is_shipped(path: Path) -> bool:
    """Whether ``path`` is one of the package's own spec files."""
    try:
        return path.resolve().parent == shipped_spec_dir().resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symbolic link loop (Python < 3.13)
        return False


def cache_root() -> Path:
    """The user cache: ``$BEARINGDYN_CACHE`` or the platform's user cache folder."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("bearingdyn"))


def spec_digest(path: Path) -> str:
    """SHA-256 of the spec file's bytes (``sha256sum`` gives the same)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def cached_model_root(path: Path) -> Path:
    """The generated root of a user spec in the cache: keyed by the spec's SHA-256 and by its
    absolute path (the path is part of the provenance the generated header states) and by
    the layout of generated code."""
    resolved = path.resolve()
    key = f"{GENERATED_LAYOUT}\0{resolved}".encode()
    where = hashlib.sha256(key).hexdigest()[:8]
    return cache_root() / "models" / f"{resolved.stem}-{spec_digest(resolved)[:16]}-{where}"


def broken_link(path: Path) -> str | None:
    """How a path that cannot be opened is a broken symbolic link: 'is a symbolic link loop'
    or "is a symbolic link to 'TARGET', which does not exist"; None when it is not a link
    (then it simply does not exist, or it opens)."""
    import errno

    if not os.path.islink(path):
        return None
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "is a symbolic link loop (it leads back to itself)"
        return f"is a symbolic link to '{os.readlink(path)}', which does not exist"
    return None


def manifest_text(files: dict[str, str]) -> str:
    """The manifest of a generated root whose files (relative path -> text) are ``files``."""
    import json

    digests = {rel: hashlib.sha256(text.encode("utf-8")).hexdigest()
               for rel, text in sorted(files.items()) if rel != MANIFEST}
    return json.dumps({"layout": GENERATED_LAYOUT, "sha256": digests}, indent=1) + "\n"


def manifest_problem(root: Path) -> str | None:
    """What is wrong with the generated root ``root`` against its manifest (a file missing,
    changed or the manifest itself unreadable), in a few words; None when every file is as
    written."""
    import json

    try:
        digests = json.loads((root / MANIFEST).read_text())["sha256"]
    except FileNotFoundError:
        return f"no {MANIFEST}"
    except (OSError, ValueError, KeyError, TypeError):
        return f"{MANIFEST} is damaged"
    if not isinstance(digests, dict):
        return f"{MANIFEST} is damaged"
    for rel, digest in digests.items():
        try:
            data = (root / rel).read_bytes()
        except OSError:
            return f"{rel} is missing"
        if hashlib.sha256(data).hexdigest() != digest:
            return f"{rel} was changed (truncated or edited)"
    return None
