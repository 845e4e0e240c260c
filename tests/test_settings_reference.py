"""docs/settings.md is what fem_bounce.settings_reference generates from the scene's and the numerics' field
metadata, so the reference cannot drift from the checks; and every field of every table is in it."""
from __future__ import annotations

import dataclasses
import typing
from pathlib import Path

from fem_bounce import numerics, scene, settings_reference

PAGE = Path(__file__).resolve().parents[1] / "docs" / "settings.md"


def scene_keys(cls: type = scene.Scene, prefix: str = "") -> list[str]:
    """Every dotted key of a scene, found by walking the dataclasses here (not by the module under test)."""
    keys = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        table = next((t for t in (hints[f.name], *typing.get_args(hints[f.name]))
                      if isinstance(t, type) and dataclasses.is_dataclass(t)), None)
        if f.name == "further_spheres":  # the second sphere's fields, under its table
            continue
        key = prefix + f.name
        keys += scene_keys(table, key + ".") if table is not None else [key]
    return keys


def test_the_committed_page_is_the_generated_one():
    assert PAGE.read_text() == settings_reference.markdown(), (
        "docs/settings.md is out of date: python -m fem_bounce.settings_reference > docs/settings.md")


def test_every_field_of_every_table_has_a_row():
    page = settings_reference.markdown()
    rows = {line.split("|")[1].strip().strip("`") for line in page.splitlines() if line.startswith("| `")}
    expected = set(scene_keys())
    assert expected - rows == set()
    assert rows - expected == set()
    for model in ("ode", "fd", "ib", "ale"):  # the numerics tables are walked, not listed by hand
        cls = getattr(numerics, f"{model.capitalize()}Numerics")
        assert {f"numerics.{model}.{f.name}" for f in dataclasses.fields(cls)} <= rows


def test_a_row_shows_the_metadata_the_checks_read():
    rows = {s.key: s for prefix, cls in settings_reference.tables() for s in settings_reference.settings(prefix, cls)}
    assert rows["liquid.viscosity"].allowed == "(0, 1e8]" and rows["liquid.viscosity"].unit == "Pa s"
    assert rows["sphere.poisson_ratio"].allowed == "(-1, 0.5)"
    assert rows["numerics.fd.cells_per_diameter"].default == "`8`"
    assert rows["numerics.fd.surface_refinement"].default == "`5`"
    assert rows["numerics.fd.mesh"].allowed == '`"moving"`, `"fixed"`'
    assert rows["numerics.fd.peak_cfl"].default == "unset" and rows["numerics.fd.peak_cfl"].allowed.endswith("unset")
    assert rows["initial_gap"].default == "required"
    assert "pitch" in rows["liquid.viscosity"].note  # the note of the range error
    assert rows["numerics.ib.cfl"].note.startswith("dt = cfl")  # a numerics field's comment
