"""fem_bounce's caches of study runs and meshes: in the user's cache folder, never the working directory or the
source tree; refused in one line where they cannot be; never trusted when damaged, never poisoned through --out,
and shared by two identical studies at once."""
import os

from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import cache, cachedir, cli
from fem_bounce.fem import mesh as halfplane
from helpers import ODE, ODE_ONE, assert_one_line, refused, refused_same_listing, run_cli, spawn, tree, wait_for


# -- where the caches are ---------------------------------------------------------------------------------------------


def test_studies_and_meshes_cache_outside_the_working_directory(tmp_path, monkeypatch, capsys):
    """restitution, study and compare wrote results/cache/ into the working directory even with --out,
    and generated meshes went to meshes/cache/ inside the source tree."""
    from fem_bounce import cachedir

    monkeypatch.chdir(tmp_path / "work" if (tmp_path / "work").mkdir() is None else tmp_path)
    monkeypatch.delenv("FEM_BOUNCE_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cachedir.folder("runs") == tmp_path / "xdg" / "fem_bounce" / "runs"
    code, _ = run_cli(capsys, "compare", "li2011-case3", "--models", "ode", "--out", str(tmp_path / "cmp"),
                      "--set", "run.bounces=1")
    assert code == 0 and os.listdir(tmp_path / "work") == []
    assert list((tmp_path / "xdg" / "fem_bounce" / "runs").iterdir())


def test_a_relative_xdg_cache_home_is_ignored(tmp_path, monkeypatch):
    """XDG_CACHE_HOME=rel put the cache in the working directory; the XDG rule: a relative path is invalid."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("FEM_BOUNCE_CACHE", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", "rel")
    assert cachedir.folder("runs") == tmp_path / "home" / ".cache" / "fem_bounce" / "runs"
    assert not (tmp_path / "rel").exists()


def test_a_cache_that_is_a_file_gives_one_line(tmp_path, monkeypatch, capsys):
    """FEM_BOUNCE_MESH_CACHE pointing at a file ended in FileExistsError."""
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "file"))
    refused_same_listing(capsys, tmp_path, monkeypatch, "compare", "li2011-case3", "--models", "ode", "--out", "c",
                         message="cannot use " + str(tmp_path / "file" / "runs") + " as fem_bounce's cache")


def test_a_cache_inside_a_run_directory_is_refused(tmp_path, monkeypatch, capsys):
    """FEM_BOUNCE_CACHE=<a run directory> fem-bounce compare ...: blamed --out and left a lock file in the run."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", *ODE_ONE, "--out", "r"]) == 0
    capsys.readouterr()
    before = tree(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "r"))
    status, lines = run_cli(capsys, "compare", "li2011-case3", "--models", "ode", "--quiet", "--out", "c")
    assert status == 2
    assert_one_line(lines, f"error: fem_bounce's cache {tmp_path / 'r'} is inside the run directory",
                    "set FEM_BOUNCE_CACHE")
    assert tree(tmp_path) == before


# -- the study cache --------------------------------------------------------------------------------------------------


def test_the_study_cache_cannot_be_poisoned(tmp_path, monkeypatch, capsys):
    """`--out CACHE/runs/<key> --force` with another scene was accepted and `compare` then reported that run; a
    cache entry edited or half-written was trusted."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    argv = ["compare", "li2011-case3", "--models", "ode", "--set", "run.bounces=1", "--quiet"]
    assert cli.main([*argv, "--out", str(tmp_path / "first")]) == 0
    entry, = (tmp_path / "cache" / "runs").glob("li2011-*")
    assert cache.finished(entry) == entry
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--set", "sphere.density=2000", "--force",
            "--out", str(entry), message="is inside fem_bounce's cache")
    trajectory = entry / "trajectory.csv"
    trajectory.write_text(trajectory.read_text().replace("0.", "1.", 5))
    assert cache.finished(entry) is None  # damaged: made again, never trusted
    assert cli.main([*argv, "--out", str(tmp_path / "second")]) == 0  # made again
    assert cache.finished(entry) == entry
    first, second = ((tmp_path / name / "ode" / "trajectory.csv").read_text() for name in ("first", "second"))
    assert first == second == trajectory.read_text()  # the damaged entry replaced by the run made again


def test_the_study_cache_key_holds_the_series_content(tmp_path, monkeypatch):
    """Editing a motion.series CSV did not invalidate the cached run (the key held its path only)."""
    monkeypatch.chdir(tmp_path)
    series = tmp_path / "series.csv"
    series.write_text("t,velocity\n0,0\n0.05,-0.1\n")
    scene = fb.load("li2011-case3", {"motion.mode": "prescribed", "motion.series": "series.csv"})
    before = cache.run_key(scene, "ode")
    series.write_text("t,velocity\n0,0\n0.05,-0.2\n")
    assert cache.run_key(scene, "ode") != before


def test_two_identical_studies_at_once_share_their_runs(tmp_path, monkeypatch):
    """The second of two identical `compare` runs failed: "the cache directory is in use ... choose another --out"."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    argv = ["compare", "li2011-case3", "--models", "fd", "--quiet", "--set", "numerics.fd.cells_per_diameter=6",
            "--set", "run.end_time=0.05"]
    first = spawn([*argv, "--out", "a"], tmp_path)
    wait_for(lambda: any((tmp_path / "cache" / "runs").glob(".*.partial")), first)
    second = spawn([*argv, "--out", "b"], tmp_path)
    outcomes = [process.communicate(timeout=300) for process in (first, second)]
    assert [first.returncode, second.returncode] == [0, 0], outcomes
    assert len([p for p in (tmp_path / "cache" / "runs").iterdir() if not p.name.startswith(".")]) == 1
    assert (tmp_path / "a" / "comparison.csv").read_text() == (tmp_path / "b" / "comparison.csv").read_text()


# -- the mesh cache ---------------------------------------------------------------------------------------------------


def test_a_damaged_mesh_in_the_cache_is_made_again(tmp_path, monkeypatch):
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path))
    spec = halfplane.HalfPlane(radius=0.05, height=0.1, fine_size=0.01, coarse_size=0.02, grading=0.2)
    first, _, _ = halfplane.create_mesh(MPI.COMM_SELF, spec)
    entry = tmp_path / "meshes" / f"halfplane-{spec.key()}.msh"
    whole = entry.read_bytes()
    entry.write_bytes(whole[: len(whole) // 2])  # as a full disk or a crash left it
    again, _, _ = halfplane.create_mesh(MPI.COMM_SELF, spec)
    assert entry.read_bytes() == whole
    assert again.topology.index_map(2).size_global == first.topology.index_map(2).size_global
