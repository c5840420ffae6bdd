"""A form whose compilation was killed half-way is compiled again by the next run, instead
of failing every later run with FFCx's ``TimeoutError`` (nitsche_dolfinx.common.form_cache)."""

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from mpi4py import MPI
from runs import environment

# A form of its own (an unusual constant in the integrand) so that no other test shares it.
COMPILE = textwrap.dedent(
    """
    import nitsche_dolfinx  # installs the recovery
    import ufl
    from dolfinx import fem, mesh
    from mpi4py import MPI

    square = mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)
    x = ufl.SpatialCoordinate(square)
    value = fem.assemble_scalar(fem.form(ufl.sin(3.25 * x[0]) * x[1] ** 7 * ufl.dx))
    print(f"value {value:.12f}")
    """
)


def compile_in_child(cache: Path) -> subprocess.CompletedProcess:
    env = environment()
    env["XDG_CACHE_HOME"] = str(cache)
    return subprocess.run(
        [sys.executable, "-c", COMPILE], capture_output=True, text=True, env=env, timeout=300
    )


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts its own processes")
def test_claim_left_by_a_killed_compilation_is_compiled_again(tmp_path):
    first = compile_in_child(tmp_path)
    assert first.returncode == 0, first.stderr
    claims = sorted((tmp_path / "fenics").glob("libffcx_forms_*.c"))
    assert claims, "no form compiled into the fresh cache"
    # What a run killed inside the C compiler leaves: the claim, without its mark nor library.
    for claim in claims:
        for done in claim.parent.glob(claim.stem + "*"):
            if done != claim:
                done.unlink()
        hour_ago = time.time() - 3600
        os.utime(claim, (hour_ago, hour_ago))
    again = compile_in_child(tmp_path)
    assert again.returncode == 0, again.stderr
    assert "Traceback" not in again.stderr
    assert again.stdout == first.stdout
    assert "left unfinished by a run killed 60 min ago; compiling it again" in again.stderr
    assert all(claim.with_suffix(".c.cached").exists() for claim in claims)
