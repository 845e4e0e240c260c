"""Every `fem-bounce ...` command quoted in README.md and docs/*.md is accepted: what the docs tell a user to run,
runs.

What is quoted is found, not listed: the code spans of the prose (a span may run over a line break) and the shell
code blocks, fenced (sh, bash, console, none) or indented, with their continuation lines (`\\`) joined and their
comments, redirections and launchers (`mpiexec -n 2`, `python -m mpi4py.futures -m fem_bounce`, `nohup`) dropped.
`make` and `python script.py` lines are not fem-bounce commands and are not looked at.

Each command is then

- parsed by the command's own parser (`fem_bounce.cli._parser`), nothing run: an unknown option or choice fails;
- checked as the command checks it before it runs: its scene loaded with its `--set` values through the package's
  loader (an unknown key or an out-of-range value fails), its models known and able to run the scene, a study's
  levels, sweeps, angles, ranges (`--vary`) and design, the restitution sweep's `--set` values on each of its sets;
- and a representative few (RUNS) are run at toy size (a short run.end_time, few cells per diameter, two points,
  no figures) into a temporary directory, so that the whole file stays within about a minute of one core.

Synopses (`fem-bounce study convergence SCENE --model M [--levels ...]`) are checked with their placeholders
replaced by a value of the kind they name (PLACEHOLDERS) and their optional parts included.  A quoted command that
cannot be checked is in SKIPPED with the reason; a SKIPPED or RUNS entry no longer quoted anywhere fails, so neither
list goes stale.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import shlex
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import pytest

from fem_bounce import api, cli, models, uncertain
from fem_bounce import scene as scenes
from fem_bounce.errors import Error
from helpers import ALE_PLAIN_OPTIONS

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SHELL_FENCES = {"", "sh", "bash", "shell", "console"}
PROGRAM = "fem-bounce"
ENDS = {">", ">>", "|", "||", "&&", ";", "&", "2>", "2>&1", "<"}  # what ends a command on a shell line

# A synopsis's placeholders, and what each is replaced with to check it (word by word: numerics.M.cells becomes
# numerics.fd.cells)
PLACEHOLDERS = {"SCENE": "li2011-case3", "M": "fd", "MODEL": "fd", "N": "8", "DIR": "runs/li2011-case3-fd"}

# Quoted, but not a command that can be checked: the text as quoted (whitespace runs as one space) -> why
SKIPPED = {
    "fem-bounce study speed-accuracy li2011-case3 ...": "elided in the prose (README's validation table); "
                                                       "docs/performance.md quotes it whole",
    "fem-bounce run --accuracy": "names the option in a sentence (its value is the sentence's next words)",
    "fem-bounce scenes show": "names the subcommand in a sentence (fb.save's description)",
    "fem-bounce study band": "names the command in a sentence (fb.band's description)",
}

# Toy sizes: a few cells per diameter, a run 20 ms long (the sphere does not reach the wall: the command's path is
# what is run, not the physics), one process (the machine's cores are the other tests'; --jobs is
# test_study_runner's)
TOY_END = ["--set", "run.end_time=0.02"]
TOY_CELLS = {"fd": ["--set", "numerics.fd.cells_per_diameter=4"], "ib": ["--set", "numerics.ib.cells_per_diameter=8"],
             "ale": ["--set", "numerics.ale.cells_per_diameter=4", *ALE_PLAIN_OPTIONS]}
ONE_CORE = ["--jobs", "1"]
SWEEP = ["--points", "2", "--st-min", "100", "--st-max", "200"]  # two Stokes numbers, none of the low-St extras

# The quoted commands that are run, as quoted (whitespace runs as one space), and what is added to make them toys
# (argparse takes an option's last value, so `--points 2` after a quoted `--points 24` wins).  One of each path:
# the scene list and dump, a whole ode run into its documented directory, a pair, a scene file, the fd model's run
# and its restart (test_a_documented_run_restarts), the comparison of every flow model, the restitution sweep and
# its band, the oblique and band studies.
RUNS = {
    "fem-bounce scenes": [],
    "fem-bounce scenes show li2011-case3": [],
    "fem-bounce run li2011-case3 --model ode --no-plots": ["--quiet"],
    "fem-bounce run yang-hunt2006-pair --model ode": ["--quiet", "--no-plots"],
    "fem-bounce run my.toml --model fd --set run.bounces=2": [*TOY_END, *TOY_CELLS["fd"], "--quiet", "--no-plots",
                                                              "--set", "numerics.fd.checkpoint_every=5"],
    "fem-bounce compare li2011-case3 --models ode,fd,ib,ale": [*TOY_END, *TOY_CELLS["fd"], *TOY_CELLS["ib"],
                                                               *TOY_CELLS["ale"], "--quiet", "--no-plots"],
    "fem-bounce restitution --jobs 2": [*SWEEP, *ONE_CORE],
    "fem-bounce restitution --band --points 24 --samples 32 --jobs 2": [*SWEEP, "--samples", "2", *ONE_CORE],
    "fem-bounce study oblique foerster1994-glass --jobs 2": ["--angles", "20,60", *ONE_CORE],
    "fem-bounce study band li2011-case3 --model ode --vary liquid.viscosity=+-3% --vary sphere.density=7700:7850":
        ["--samples", "4"],
}
RESTARTED = ("fem-bounce run my.toml --model fd --set run.bounces=2", "fem-bounce run --restart runs/li2011-case3-fd")

# Files a quoted command names that the docs tell the reader to make, and the command that makes them
MADE_BY_THE_DOCS = {"my.toml": ("fem-bounce scenes show li2011-case3", "li2011-case3")}  # `... > my.toml`


@dataclass(frozen=True)
class Quoted:
    where: str  # "docs/usage.md:46"
    text: str  # as quoted, from `fem-bounce` on, on one line
    argv: tuple[str, ...]  # the arguments after `fem-bounce`
    synopsis: bool = False  # it has placeholders (replaced in argv) or optional [parts] (included)
    launcher: str = ""  # what came before fem-bounce (mpiexec -n 2, ...)


def _spans(paragraph: str):
    """The code spans of a paragraph of Markdown, each with its offset (a span may run over a line break)."""
    for found in re.finditer(r"(?<!`)(`+)(?!`)(.+?)(?<!`)\1(?!`)", paragraph, re.S):
        yield found.start(), found.group(2)


def _command(tokens: list[str]) -> tuple[str, list[str]] | None:
    """(the launcher, the arguments) of a shell line's words that run fem-bounce, or None: fem-bounce is the command
    word, after launchers (VAR=value, nohup, time, mpiexec/mpirun and their options) or as `python ... -m
    fem_bounce` (`python -m mpi4py.futures -m fem_bounce`)."""
    k = 0
    while k < len(tokens):
        word = tokens[k]
        if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*=\S*", word) or word in ("nohup", "time"):
            k += 1
        elif Path(word).name in ("mpiexec", "mpirun"):
            k += 1
            while k < len(tokens) and tokens[k].startswith("-"):
                k += 2 if tokens[k] in ("-n", "-np", "-host", "-hosts", "-f") else 1
        elif re.fullmatch(r"python[0-9.]*", Path(word).name):
            later = [j for j in range(k + 1, len(tokens) - 1) if tokens[j] == "-m" and tokens[j + 1] == "fem_bounce"]
            if not later:
                return None
            k = later[0] + 1
            break
        elif word == PROGRAM or word.endswith("/" + PROGRAM):
            break
        else:
            return None
    if k >= len(tokens):
        return None
    rest = tokens[k + 1:]
    end = next((j for j, w in enumerate(rest) if w in ENDS), len(rest))
    return " ".join(tokens[:k]), rest[:end]


def _synopsis(argv: list[str]) -> tuple[list[str], bool]:
    """A synopsis's arguments as a command: [optional] parts kept, each placeholder replaced (PLACEHOLDERS; the
    oblique study's SCENE by a launched scene)."""
    changed = False
    out = []
    values = PLACEHOLDERS | ({"SCENE": "foerster1994-glass"} if argv[:2] == ["study", "oblique"] else {})
    for word in argv:
        plain = word.strip("[]")
        plain = re.sub(r"\b[A-Z][A-Z0-9]*\b", lambda m: values.get(m.group(0), m.group(0)), plain)
        changed |= plain != word
        out.append(plain)
    return out, changed


def _quoted(text: str, where: str, launcher: str, argv: list[str]) -> Quoted:
    args, synopsis = _synopsis(argv)
    return Quoted(where, " ".join([PROGRAM, *argv]) if not text else text, tuple(args), synopsis, launcher)


def _shell_line(line: str, where: str) -> Quoted | None:
    try:
        tokens = shlex.split(line, comments=True)
    except ValueError:
        return None
    found = _command(tokens)
    if found is None:
        return None
    launcher, argv = found
    return _quoted("", where, launcher, argv)


def quoted_commands(documents=DOCUMENTS) -> list[Quoted]:
    """Every fem-bounce command quoted in the documents, in their order."""
    found = []
    for path in documents:
        name = str(path.relative_to(ROOT))
        lines = path.read_text(encoding="utf-8").splitlines()
        prose: list[tuple[int, str]] = []  # (line number, text) outside code blocks
        fence = None  # the open fence's language
        pending, start = "", 0  # a shell line with continuations
        for number, line in enumerate(lines, 1):
            stripped = line.strip()
            if stripped.startswith("```"):
                fence = stripped[3:].strip().lower() if fence is None else None
                prose.append((number, ""))
                continue
            indented = fence is None and line.startswith("    ") and (pending or re.match(
                rf"\s*(\S*/)?({re.escape(PROGRAM)}|mpiexec|mpirun|nohup)\b", line))
            if (fence is not None and fence in SHELL_FENCES) or indented:
                if not pending:
                    start = number
                if stripped.endswith("\\"):
                    pending += stripped[:-1] + " "
                    continue
                command = _shell_line(pending + stripped, f"{name}:{start}")
                pending = ""
                if command:
                    found.append(command)
                prose.append((number, ""))
                continue
            prose.append((number, "" if fence is not None else line))
        # the prose, paragraph by paragraph (a code span never crosses a blank line)
        paragraph: list[tuple[int, str]] = []
        for number, line in [*prose, (len(lines) + 1, "")]:
            if line.strip():
                paragraph.append((number, line))
                continue
            text = "\n".join(t for _, t in paragraph)
            offsets = []
            total = 0
            for n, t in paragraph:
                offsets.append((total, n))
                total += len(t) + 1
            for offset, span in _spans(text):
                words = " ".join(span.split())
                if PROGRAM + " " not in words + " ":
                    continue
                at = max(n for o, n in offsets if o <= offset)
                try:
                    tokens = shlex.split(words)
                except ValueError:
                    tokens = words.split()
                if (found_here := _command(tokens)) is None:
                    continue
                launcher, argv = found_here
                if not argv:  # the program's name alone
                    continue
                text_from = words[words.index(PROGRAM):]
                found.append(_quoted(text_from, f"{name}:{at}", launcher, argv))
            paragraph = []
    return found


QUOTED = quoted_commands()


# -- checking a command as the command checks it, without running it --------------------------------------------


def parse(argv) -> argparse.Namespace:
    """The command's own parser on argv; its refusal (argparse exits) as an AssertionError with its message."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            return cli._parser().parse_args(list(argv))
    except SystemExit:
        raise AssertionError(f"the parser refuses it: {err.getvalue().strip().splitlines()[-1]}") from None


def _value(scene: scenes.Scene, key: str):
    """The scene's value of a dotted key (a synopsis's `--set key=PLACEHOLDER` is checked with it)."""
    value = scene
    for part in key.split("."):
        value = getattr(value, part)
    return value


def _overrides(source, texts) -> dict:
    """--set texts as a dict; a placeholder value (KEY=MU) becomes the scene's own value of KEY (a known key)."""
    changes = dict(scenes.parse_override(text) for text in texts)
    held = {k for k, v in changes.items() if isinstance(v, str) and re.fullmatch(r"[A-Z][A-Z0-9_]*", v)}
    if held:
        plain = scenes.load(source, {k: v for k, v in changes.items() if k not in held})
        changes |= {k: _value(plain, k) for k in held}
    return changes


def _load(source, texts) -> scenes.Scene:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Re and light-sphere warnings: what a run prints, not a refusal
        return api.load(source, _overrides(source, texts))


def _construct(model: str, scene: scenes.Scene) -> None:
    """What a run does before it writes anything (run.Run.prepare): the model's refusals of the scene, its
    class chosen for the scene and made (cheap: no mesh yet), which checks its numerical settings."""
    from mpi4py import MPI

    info = models.info(model)
    models.check_scene(info, scene)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        flow = models.flow_model_class(info, scene)(scene, MPI.COMM_WORLD)
    flow.destroy()


def _numbers(text: str | None) -> tuple:
    values = tuple(float(x) for x in text.split(",")) if text else ()
    assert all(v > 0 for v in values), text
    return values


def _check_run(args) -> None:
    if args.restart is not None:  # what the command checks before it reads DIR (RUNS restarts a run it made)
        assert not (args.scene or args.overrides or args.out or args.force or args.accuracy), \
            "--restart takes no SCENE, --set, --out, --force or --accuracy"
        return
    scene = _load(args.scene or cli.DEFAULT_SCENE, args.overrides)
    model = args.model
    if args.accuracy is not None:
        with contextlib.redirect_stderr(io.StringIO()):  # its one line on what it picked
            scene, model = cli._scene_for_accuracy(scene, args.accuracy, model, args.overrides)
    elif model is None:
        model, _ = models.choose(scene)
    _construct(model, scene)


def _check_compare(args) -> None:
    names = models.model_list(args.models)
    scene = _load(args.scene or cli.DEFAULT_SCENE, args.overrides)
    assert not scene.pair, "compare refuses a pair scene"
    for name in names:
        _construct(name, scene)


def _check_restitution(args) -> None:
    from fem_bounce.studies import restitution_planning as planning

    models.get(args.model)
    changes = _overrides(planning.MATERIAL_SETS[0], args.overrides)
    planning.check_overrides(changes)  # every set with the --set values, launched at the sweep's slowest speed
    assert (args.points is None or args.points >= 2) and 0 < args.st_min < args.st_max
    first = planning.bounce_scene(scenes.load(planning.MATERIAL_SETS[0], changes), planning.LAUNCH_SPEEDS[0])
    _construct(args.model, first)
    if args.band:
        from fem_bounce.studies import band

        for name in (*planning.MATERIAL_SETS, planning.DSS_PLUS_5):
            ranges = uncertain.ranges_for(scenes.load(name, changes), args.vary, None, not args.no_defaults)
        band.check_design(args.design, args.samples, len(ranges))


def _check_study(args) -> None:
    from fem_bounce.studies.common import LADDERS

    scene_name = getattr(args, "scene", None) or cli.DEFAULT_SCENE
    if args.kind == "figures":
        models.get(args.model)
        _load(scene_name, args.overrides)
        return
    if args.kind == "stability":
        cli._stability_sweeps(args.sweeps, args.model)
        scene = _load(scene_name, [*args.overrides, "run.bounces=1"])
    else:
        scene = _load(scene_name, args.overrides)
    if args.kind == "convergence":
        ladder = LADDERS[args.model]
        assert not (args.cfls and ladder.time_step_key is None), f"the {args.model} model has no time-step setting"
        for value in _numbers(args.levels):
            scene.replace(**{ladder.key: value})
        for cfl in _numbers(args.cfls):
            scene.replace(**ladder.time_step(scene, cfl))
        _construct(args.model, scene)
    elif args.kind == "speed-accuracy":
        names = models.model_list(args.models)
        for text in args.levels:
            name = text.partition("=")[0]
            assert name in names, f"--levels {text}: {name} is not in --models"
            for level in cli._speed_levels(text, name):
                scene.replace(**{LADDERS[name].key: level.resolution})
        assert args.reference_step is None or 0 < args.reference_step <= 1
        for name in names:
            _construct(name, scene)
    elif args.kind == "stability":
        _construct(args.model, scene)
    elif args.kind == "oblique":
        from fem_bounce.studies import oblique

        angles = _numbers(args.angles) or oblique.ANGLES
        oblique.check(scene, angles)
        _construct("ode", oblique.scene_at(scene, angles[0]))
    elif args.kind == "band":
        from fem_bounce.studies import band

        ranges = uncertain.ranges_for(scene, args.vary, uncertain.scene_table(scene_name), not args.no_defaults,
                                      where=f"{scene_name} [uncertain]")
        band.check_design(args.design, args.samples, len(ranges))
        _construct(args.model, scene)
    else:  # a kind this test does not know yet: its scene, its --set values and its model(s)
        for name in models.model_list(getattr(args, "models", None) or [getattr(args, "model", None) or "ode"]):
            _construct(name, scene)


def check(argv) -> None:
    """Parse argv with the command's parser and check it as the command does before it runs anything."""
    args = parse(argv)
    if args.command == "scenes":
        if args.action == "show":
            assert args.name, "scenes show needs a NAME"
            scenes.load(args.name)
    elif args.command == "run":
        _check_run(args)
    elif args.command == "compare":
        _check_compare(args)
    elif args.command == "restitution":
        _check_restitution(args)
    elif args.command == "study":
        _check_study(args)
    else:  # a command this test does not know yet: its scene and --set values, if it has them
        if getattr(args, "scene", None) or getattr(args, "overrides", None):
            _load(getattr(args, "scene", None) or cli.DEFAULT_SCENE, getattr(args, "overrides", []))


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """The study and mesh cache of this file's runs: empty at the start, as a new reader's is, and shared by the
    runs (the restitution sweep and its band plan their launches once)."""
    return tmp_path_factory.mktemp("cache")


@pytest.fixture
def in_a_directory(tmp_path, monkeypatch, cache):
    """A working directory of the reader's, holding the files the docs tell the reader to make (my.toml)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(cache))
    for name, (command, preset) in MADE_BY_THE_DOCS.items():
        assert command in {q.text for q in QUOTED}, f"{command} (which makes {name}) is no longer quoted"
        (tmp_path / name).write_text(scenes.dumps(scenes.load(preset)), encoding="utf-8")
    return tmp_path


def _checked(quoted: Quoted) -> str | None:
    """Why a quoted command is not checked, or None."""
    if quoted.text in SKIPPED:
        return SKIPPED[quoted.text]
    scene = next((w for w in quoted.argv[1:] if w.endswith(".toml")), None)
    if scene and scene not in MADE_BY_THE_DOCS:
        return f"names {scene}, a scene file of the reader's"
    return None


@pytest.mark.parametrize("quoted", QUOTED, ids=[q.where for q in QUOTED])
def test_every_quoted_command_is_accepted(quoted, in_a_directory):
    reason = _checked(quoted)
    if reason:
        pytest.skip(f"`{quoted.text}` ({quoted.where}): {reason}")
    try:
        check(quoted.argv)
    except (Error, AssertionError) as err:
        kind = "synopsis " if quoted.synopsis else ""
        pytest.fail(f"{quoted.where}: the {kind}`{quoted.text}` is refused: {err}", pytrace=False)


def test_the_docs_quote_commands_and_the_lists_are_current():
    """The extraction finds the commands (README's Run block among them), and every SKIPPED and RUNS entry is
    still quoted somewhere (a reworded command needs its entry moved, not forgotten)."""
    texts = {q.text for q in QUOTED}
    assert len(QUOTED) > 50 and "fem-bounce run li2011-case3 --model ode" in texts
    assert not [t for t in SKIPPED if t not in texts], [t for t in SKIPPED if t not in texts]
    assert not [t for t in RUNS if t not in texts], [t for t in RUNS if t not in texts]


def _documented(text: str) -> Quoted:
    found = [q for q in QUOTED if q.text == text]
    assert found, f"`{text}` is no longer quoted in the docs: run another quoted command of its kind (RUNS)"
    return found[0]


def _run(argv, capsys) -> tuple[int, str, str]:
    """fem-bounce argv in this process: its exit status, stdout and stderr (the time it took on the test's)."""
    start = time.perf_counter()
    status = cli.main(list(argv))
    out = capsys.readouterr()
    print(f"fem-bounce {shlex.join(argv)}: exit {status} in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return status, out.out, out.err


@pytest.mark.slow
@pytest.mark.parametrize("text", [t for t in RUNS if t not in RESTARTED],
                         ids=[" ".join(t.split()[1:4]) for t in RUNS if t not in RESTARTED])
def test_a_documented_command_runs_at_toy_size(text, in_a_directory, capsys):
    quoted = _documented(text)
    status, stdout, stderr = _run([*quoted.argv, *RUNS[text]], capsys)
    assert status == 0, f"{quoted.where}: `{text}` at toy size exits {status}: {stderr[-1500:]}"
    if quoted.argv[:2] == ("scenes", "show"):  # `> my.toml`: a scene file that loads back to the same scene
        (in_a_directory / "shown.toml").write_text(stdout, encoding="utf-8")
        assert scenes.load(in_a_directory / "shown.toml").replace(name=quoted.argv[2]) == scenes.load(quoted.argv[2])
    if quoted.argv[0] == "run":  # into the directory the docs name (runs/SCENE-MODEL)
        scene = scenes.load(quoted.argv[1])
        model = quoted.argv[quoted.argv.index("--model") + 1]
        summary = json.loads((in_a_directory / "runs" / f"{scene.name}-{model}" / "summary.json").read_text())
        assert summary["status"] == "completed"


@pytest.mark.slow
def test_a_documented_run_restarts(in_a_directory, capsys):
    """The README's fd run of my.toml (toy size), killed after a checkpoint (its summary removed, as a kill
    leaves it), continued by the quoted `fem-bounce run --restart runs/li2011-case3-fd`."""
    run, restart = (_documented(text) for text in RESTARTED)
    status, _, stderr = _run([*run.argv, *RUNS[run.text]], capsys)
    assert status == 0, f"{run.where}: `{run.text}` at toy size exits {status}: {stderr[-1500:]}"
    directory = in_a_directory / restart.argv[restart.argv.index("--restart") + 1]
    assert (directory / "checkpoint" / "state.json").is_file()
    (directory / "summary.json").unlink()
    status, _, stderr = _run([*restart.argv, "--quiet", "--no-plots"], capsys)
    assert status == 0, f"{restart.where}: `{restart.text}` exits {status}: {stderr[-1500:]}"
    assert json.loads((directory / "summary.json").read_text())["status"] == "completed"


# A few commands the checks must refuse: the test above would pass every command if check() accepted anything
REFUSED = [
    ("run li2011-case3 --model ode --set sphere.densty=7800", "unknown key sphere.densty"),
    ("run li2011-case3 --model ode --set contact.dry_restitution=1.5", "contact.dry_restitution"),
    ("run li2011-case3 --model odd", "unknown model"),
    ("run yang-hunt2006-pair --model ib", "cannot run a pair"),
    ("run li2011-case3 --model fd --set numerics.fd.cells_per_diameter=1", "numerics.fd.cells_per_diameter"),
    ("compare li2011-case3 --models ode,fd --frobnicate", "unrecognized arguments"),
    ("restitution --set initial_gap=0.01", "initial_gap"),
    ("restitution --set liquid.viscosity=-1", "liquid.viscosity"),
    ("study band li2011-case3 --model ode --samples 6", "--samples 6"),
    ("study band li2011-case3 --vary contact.dry_restitution=0.9:1.2", "contact.dry_restitution"),
    ("study speed-accuracy li2011-case3 --models ode,fd --levels ib=8", "--levels"),
    ("study stability --model ode --sweeps cells_per_gap", "cells_per_gap"),
    ("study oblique li2011-case3", "initial_velocity"),
    ("study convergence li2011-case3 --model ode --cfls 0.5", "time-step"),
]


@pytest.mark.parametrize("command, fragment", REFUSED)
def test_the_checks_refuse_a_wrong_command(command, fragment, in_a_directory):
    with pytest.raises((Error, AssertionError), match=re.escape(fragment)):
        check(shlex.split(command))
