"""MPI hygiene as in dolfinx's own conftest: collect garbage and synchronise after each test,
and give all ranks of a test the same temporary folder."""

import gc
import os
import shutil
import tempfile

import pytest
from mpi4py import MPI


@pytest.fixture(autouse=True)
def _collect_and_sync():
    yield
    gc.collect()
    MPI.COMM_WORLD.barrier()


@pytest.fixture
def mpi_tmp_path(request):
    """A temporary folder shared by every rank of the test (created on rank 0)."""
    comm = MPI.COMM_WORLD
    path = tempfile.mkdtemp(prefix="nitsche-") if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
