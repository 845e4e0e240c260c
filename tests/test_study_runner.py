"""The parallel study runner: N processes give the runs one process gives, a resumed study reuses the
finished runs and redoes the unfinished ones, and bad --jobs/--executor requests are refused clearly."""
import json
import os
import subprocess
import sys

import pytest
from mpi4py import MPI

from fem_bounce import cache, cli, scene
from fem_bounce.studies import convergence
from fem_bounce.studies.runner import Runner, RunnerError

LEVELS = (1e-3, 1e-4, 1e-5)


def tiny_study(tmp_path, jobs: int, name: str) -> list[dict]:
    """An ODE convergence study of case 1 to its first apex: 3 tolerances (a second each)."""
    sc = scene.load("li2011-case1", {"run.bounces": 1})
    runner = Runner(MPI.COMM_SELF, jobs=jobs, root=tmp_path / f"cache-{name}")
    convergence.run(sc, "ode", MPI.COMM_SELF, tmp_path / name, levels=LEVELS, runner=runner)
    return json.loads((tmp_path / name / "convergence.json").read_text())["rows"]


def same_runs(rows: list[dict]) -> list[dict]:
    """What must not depend on how the runs were spread: everything but the wall time and the cache root."""
    return [{k: v for k, v in row.items() if k not in ("wall_time_s", "run_dir")} for row in rows]


def summaries(root) -> dict:
    return {path.parent.name: path.stat().st_mtime_ns for path in root.glob("*/summary.json")}


def test_two_jobs_give_the_runs_of_one(tmp_path):
    serial = tiny_study(tmp_path, 1, "serial")
    parallel = tiny_study(tmp_path, 2, "parallel")
    assert len(serial) == len(LEVELS)
    assert same_runs(parallel) == same_runs(serial)
    assert all(row["status"] == "completed" for row in parallel)
    assert sorted(summaries(tmp_path / "cache-parallel")) == sorted(summaries(tmp_path / "cache-serial"))


def test_a_resumed_study_reuses_finished_runs_and_redoes_unfinished_ones(tmp_path):
    first = tiny_study(tmp_path, 2, "study")
    root = tmp_path / "cache-study"
    runs = sorted(p for p in root.iterdir() if not p.name.startswith("."))  # not the entries' lock files
    # as a killed study leaves them: one run interrupted between two steps, one killed before its summary
    interrupted, killed = runs[0], runs[1]
    summary = json.loads((interrupted / "summary.json").read_text())
    (interrupted / "summary.json").write_text(json.dumps({**summary, "status": "interrupted"}))
    (killed / "summary.json").unlink()
    before = summaries(root)
    again = tiny_study(tmp_path, 2, "study")
    after = summaries(root)
    finished = set(before) - {interrupted.name}
    assert {name: after[name] for name in finished} == {name: before[name] for name in finished}  # reused
    assert after[interrupted.name] != before[interrupted.name] and killed.name in after  # redone
    assert same_runs(again) == same_runs(first)
    assert all(cache.finished(run) for run in runs)


def test_identical_runs_are_run_once(tmp_path):
    sc = scene.load("li2011-case1", {"run.bounces": 1})
    found = dict(Runner(MPI.COMM_SELF, jobs=2, root=tmp_path).run([(sc, "ode"), (sc, "ode")]))
    assert found[0] == found[1] and len([p for p in tmp_path.iterdir() if not p.name.startswith(".")]) == 1


def test_the_documented_mpi_pool_command_gives_the_runs_of_one_process(tmp_path, mpiexec):
    """`mpiexec -n 2 python -m mpi4py.futures -m fem_bounce study ... --executor mpi` (one worker), as the
    README gives it, in a fresh MPI job of its own."""
    serial = tiny_study(tmp_path, 1, "serial")
    # not this process's MPI job, if it is in one (MPICH's PMI_*, OpenMPI's OMPI_*)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PMI_"))}
    command = [mpiexec, "-n", "2", sys.executable, "-m", "mpi4py.futures", "-m", "fem_bounce", "study", "convergence",
               "li2011-case1", "--model", "ode", "--set", "run.bounces=1", "--levels", ",".join(map(str, LEVELS)),
               "--out", "pooled", "--executor", "mpi"]
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "1 MPI worker(s) of mpi4py.futures" in done.stderr
    pooled = json.loads((tmp_path / "pooled" / "convergence.json").read_text())["rows"]
    assert same_runs(pooled) == same_runs(serial)


@pytest.mark.parametrize("jobs, executor, message", [
    (0, "local", "--jobs 0: give a whole number of processes, 1 or more"),
    (1, "threads", "--executor 'threads': choose one of local, mpi"),
    (1, "mpi", "start it as `mpiexec -n K python -m mpi4py.futures -m fem_bounce study ... --executor mpi`"),
    (2, "mpi", "--jobs applies to --executor local"),
])
def test_bad_parallel_requests_are_refused(jobs, executor, message):
    with pytest.raises(RunnerError, match=message.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        Runner(MPI.COMM_SELF, jobs=jobs, executor=executor)


def test_the_command_line_refuses_an_mpi_executor_outside_a_pool(capsys, tmp_path):
    args = ["study", "convergence", "li2011-case1", "--model", "ode", "--executor", "mpi", "--out", str(tmp_path / "s")]
    assert cli.main(args) == 2
    assert "python -m mpi4py.futures -m fem_bounce" in capsys.readouterr().err


@pytest.mark.mpi
def test_local_jobs_under_mpiexec_are_refused_on_every_rank(capsys, shared_tmp):
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("needs mpiexec -n 2")
    args = ["study", "convergence", "li2011-case1", "--model", "ode", "--jobs", "2", "--out", str(shared_tmp / "s")]
    assert cli.main(args) == 2
    if MPI.COMM_WORLD.rank == 0:
        assert "--jobs 2 starts its own processes: run it without mpiexec" in capsys.readouterr().err


@pytest.mark.mpi
def test_a_rank_that_comes_late_joins_the_runs_of_the_others(shared_tmp):
    """Under mpiexec each rank used to decide from the cache on its own: a rank that reached the study after
    rank 0 had finished a run found it finished and skipped it, so the ranks' collectives no longer matched
    (found by demos/tutorial.py under mpiexec -n 2, whose ranks plan the restitution sweep at their own pace).
    Now rank 0 decides for all."""
    import time

    if MPI.COMM_WORLD.size < 2:
        pytest.skip("needs mpiexec -n 2")
    sc = scene.load("li2011-case1", {"run.bounces": 1})
    tasks = [(sc, "ode"), (sc.replace(**{"numerics.ode.rtol": 1e-4}), "ode")]
    if MPI.COMM_WORLD.rank == 1:
        time.sleep(3.0)  # rank 0 finishes the first run (about a second) meanwhile
    found = dict(Runner(MPI.COMM_WORLD, root=shared_tmp / "cache").run(tasks))
    assert sorted(found) == [0, 1] and found[0] != found[1]
    assert all(cache.finished(run_dir) for run_dir in found.values())  # both runs done when a rank has them
