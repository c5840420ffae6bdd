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


@pytest.fixture
def compilations(monkeypatch):
    """A list that gets one entry per form or expression FFCx compiles (not those it finds
    in its cache): ``_compile_objects`` is where every supported FFCx compiles."""
    import ffcx.codegeneration.jit as jit

    calls = []
    compile_objects = jit._compile_objects

    def counted(*args, **kwargs):
        calls.append(args[2] if len(args) > 2 else kwargs.get("object_names"))
        return compile_objects(*args, **kwargs)

    monkeypatch.setattr(jit, "_compile_objects", counted)
    return calls


REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
