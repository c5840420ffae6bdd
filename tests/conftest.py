"""MPI hygiene as in dolfinx's own conftest: collect garbage and synchronise after each test,
and give all ranks of a test the same temporary folder; one BLAS thread unless the user
chose a number."""

import os

# One BLAS thread, as `make test` sets, before numpy loads: the runs the tests start
# (tests/runs.py) inherit the same number, and a check that a restarted run, started in
# its own process, writes the same fields as this process's run to the bit needs the same
# operations in both. OpenBLAS splits a product over its threads, and another number of
# threads sums in another order (8e-20 relative in a restart's fields with two threads
# here, one there).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import gc
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
