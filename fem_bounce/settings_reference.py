"""The reference of every scene setting, generated from the dataclasses that check them.

Each field of the scene (fem_bounce.scene) and of its numerics tables (fem_bounce.numerics) declares its
default, its allowed range or choices and its unit in its field metadata, the same metadata a scene's checks
read for their one-line errors; its meaning is the metadata's `note`, else the field's entry in its class's
docstring (`name: text`), else the comments above and beside it in the source.  `markdown()` builds the page
from those, table by table, so the reference cannot drift from the checks: docs/settings.md is its output,
and tests/test_settings_reference.py fails when the two differ.  Regenerate the page with

    python -m fem_bounce.settings_reference > docs/settings.md
"""
from __future__ import annotations

import dataclasses
import inspect
import io
import re
import textwrap
import tokenize
import typing
from collections.abc import Iterator
from typing import Any

from . import scene

HEADER = """# Settings reference

Every key a scene file can set, table by table: its default, what it may be, its unit and what it means.
Generated from the field metadata of `fem_bounce/scene.py` and `fem_bounce/numerics.py` (the ranges the
checks enforce on load) by `fem_bounce.settings_reference.markdown()`; do not edit by hand, regenerate with
`python -m fem_bounce.settings_reference > docs/settings.md` (tests/test_settings_reference.py checks that this
page is up to date). How to write a scene and set a key from the command line or Python:
[usage.md](usage.md#scenes).

Keys of a table are written `table.key` on the command line (`--set numerics.fd.peak_cfl=0.4`) and as `key = value`
under `[table]` in a scene file; "required" has no default; "unset" leaves the value to the model (the note says
which). Ranges: `[a, b]` includes both ends, `(a, b)` excludes them."""

TITLES = {
    "": "The scene itself (top level)",
    "sphere": "The sphere (`[sphere]`)",
    "liquid": "The liquid (`[liquid]`)",
    "wall": "The wall (`[wall]`)",
    "container": "The container (`[container]`)",
    "contact": "The contact and the near-wall force (`[contact]`)",
    "motion": "How the sphere moves (`[motion]`)",
    "run": "How long a run lasts (`[run]`)",
    "reference": "Measured values to compare with (`[reference]`)",
    "second_sphere": "A second sphere above the first (`[second_sphere]`, and each `[[further_spheres]]`)",
    "numerics.ode": "The ode model (`[numerics.ode]`)",
    "numerics.fd": "The fd model (`[numerics.fd]`)",
    "numerics.ib": "The ib model (`[numerics.ib]`)",
    "numerics.ale": "The ale model (`[numerics.ale]`)",
}


@dataclasses.dataclass(frozen=True)
class Setting:
    """One key of a scene table, as the reference shows it."""

    key: str  # dotted from the scene's top: "numerics.fd.peak_cfl"
    default: str
    allowed: str
    unit: str
    note: str


def tables() -> list[tuple[str, type]]:
    """(dotted table name, dataclass) of every table of a scene, the top level first ("").  The spheres above
    the second ([[further_spheres]]) have the second sphere's fields and share its table."""
    found: list[tuple[str, type]] = []

    def walk(prefix: str, cls: type) -> None:
        found.append((prefix, cls))
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            sub = _table_type(hints[f.name])
            if sub is not None and f.name != "further_spheres":
                walk(f"{prefix}.{f.name}" if prefix else f.name, sub)

    walk("", scene.Scene)
    return sorted(found, key=lambda table: table[0].startswith("numerics"))  # the physics first, then the models


def settings(prefix: str, cls: type) -> list[Setting]:
    """The keys of one table (its sub-tables are tables of their own)."""
    hints = typing.get_type_hints(cls)
    doc_notes = _docstring_notes(cls)
    rows = []
    for f in dataclasses.fields(cls):
        hint = hints[f.name]
        if _table_type(hint) is not None:
            continue
        note = (f.metadata.get("note") or doc_notes.get(f.name)
                or _comment_notes(_defining_class(cls, f.name)).get(f.name, ""))
        rows.append(Setting(key=f"{prefix}.{f.name}" if prefix else f.name, default=_default(f),
                            allowed=_allowed(f, hint), unit=f.metadata.get("unit", ""), note=note))
    return rows


def markdown() -> str:
    """The settings reference as Markdown (docs/settings.md)."""
    parts = [HEADER]
    for prefix, cls in tables():
        rows = settings(prefix, cls)
        if not rows:
            continue
        parts.append(f"## {TITLES.get(prefix, f'`[{prefix}]`')}")
        intro = _first_paragraph(cls)
        if intro:
            parts.append(intro)
        lines = ["| key | default | allowed | unit | note |", "|---|---|---|---|---|"]
        lines += [f"| `{_cell(row.key)}` | {_cell(row.default)} | {_cell(row.allowed)} | {_cell(row.unit)} | "
                  f"{_cell(row.note)} |" for row in rows]
        parts.append("\n".join(lines))
        unread = _unread_list(prefix)
        if unread:
            parts.append(unread)
    return "\n\n".join(parts) + "\n"


def _unread_list(prefix: str) -> str:
    """The settings of a numerics table that a mode of its model reads nowhere (models/unread.py RULES), refused when
    set away from their defaults; "" for a table without any."""
    from .models.unread import RULES

    model = prefix.removeprefix("numerics.")
    rules = RULES.get(model, ()) if prefix.startswith("numerics.") else ()
    if not rules:
        return ""
    items = [f"- {rule.mode}: " + ", ".join(f"`{name}`" for name in rule.names) for rule in rules]
    return ("Read nowhere, and so refused when set away from its default, in these modes (a one-line error saying "
            "what to set instead; `fem_bounce/models/unread.py`):\n\n" + "\n".join(items))


# -- reading the dataclasses -----------------------------------------------------------------------


def _table_type(hint: Any) -> type | None:
    """The dataclass a field's type holds (a table, an optional table or a tuple of tables), else None."""
    if dataclasses.is_dataclass(hint):
        return hint
    for arg in typing.get_args(hint):
        if isinstance(arg, type) and dataclasses.is_dataclass(arg):
            return arg
    return None


def _default(f: dataclasses.Field) -> str:
    if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
        return "required"
    value = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    return "unset" if value is None else f"`{_toml(value)}`"


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, float):
        return _number(value)
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return str(value)


def _number(value: float) -> str:
    """A bound or default as a scene file would write it: 1e-06 as 1e-6, 1e+13 as 1e13."""
    return re.sub(r"e([+-])0*(\d)", lambda m: "e" + m.group(1).replace("+", "") + m.group(2), f"{value:g}")


def _allowed(f: dataclasses.Field, hint: Any) -> str:
    meta = f.metadata
    optional = "unset" if type(None) in typing.get_args(hint) else ""
    if "choices" in meta:
        text = ", ".join(f'`"{c}"`' for c in meta["choices"])
    elif "allowed" in meta:
        text = meta["allowed"]
    elif "range" in meta:
        lo, hi, lo_open, hi_open = meta["range"]
        if hi is None:
            text = f"{'>' if lo_open else '>='} {_number(lo)}"
        else:
            text = f"{'(' if lo_open else '['}{_number(lo)}, {_number(hi)}{')' if hi_open else ']'}"
    else:
        kinds = [arg for arg in (typing.get_args(hint) or (hint,)) if arg is not type(None)]
        text = " or ".join({bool: "true, false", str: "text", int: "integer", float: "number"}.get(
            typing.get_origin(k) or k, "a list of tables") for k in kinds)
    return f"{text}; {optional}" if optional and "choices" not in meta else text


def _defining_class(cls: type, name: str) -> type:
    """The class of cls's method resolution order whose body declares the field `name`."""
    for base in cls.__mro__:
        if name in base.__dict__.get("__annotations__", {}):
            return base
    return cls


def _first_paragraph(cls: type) -> str:
    """The class docstring's opening paragraph (before any `name: text` entries), on one line."""
    doc = cls.__dict__.get("__doc__") or ""
    if not doc or doc.startswith(f"{cls.__name__}("):  # the dataclass's generated signature
        return ""
    paragraph = inspect.cleandoc(doc).split("\n\n")[0]
    return " ".join(paragraph.split())


_ENTRY = re.compile(r"^([a-z_][a-z0-9_]*): (.*)$")


def _docstring_notes(cls: type) -> dict[str, str]:
    """{field: text} from the docstring's entries `field: text` (continued on lines indented further)."""
    doc = cls.__dict__.get("__doc__") or ""
    names = {f.name for f in dataclasses.fields(cls)}
    notes: dict[str, list[str]] = {}
    current = None
    for line in inspect.cleandoc(doc).splitlines():
        match = _ENTRY.match(line)
        if match and match.group(1) in names:
            current = match.group(1)
            notes[current] = [match.group(2)]
        elif current and line.startswith((" ", "\t")) and line.strip():
            notes[current].append(line.strip())
        else:
            current = None
    return {name: " ".join(words) for name, words in notes.items()}


def _comment_notes(cls: type) -> dict[str, str]:
    """{field: text} from the source's comments: the block of comment lines just above a field, then the comment
    after it on its line."""
    try:
        source = textwrap.dedent(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    names = set(cls.__dict__.get("__annotations__", {}))
    notes: dict[str, str] = {}
    block: list[str] = []
    for line_tokens in _logical_lines(source):
        first = line_tokens[0]
        if first.type == tokenize.COMMENT:
            block.append(first.string.lstrip("#").strip())
            continue
        comments = [tok.string.lstrip("#").strip() for tok in line_tokens if tok.type == tokenize.COMMENT]
        if first.type == tokenize.NAME and first.string in names and len(line_tokens) > 1 and \
                line_tokens[1].string == ":":
            text = "; ".join(part for part in (" ".join(block), " ".join(comments)) if part)
            if text:  # a comment that opens with the field's name says it once
                notes[first.string] = text.removeprefix(f"{first.string}: ")
        block = []
    return notes


def _logical_lines(source: str) -> Iterator[list[tokenize.TokenInfo]]:
    """The source's tokens grouped by line, a comment line on its own counting as one (indentation and blank
    lines dropped); a statement over several lines is one group."""
    group: list[tokenize.TokenInfo] = []
    skip = {tokenize.INDENT, tokenize.DEDENT, tokenize.NL, tokenize.ENCODING, tokenize.ENDMARKER}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.NEWLINE:
            if group:
                yield group
            group = []
        elif tok.type == tokenize.COMMENT and not group:
            yield [tok]
        elif tok.type not in skip:
            group.append(tok)
    if group:
        yield group


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


if __name__ == "__main__":
    print(markdown(), end="")
