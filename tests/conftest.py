import warnings

import pytest


@pytest.fixture(autouse=True)
def _quiet_re_warnings():
    # Scenes warn when Re exceeds the axisymmetric range; tests that care catch it themselves.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*axisymmetric.*")
        yield


@pytest.fixture
def shared_tmp(tmp_path):
    """A temporary directory that every MPI rank sees (rank 0's)."""
    from mpi4py import MPI

    return type(tmp_path)(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))
