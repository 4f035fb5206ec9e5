"""The spec-writing guide and the spec reference: what they show is what the code does.

- the annotated spec of ``docs/spec-guide.md`` and the fragments added to it are valid specs;
- the validation messages the guide quotes are the ones the code gives, word for word;
- the worked user model (``docs/examples/user-model/``) is valid, runs by its path with its
  code in a private cache, and its results cite its resolved path and SHA-256 (the one the
  guide quotes);
- the spec reference, written at build time by ``docs/hooks.py``, has every field of every
  class of the schema (walked here independently of the hook) and every term and quantity,
  and every field has a description: a field added without a docstring fails here.
"""

from __future__ import annotations

import copy
import hashlib
import importlib.util
import re
import tomllib
import types
from pathlib import Path
from typing import Annotated, Union, get_args, get_origin

import pytest
from pydantic import BaseModel

from modelgen.errors import SpecError
from modelgen.quantities import QUANTITIES
from modelgen.spec import Spec, load_spec, parse_spec
from modelgen.terms import TERM_CLASSES, TERMS
from tests.conftest import ROOT

DOCS = ROOT / "docs"
GUIDE = DOCS / "spec-guide.md"
EXAMPLE = DOCS / "examples" / "user-model" / "pedestal-rotor.toml"
TOML_FENCE = re.compile(r"^```toml([^\n]*)\n(.*?)^```[ \t]*$", re.M | re.S)
TEXT_FENCE = re.compile(r"^```text[^\n]*\n(.*?)^```[ \t]*$", re.M | re.S)
ADDED = "# added to my-rotor.toml"


def _guide() -> str:
    return GUIDE.read_text(encoding="utf-8")


def _annotated() -> str:
    """The complete annotated spec of the guide (the fence titled my-rotor.toml)."""
    found = [body for attrs, body in TOML_FENCE.findall(_guide())
             if 'title="my-rotor.toml"' in attrs]
    assert len(found) == 1, "docs/spec-guide.md: one ```toml title=\"my-rotor.toml\" block"
    return found[0]


def _problems(data: dict) -> list[str]:
    with pytest.raises(SpecError) as info:
        parse_spec(data, "my-rotor.toml")
    return info.value.problems


# --------------------------------------------------------------------------- the guide


def test_the_annotated_spec_is_valid_and_has_a_comment_on_every_line():
    text = _annotated()
    spec = parse_spec(tomllib.loads(text), "my-rotor.toml")
    assert spec.model.name == "my-rotor"
    assert [b.name for b in spec.bearing_list()] == ["left", "right"]
    assert spec.state_names() == ("x", "y", "tx", "ty", "vx", "vy", "vtx", "vty")
    assert "radial_clearance_right" in spec.parameters
    for line in text.splitlines():
        if line.strip():
            assert "#" in line, f"annotated spec: no comment on the line {line!r}"


def test_the_annotated_spec_loads_from_its_file(tmp_path):
    path = tmp_path / "my-rotor.toml"
    path.write_text(_annotated(), encoding="utf-8")
    spec, found = load_spec(path)
    assert found == path and spec.n_balls == 8


def test_the_fragments_added_to_the_annotated_spec_are_valid():
    fragments = [body for _, body in TOML_FENCE.findall(_guide()) if body.startswith(ADDED)]
    assert fragments, f"docs/spec-guide.md: no ```toml block starting with {ADDED!r}"
    for fragment in fragments:
        spec = parse_spec(tomllib.loads(_annotated() + "\n" + fragment), "my-rotor.toml")
        assert any(t.kind == "expression" for t in spec.terms)


def test_the_validation_messages_the_guide_quotes_are_the_codes():
    base = tomllib.loads(_annotated())
    too_many = copy.deepcopy(base)
    too_many["bearings"][1]["n_balls"] = 20
    two = copy.deepcopy(base)
    two["parameters"]["radial_clearance_right"]["value"] = 2e-3
    two["terms"][1]["bearing"] = "rigth"
    quoted = "\n".join(TEXT_FENCE.findall(_guide()))
    for data, count in ((too_many, 1), (two, 2)):
        problems = _problems(data)
        assert len(problems) == count, problems
        for problem in problems:
            line = f"error: my-rotor.toml: {problem}"
            assert line in quoted, f"docs/spec-guide.md does not quote, as given:\n{line}"


def test_the_one_body_shape_is_what_the_guide_says():
    spec, _ = load_spec("vakharia2015")
    assert spec.bodies is None and spec.structure is not None
    assert [b.name for b in spec.body_list()] == ["rotor"]
    assert spec.body_list()[0].mass_parameter == "rotor_mass"
    assert [(b.name, b.inner, b.outer) for b in spec.bearing_list()] == [
        ("bearing", "rotor", "ground")]
    assert spec.state_names() == ("x", "y", "vx", "vy")


def test_the_state_names_the_guide_shows():
    rotor_housing, _ = load_spec("rotor-housing")
    names = ", ".join(rotor_housing.state_names())
    assert names in _guide()
    mathieu, _ = load_spec("mathieu")
    assert mathieu.state_names() == ("x", "vx")


# --------------------------------------------------------------------------- the user model


def test_the_worked_user_model_is_valid_and_kept_out_of_the_package():
    spec, path = load_spec(EXAMPLE)
    assert spec.model.name == EXAMPLE.stem
    assert path.resolve().is_relative_to(DOCS)
    assert {"x_pedestal", "vx_rotor"} <= set(spec.state_names())
    declared = [n for n, p in spec.parameters.items() if p.low is not None]
    assert "pedestal_cubic_stiffness" in declared
    assert "<!-- bearingdyn:include examples/user-model/pedestal-rotor.toml -->" in _guide()


def test_the_guide_quotes_the_user_models_sha256():
    digest = hashlib.sha256(EXAMPLE.read_bytes()).hexdigest()
    rel = EXAMPLE.relative_to(ROOT).as_posix()
    assert f"{digest}  {rel}" in _guide(), (
        f"docs/spec-guide.md: update the sha256sum output of {rel} to {digest}")
    assert f"spec_sha256 = {digest}" in _guide()


def test_the_user_model_runs_by_path_and_cites_its_file(tmp_path, monkeypatch):
    from analysis import simulate

    monkeypatch.setenv("BEARINGDYN_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("BEARINGDYN_MODELS", raising=False)
    ds = simulate(EXAMPLE, duration=0.02, transient=0)
    assert ds.attrs["model"] == "pedestal-rotor"
    assert Path(ds.attrs["spec_file"]) == EXAMPLE.resolve()
    assert ds.attrs["spec_sha256"] == hashlib.sha256(EXAMPLE.read_bytes()).hexdigest()
    assert float(abs(ds["x_pedestal"]).max()) > 0
    generated = list((tmp_path / "cache" / "models").iterdir())
    assert len(generated) == 1 and generated[0].name.startswith("pedestal-rotor-")
    assert not (ROOT / "generated" / "pedestal_rotor").exists()


# --------------------------------------------------------------------------- the reference


def _hooks():
    spec = importlib.util.spec_from_file_location("bearingdyn_docs_hooks", DOCS / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _schema_classes() -> list[type[BaseModel]]:
    """Every pydantic class a spec holds, walked from Spec (independently of the hook)."""
    found: list[type[BaseModel]] = []

    def models(annotation) -> list[type[BaseModel]]:
        origin = get_origin(annotation)
        if origin in (Annotated, Union, types.UnionType, list, dict):
            return [m for arg in get_args(annotation) for m in models(arg)]
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            return [annotation]
        return []

    def walk(cls: type[BaseModel]) -> None:
        if cls in found:
            return
        found.append(cls)
        for info in cls.model_fields.values():
            for sub in models(info.annotation):
                walk(sub)

    walk(Spec)
    return found


def _reference_sections(text: str) -> dict[str, str]:
    """Heading line -> the text under it up to the next heading."""
    parts = re.split(r"^(#{2,3} .*)$", text, flags=re.M)
    return {parts[i].strip(): parts[i + 1] for i in range(1, len(parts) - 1, 2)}


def test_the_reference_has_every_field_of_every_schema_class():
    hooks = _hooks()
    text = hooks.spec_reference_markdown()
    classes = _schema_classes()
    assert set(TERM_CLASSES) <= set(classes)
    assert [c for _, c in hooks.schema_sections()] == classes
    sections = _reference_sections(text)
    for cls in classes:
        owner = f"`{cls.__module__}.{cls.__name__}`"
        body = next((b for b in sections.values() if owner in b), None)
        assert body is not None, f"spec reference: no section for {owner}"
        rows = re.findall(r"^\| `(\w+)` \|", body, re.M)
        assert set(cls.model_fields) <= set(rows), (
            f"spec reference, {cls.__name__}: fields missing: "
            f"{sorted(set(cls.model_fields) - set(rows))}")


def test_every_schema_field_has_a_description():
    hooks = _hooks()
    missing = [f"{cls.__name__}.{name}" for cls in _schema_classes()
               for name in cls.model_fields if not hooks.field_description(cls, name)]
    assert not missing, (
        "fields without a description (write a docstring under the field in the code): "
        + ", ".join(missing))


def test_the_fallback_notes_are_for_real_fields_without_a_docstring():
    """A note in docs/hooks.py is only for a field whose class gives it no docstring: once
    the code documents the field, the note must go (so the two never disagree)."""
    hooks = _hooks()
    classes = _schema_classes()
    for key in hooks.FIELD_NOTES:
        cls_name, field = key.split(".")
        # a note for a base class ("Term.kind") is for the field in each class derived from it
        users = [c for c in classes if cls_name in {k.__name__ for k in c.__mro__}
                 and field in c.model_fields]
        assert users, f"FIELD_NOTES[{key!r}]: no such field"
        for cls in users:
            assert not (cls.model_fields[field].description
                        or hooks.attribute_docs(cls).get(field)), (
                f"FIELD_NOTES[{key!r}]: {cls.__name__} documents this field now; remove "
                "the note")
    assert set(hooks.TERM_ATTACH_NOTES) <= set(TERMS)


def test_the_reference_has_every_term_and_quantity():
    text = _hooks().spec_reference_markdown()
    for kind in TERMS:
        assert f'### `[[terms]] kind = "{kind}"`' in text
    for name, q in QUANTITIES.items():
        assert re.search(rf"^\| `{name}` \| `{re.escape(q.unit)}` \|", text, re.M), name


def test_the_reference_lists_the_choices_and_ranges():
    text = _hooks().spec_reference_markdown()
    assert '`"planar"`, `"linear"`, `"planar_tilt"`' in text
    assert "| `n_balls` | integer | **required** | [3, 64] |" in text
    assert "+ `hunt_crossley_damping`" in text
