"""The contact-aware partition (contact_bisection) and the gmsh pipeline that every gmsh mesh
goes through: each rank's share of every contact surface of the two-body meshes (which
dolfinx's graph partition leaves on one rank or the other), the bisection in both dolfinx
conventions, and the pipeline's rules (errors of rank 0 on every rank, gmsh started
without taking SIGINT)."""

import os
import signal

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx.cases import (
    BALL_BOTTOM,
    LOWER_CONTACT,
    SLAB_BOTTOM,
    SLAB_TOP,
    UPPER_CONTACT,
    ball_on_slab_mesh,
    mirrored_bodies_mesh,
    two_bars_mesh,
)
from nitsche_dolfinx.meshing import contact_bisection, from_root, gmsh_session, load_mesh

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: The two-body meshes and their contact surfaces (all spread over the ranks).
PAIR = (UPPER_CONTACT, LOWER_CONTACT)
TWO_BODIES = {
    "two_disks": (lambda: mirrored_bodies_mesh(2, mesh_size=4.0, gap=1.0), PAIR),
    "two_balls": (lambda: mirrored_bodies_mesh(3, mesh_size=8.0, gap=1.0), PAIR),
    "disk_on_slab": (
        lambda: ball_on_slab_mesh(2, mesh_size=4.0),
        (BALL_BOTTOM, SLAB_TOP, SLAB_BOTTOM),
    ),
}


def _owned(mesh, facet_tags, tag) -> int:
    """The facets of ``tag`` this rank owns."""
    fdim = mesh.topology.dim - 1
    facets = facet_tags.indices[facet_tags.values == tag]
    return int(np.count_nonzero(facets < mesh.topology.index_map(fdim).size_local))


def _assert_shares(mesh, facet_tags, tags) -> None:
    """Each rank owns at least 80 % of its share of every surface, and its share of the
    cells (to one)."""
    comm = mesh.comm
    for tag in tags:
        owned = np.array(comm.allgather(_owned(mesh, facet_tags, tag)))
        assert owned.sum() > 0
        assert owned.min() >= 0.8 * owned.sum() / comm.size, (tag, owned)
    cells = np.array(comm.allgather(mesh.topology.index_map(mesh.topology.dim).size_local))
    assert np.ptp(cells) <= 1, cells


@pytest.mark.mpi
@pytest.mark.parametrize("case", TWO_BODIES)
def test_each_rank_has_its_share_of_every_contact_surface(case):
    make, tags = TWO_BODIES[case]
    mesh, _, facet_tags = make()
    _assert_shares(mesh, facet_tags, tags)


@pytest.mark.mpi
def test_two_bars_are_cut_between_the_bars():
    """In 1D a contact surface is a point: the cut falls between the bars (the cells'
    median), each rank with one bar and one contact point."""
    mesh, cell_tags, facet_tags = two_bars_mesh(20, gap=0.1)
    comm = mesh.comm
    points = np.array(comm.allgather(sum(_owned(mesh, facet_tags, t) for t in PAIR)))
    assert points.sum() == 2
    if comm.size == 2:
        assert points.tolist() == [1, 1]
        owned = cell_tags.values[cell_tags.indices < mesh.topology.index_map(1).size_local]
        assert len(set(owned.tolist())) == 1  # one body per rank


@pytest.mark.mpi
def test_msh_file_partitioned_by_its_contact_tags():
    """load_mesh(contact_tags=...): the ring's Gamma_C (tag 1) spread over the ranks."""
    mesh, facet_tags = load_mesh(os.path.join(REPO, "meshes", "ring_2d.msh"), contact_tags=[1])
    _assert_shares(mesh, facet_tags, [1])


def _lattice(n: int = 12):
    """The nodes of an n^3 lattice of unit cubes and a tetrahedron in each cube."""
    x = np.stack(np.meshgrid(*[np.arange(n + 1.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    index = np.arange(len(x)).reshape(n + 1, n + 1, n + 1)
    corner = index[:-1, :-1, :-1].ravel()
    cells = np.stack([corner, corner + 1, corner + n + 1, corner + (n + 1) ** 2], axis=1)
    return x, cells


def test_contact_bisection_gives_each_part_its_share_of_the_contact():
    """The partitioner on a lattice of cubes, contact at the bottom: the cells in equal
    parts, each with its share of the bottom layer (the cuts are vertical), in dolfinx
    0.9's convention (the owners) and 0.5's (the owners, then the ranks sharing a vertex)."""
    import dolfinx.cpp

    x, cells = _lattice()
    contact = x[x[:, 2] == 0.0]
    bottom = x[cells[:, 0], 2] == 0.0
    partition = contact_bisection(x, contact, 4)
    for parts in (2, 3, 4):
        owners = partition(MPI.COMM_SELF, parts, [None], [cells.ravel()]).array
        assert np.ptp(np.bincount(owners, minlength=parts)) <= 1
        share = np.bincount(owners[bottom], minlength=parts)
        assert share.min() >= 0.9 * bottom.sum() / parts
        legacy = dolfinx.cpp.graph.AdjacencyList_int64(cells)
        destinations = partition(MPI.COMM_SELF, parts, 3, legacy, None)
        assert np.array_equal(destinations.array[destinations.offsets[:-1]], owners)
        shared = destinations.offsets[1:] - destinations.offsets[:-1] > 1
        assert 0 < shared.sum() < len(cells) // 2  # the cells along the cuts


def test_contact_bisection_shares_two_facing_surfaces():
    """Contact at the bottom and the top of the lattice (two bodies' facing surfaces, in
    a box 12 wide and 12 high): each part gets its share of both, which a cut between
    them (each surface on one rank) would not; one surface as a list of one gives the
    cuts of the surface alone."""
    x, cells = _lattice()
    bottom, top = x[x[:, 2] == 0.0], x[x[:, 2] == 12.0]
    owners = contact_bisection(x, [bottom, top], 4)(MPI.COMM_SELF, 2, [None], [cells.ravel()])
    owners = owners.array
    for layer in (x[cells[:, 0], 2] == 0.0, x[cells[:, 3], 2] == 12.0):
        share = np.bincount(owners[layer], minlength=2)
        assert share.min() >= 0.9 * layer.sum() / 2, share
    alone = contact_bisection(x, bottom, 4)(MPI.COMM_SELF, 3, [None], [cells.ravel()]).array
    listed = contact_bisection(x, [bottom], 4)(MPI.COMM_SELF, 3, [None], [cells.ravel()]).array
    assert np.array_equal(alone, listed)


@pytest.mark.mpi
def test_error_of_rank_zero_is_raised_on_every_rank():
    comm = MPI.COMM_WORLD

    def fail():
        raise ValueError("mesh file 'x.msh' is bad")

    with pytest.raises(ValueError, match="mesh file 'x.msh' is bad"):
        from_root(comm, fail)
    assert from_root(comm, lambda: {"rank": comm.rank}) == {"rank": 0}


class _Unpicklable(ValueError):
    def __init__(self, what, why):  # pickle calls it with the message alone
        super().__init__(f"{what}: {why}")


@pytest.mark.mpi
def test_error_that_pickle_refuses_reaches_the_other_ranks_as_its_message():
    comm = MPI.COMM_WORLD

    def fail():
        raise _Unpicklable("gdim=3", "not the cells' dimension")

    with pytest.raises(ValueError, match="gdim=3: not the cells' dimension") as caught:
        from_root(comm, fail)
    if comm.rank == 0:  # the rank that failed keeps its own error
        assert isinstance(caught.value, _Unpicklable)


def test_gmsh_leaves_the_sigint_handler_alone():
    """gmsh takes SIGINT (4.8 when imported, 4.9 on when started; 4.13 never puts it
    back): the runs' handler (nitsche_dolfinx.common.signals) survives a mesh, and inside the
    session gmsh 4.9 on is told to leave it alone."""

    def handler(signum, frame):
        pass

    previous = signal.signal(signal.SIGINT, handler)
    try:
        with gmsh_session() as gmsh:
            assert gmsh.option.getNumber("General.Terminal") == 0
        assert signal.getsignal(signal.SIGINT) is handler
        mesh, _, _ = two_bars_mesh(2)  # gmsh, then dolfinx's reader of gmsh models
        assert signal.getsignal(signal.SIGINT) is handler
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.mpi
def test_graph_partition_is_the_same_every_time():
    """dolfinx's own partition (a .msh file read without contact tags) gives the same
    cells and node order each time on the same ranks: the package runs PT-Scotch with one
    thread, whose threads otherwise change it from one run to the next (four node orders
    in five runs of the ring on 2 ranks). Bitwise: the same partition of the same file."""
    import nitsche_dolfinx  # noqa: F401  (sets the thread count on import)

    assert os.environ.get("SCOTCH_PTHREAD_NUMBER") == "1"
    ring = os.path.join(REPO, "meshes", "ring_2d.msh")
    first, *others = (load_mesh(ring)[0].geometry.x.copy() for _ in range(3))
    assert all(np.array_equal(first, other) for other in others)
