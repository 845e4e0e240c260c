"""Uncertain properties: a scalar setting of a scene given as a range and a distribution instead of a value.

    --vary contact.dry_restitution=0.90:0.97       uniform on [0.90, 0.97]
    --vary sphere.roughness=1e-8:1e-6:log          log-uniform (in the magnitude; ends of one sign)
    --vary liquid.viscosity=0.0502~0.0035          normal, mean ~ standard deviation, cut at 3 standard deviations
    --vary liquid.viscosity=+-7%                   uniform within 7 % of the scene's own value
    --vary liquid.viscosity=~7%                    normal about the scene's value, standard deviation 7 % of it

The same texts go into a scene file's `[uncertain]` table, each a string or a table with `range` and `source`:

    [uncertain]
    "contact.dry_restitution" = "0.90:0.97"
    "liquid.viscosity" = { range = "+-7%", source = "+-1 K at 7 %/K" }

A range is checked against the setting's allowed interval (the scene's field metadata, docs/settings.md) and
refused, naming the setting and the interval, when any value it can give leaves it: the whole interval of a
uniform one, mean +- 3 standard deviations of a normal one (the normal is cut there, so that every sample is a
scene the checks admit, and the design's points map to finite values).  The packaged defaults
(fem_bounce/data/uncertain_defaults.toml) give the ranges of docs/usage.md with their sources.

A Range maps a point u of the unit interval (a design's coordinate) to the setting's value, so a design is built
once in [0, 1)^d and the same u gives the same scene on every machine.
"""
from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
import typing
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from . import scene as scenes
from .scene import SceneError

DISTRIBUTIONS = ("uniform", "log-uniform", "normal")
NORMAL_CUT = 3.0  # a normal range is cut at mean +- NORMAL_CUT standard deviations
SYNTAX = "LOW:HIGH, LOW:HIGH:log, MEAN~SD, +-P% or ~P% (docs/usage.md, Predictions with bands)"
DEFAULTS_FILE = "uncertain_defaults.toml"
# settings whose type admits words besides a number: their numeric interval, which the field metadata cannot hold
NUMERIC_INTERVALS = {"contact.cavitation_pressure": (scenes.CAVITATION_PRESSURE_MIN, 0.0, False, False)}


@dataclass(frozen=True)
class Range:
    """One uncertain setting: `key` (dotted), its distribution and its parameters in the setting's unit: `low`,
    `high` (uniform, log-uniform) or `mean`, `sd` (normal), and where the range comes from (`source`)."""

    key: str
    distribution: str
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    sd: float | None = None
    source: str = ""
    text: str = ""  # as given

    def value(self, u: float) -> float:
        """The setting's value at the design coordinate u in [0, 1]."""
        if self.distribution == "uniform":
            return self.low + u * (self.high - self.low)
        if self.distribution == "log-uniform":  # in the magnitude: a range of negative values too
            sign = math.copysign(1.0, self.low)
            a, b = math.log(abs(self.low)), math.log(abs(self.high))
            return sign * math.exp(a + u * (b - a))
        from scipy.stats import truncnorm

        return float(truncnorm.ppf(u, -NORMAL_CUT, NORMAL_CUT, loc=self.mean, scale=self.sd))

    @property
    def bounds(self) -> tuple[float, float]:
        """The smallest and largest value the range gives."""
        if self.distribution == "normal":
            return self.mean - NORMAL_CUT * self.sd, self.mean + NORMAL_CUT * self.sd
        return self.low, self.high

    def describe(self) -> str:
        if self.distribution == "normal":
            return f"{self.key} normal {self.mean:.4g} +- {self.sd:.3g} (cut at {NORMAL_CUT:g} sd)"
        return f"{self.key} {self.distribution} {self.low:.4g} to {self.high:.4g}"

    def as_dict(self) -> dict:
        return {k: v for k, v in dataclasses.asdict(self).items() if v is not None}


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_UNIFORM = re.compile(rf"({_NUMBER}):({_NUMBER})(?::(log|uniform))?")
_NORMAL = re.compile(rf"({_NUMBER})~({_NUMBER})(%?)")
_RELATIVE_UNIFORM = re.compile(rf"(?:\+-|±)({_NUMBER})%")
_RELATIVE_NORMAL = re.compile(rf"~({_NUMBER})%")


def parse(key: str, text: str, scene: scenes.Scene, source: str = "", what: str | None = None) -> Range:
    """The Range of `key` written as `text` (SYNTAX), relative forms taken against `scene`'s value, checked
    against the setting's allowed interval.  `what` names the input in a refusal (default "--vary KEY=TEXT")."""
    what = what or f"--vary {key}={text}"
    if not isinstance(text, str):
        raise SceneError(f"{what}: a range is a text such as \"0.90:0.97\" ({SYNTAX})")
    interval = allowed_interval(key, what)
    spec = text.strip().replace(" ", "")
    found: dict = {}
    if match := _UNIFORM.fullmatch(spec):
        low, high = float(match[1]), float(match[2])
        found = {"distribution": "log-uniform" if match[3] == "log" else "uniform", "low": low, "high": high}
    elif match := _NORMAL.fullmatch(spec):
        mean, sd = float(match[1]), float(match[2])
        found = {"distribution": "normal", "mean": mean, "sd": abs(mean) * sd / 100.0 if match[3] else sd}
    elif (match := _RELATIVE_UNIFORM.fullmatch(spec)) or (match := _RELATIVE_NORMAL.fullmatch(spec)):
        nominal = _nominal(scene, key, what)
        share = float(match[1]) / 100.0
        if match.re is _RELATIVE_UNIFORM:
            ends = sorted((nominal * (1.0 - share), nominal * (1.0 + share)))
            found = {"distribution": "uniform", "low": ends[0], "high": ends[1]}
        else:
            found = {"distribution": "normal", "mean": nominal, "sd": abs(nominal) * share}
    else:
        raise SceneError(f"{what}: cannot read the range {text!r}; write {SYNTAX}")
    numbers = [v for v in found.values() if isinstance(v, float)]
    if not all(math.isfinite(v) for v in numbers):
        raise SceneError(f"{what}: the range's numbers must be finite")
    if found["distribution"] == "normal":
        if not found["sd"] > 0.0:
            raise SceneError(f"{what}: the standard deviation must be > 0")
    elif not found["low"] < found["high"]:
        raise SceneError(f"{what}: LOW must be below HIGH (got {found['low']:g}:{found['high']:g})")
    if found["distribution"] == "log-uniform" and not found["low"] * found["high"] > 0.0:
        raise SceneError(f"{what}: a log-uniform range needs LOW and HIGH of one sign, neither 0 (got "
                         f"{found['low']:g}:{found['high']:g})")
    ranged = Range(key, source=source, text=text, **found)
    _check_inside(ranged, interval, what)
    return ranged


def allowed_interval(key: str, what: str = "") -> tuple:
    """(lo, hi, lo_open, hi_open) of a continuous scalar setting (hi None: no upper bound); SceneError for a key
    that is unknown or not a continuous number (a choice, a word, an integer, a table)."""
    what = what or key
    if key in NUMERIC_INTERVALS:
        return NUMERIC_INTERVALS[key]
    cls, f = scenes.Scene, None
    parts = key.split(".")
    for depth, part in enumerate(parts):
        fields = {g.name: g for g in dataclasses.fields(cls)}
        if part not in fields:
            near = difflib.get_close_matches(part, list(fields), n=1)
            prefix = ".".join(parts[:depth])
            hint = f"; did you mean {'.'.join([*parts[:depth], near[0]])}?" if near else ""
            raise SceneError(f"{what}: unknown setting {key}{hint}" + ("" if hint or not prefix else
                                                                      f" ({prefix} has {', '.join(fields)})"))
        f = fields[part]
        hint = typing.get_type_hints(cls)[part]
        table = hint if dataclasses.is_dataclass(hint) else next(
            (t for t in typing.get_args(hint) if dataclasses.is_dataclass(t)), None)
        if depth < len(parts) - 1:
            if table is None:
                raise SceneError(f"{what}: {'.'.join(parts[:depth + 1])} is a setting, not a table")
            cls = table
        elif table is not None:
            raise SceneError(f"{what}: {key} is a table; give one of its settings, e.g. {key}."
                             f"{dataclasses.fields(table)[0].name}")
    if "range" not in f.metadata:
        raise SceneError(f"{what}: {key} is not a number with a range (a choice or a text): it cannot be varied")
    if int in typing.get_args(typing.get_type_hints(cls)[parts[-1]]) or \
            typing.get_type_hints(cls)[parts[-1]] is int:
        raise SceneError(f"{what}: {key} is a whole number, not a continuous property: it cannot be varied")
    return f.metadata["range"]


def _nominal(scene: scenes.Scene, key: str, what: str) -> float:
    value = scene
    for part in key.split("."):
        value = getattr(value, part, None)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value == 0.0:
        raise SceneError(f"{what}: a range relative to the scene's value needs a nonzero number, and {scene.name}'s "
                         f"{key} is {value!r}: give LOW:HIGH or MEAN~SD")
    return float(value)


def _check_inside(ranged: Range, interval: tuple, what: str) -> None:
    lo, hi, lo_open, hi_open = interval
    low, high = ranged.bounds
    below = low <= lo if lo_open else low < lo
    above = hi is not None and (high >= hi if hi_open else high > hi)
    if below or above:
        spread = (f" (mean +- {NORMAL_CUT:g} standard deviations)" if ranged.distribution == "normal" else "")
        raise SceneError(f"{what}: the range [{low:.6g}, {high:.6g}]{spread} leaves the interval {ranged.key} "
                         f"allows ({scenes._allowed(lo, hi, lo_open, hi_open)}; docs/settings.md)")


# -- where ranges come from ------------------------------------------------------------------


def parse_vary(text: str) -> tuple[str, str]:
    """'KEY=RANGE' -> (KEY, RANGE), as --vary takes it."""
    if not isinstance(text, str):
        raise SceneError(f"--vary {text!r}: expected a text KEY=RANGE, e.g. contact.dry_restitution=0.90:0.97")
    key, sep, spec = text.partition("=")
    if not sep or not key.strip() or not spec.strip():
        raise SceneError(f"--vary {text!r}: expected KEY=RANGE ({SYNTAX}), e.g. contact.dry_restitution=0.90:0.97")
    return key.strip(), spec.strip()


def _entries(table, where: str) -> dict[str, tuple[str, str, tuple | None]]:
    """{key: (range text, source, contact models or None)} from an [uncertain] table."""
    if not isinstance(table, dict):
        raise SceneError(f"{where}: [uncertain] must be a table of \"KEY\" = \"RANGE\"")
    found = {}
    for key, entry in table.items():
        if isinstance(entry, dict) and all(isinstance(v, dict) for v in entry.values()) and entry:
            # TOML reads [uncertain.contact.dry_restitution] (unquoted) as nested tables
            raise SceneError(f"{where}: [uncertain.{key}...]: quote the dotted key, [uncertain.\"{key}....\"]")
        if isinstance(entry, str):
            found[key] = (entry, "", None)
        elif isinstance(entry, dict) and isinstance(entry.get("range"), str):
            unknown = set(entry) - {"range", "source", "contact_models"}
            if unknown:
                raise SceneError(f"{where}: uncertain.{key} has unknown entries {', '.join(sorted(unknown))} "
                                 "(known: range, source, contact_models)")
            models = entry.get("contact_models")
            found[key] = (entry["range"], str(entry.get("source", "")), tuple(models) if models else None)
        else:
            raise SceneError(f"{where}: uncertain.{key} must be a range text or a table with range = \"...\"")
    return found


def default_entries() -> dict[str, tuple[str, str, tuple | None]]:
    """The packaged default ranges, {key: (range text, source, contact models or None)}."""
    text = (resources.files("fem_bounce") / "data" / DEFAULTS_FILE).read_text()
    return _entries(tomllib.loads(text)["uncertain"], f"fem_bounce/data/{DEFAULTS_FILE}")


def scene_table(source: str | Path) -> dict | None:
    """The `[uncertain]` table of a scene file (None for a preset or a file without one)."""
    path = Path(source)
    if not (path.suffix == ".toml" or path.exists()):
        return None
    try:
        data = tomllib.loads(scenes.read_scene_file(path))
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{source}: not valid TOML ({err})") from None
    return data.get("uncertain")


def ranges_for(scene: scenes.Scene, vary=(), table: dict | None = None, defaults: bool = True,
               where: str = "[uncertain]") -> list[Range]:
    """The uncertain settings of a band study on `scene`: the scene file's [uncertain] `table` when it has one,
    else (with `defaults`) the packaged defaults that act in the scene's contact model and apply to it (a wall's
    settings need a wall); each --vary text of `vary` adds a setting or replaces its range.  Checked (parse)."""
    chosen: dict[str, Range] = {}
    if table is not None:
        for key, (text, source, _) in _entries(table, where).items():
            chosen[key] = parse(key, text, scene, source, what=f"{where} {key} = {text!r}")
    elif defaults:
        for key, (text, source, models) in default_entries().items():
            if models is not None and scene.contact.model not in models:
                continue
            if key.startswith("wall.") and not scene.wall.present:
                continue
            chosen[key] = parse(key, text, scene, source, what=f"the default range {key} = {text!r}")
    for item in vary:
        key, text = parse_vary(item)
        chosen[key] = parse(key, text, scene, "--vary")
    if not chosen:
        raise SceneError("no uncertain setting: give --vary KEY=RANGE, an [uncertain] table, or keep the defaults")
    return list(chosen.values())


def rebase(ranges: list[Range], scene: scenes.Scene) -> list[Range]:
    """The same ranges for another scene: the relative ones (+-P%, ~P%) taken against its values (the restitution
    band's material sets), the absolute ones as they are; each checked again."""
    return [parse(r.key, r.text, scene, r.source, what=f"{r.key} = {r.text!r} on {scene.name}")
            if r.text.strip().startswith(("+-", "±", "~")) else r for r in ranges]


def sample_scene(scene: scenes.Scene, ranges: list[Range], point, name: str | None = None) -> scenes.Scene:
    """`scene` with each range's setting at its value for the design point (coordinates in [0, 1])."""
    changes = {r.key: r.value(float(u)) for r, u in zip(ranges, point)}
    try:
        return scene.replace(**changes, **({"name": name} if name else {}))
    except SceneError as err:
        values = ", ".join(f"{k} = {v:.6g}" for k, v in changes.items())
        raise SceneError(f"a sample of the band ({values}) is refused by the scene's checks: {err}; narrow the "
                         "ranges") from None
