"""Run pytest on every MPI rank; only rank 0 prints; the exit status is the worst rank's.

    mpiexec -n 2 python tests/mpi_pytest.py -m mpi
"""
import os
import sys

import pytest
from mpi4py import MPI

comm = MPI.COMM_WORLD
args = sys.argv[1:]
if comm.rank > 0:
    args += ["-p", "no:cacheprovider", "-q"]
    sys.stdout = open(os.devnull, "w")
status = int(pytest.main(args))
worst = comm.allreduce(0 if status in (0, 5) else status, op=MPI.MAX)
if comm.rank == 0 and status == 5 and worst == 0:
    print("no tests were selected on this rank")
sys.exit(worst)
