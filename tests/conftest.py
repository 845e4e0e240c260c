import warnings

import pytest

import fem_bounce  # noqa: F401  first, so that MPI loads ahead of PETSc and dolfinx (see fem_bounce/__init__.py)


@pytest.fixture(autouse=True)
def _quiet_re_warnings():
    # Scenes warn when Re exceeds the axisymmetric range; tests that care catch it themselves.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*axisymmetric.*")
        yield


@pytest.fixture
def mpiexec():
    """The MPI launcher of the MPI this Python uses: the one beside it in a venv (the PyPI stack's MPICH; another
    MPI's mpirun cannot start it), else the first mpiexec on PATH (conda, a system MPI)."""
    import shutil
    import sys
    from pathlib import Path

    beside = Path(sys.executable).parent / "mpiexec"
    launcher = str(beside) if beside.is_file() else shutil.which("mpiexec")
    if launcher is None:
        pytest.skip("no mpiexec")
    return launcher


@pytest.fixture
def shared_tmp(tmp_path):
    """A temporary directory that every MPI rank sees (rank 0's)."""
    from mpi4py import MPI

    return type(tmp_path)(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


@pytest.fixture(scope="session")
def fd_run(tmp_path_factory):
    """A toy fd run (helpers.FD_TOY), uninterrupted (checkpoints every 10 steps; its last at step 60 of 65): the
    reference for the restarts of its copies, and the run directory each checkpoint test copies.  Made once for
    the session: no test writes into it."""
    import json

    from fem_bounce import cli
    from helpers import FD_TOY

    out = tmp_path_factory.mktemp("fd") / "straight"
    assert cli.main(["run", *FD_TOY, "--out", str(out)]) == 0
    assert json.loads((out / "checkpoint" / "state.json").read_text())["step"] == 60
    return out


@pytest.fixture
def fd_copy(fd_run, tmp_path):
    """A copy of the toy fd run to break."""
    import shutil

    copy = tmp_path / "run"
    shutil.copytree(fd_run, copy, symlinks=True)
    (copy / "summary.json").unlink()  # as after a kill
    return copy
