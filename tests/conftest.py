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
