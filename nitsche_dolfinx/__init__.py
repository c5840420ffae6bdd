"""nitsche-dolfinx: dynamic contact in elastodynamics by Nitsche's method, for FEniCSx.

The method of Chouly, Hild & Renard, "A Nitsche finite element method for
dynamic contact", M2AN 49 (2015) 481-528. One module per idea:

- :mod:`~nitsche_dolfinx.material`: sigma, eps, sigma_n, sigma_t, von Mises;
- :mod:`~nitsche_dolfinx.obstacles`: rigid obstacles by signed distance;
- :mod:`~nitsche_dolfinx.contact`: the Nitsche contact terms in UFL;
- :mod:`~nitsche_dolfinx.schemes`: theta, Newmark, Crank-Nicolson and the hybrid scheme;
- :mod:`~nitsche_dolfinx.solver`: the PETSc SNES wrapper;
- :mod:`~nitsche_dolfinx.diagnostics`: energies E and E_Theta, contact force;
- :mod:`~nitsche_dolfinx.parameters`: the parameters of a run, validated once;
- :mod:`~nitsche_dolfinx.model`: the problem object (the model and its terms);
- :mod:`~nitsche_dolfinx.friction`: the guarded Newton and the output of Coulomb friction;
- :mod:`~nitsche_dolfinx.stepper`, :mod:`~nitsche_dolfinx.mixed`: one time step (Nitsche and
  penalty; the mixed method);
- :mod:`~nitsche_dolfinx.simulation`: the run driver (history, fields, checkpoints, restarts);
- :mod:`~nitsche_dolfinx.history`: the history of a run and its summary figures;
- :mod:`~nitsche_dolfinx.meshes`, :mod:`~nitsche_dolfinx.shapes`: loading meshes, gmsh bodies;
- :mod:`~nitsche_dolfinx.output`, :mod:`~nitsche_dolfinx.exact`, :mod:`~nitsche_dolfinx.cases`;
- :mod:`~nitsche_dolfinx.config`, :mod:`~nitsche_dolfinx.cli`: the ``nitsche-dolfinx`` command;
- :mod:`~nitsche_dolfinx.pairs`, :mod:`~nitsche_dolfinx.twobody`: contact between two bodies;
- :mod:`~nitsche_dolfinx.compat`: every dolfinx version difference (0.5 to 0.11).

Importing the package silences the compiler lines that form compilation logs on
dolfinx 0.5 (set ``NITSCHE_DOLFINX_VERBOSE=1`` to see them).
"""

from . import compat, form_cache
from .contact import NitscheContact, hybrid_contact_force, positive_part
from .diagnostics import BoundaryAverage
from .history import HISTORY_COLUMNS, History
from .material import Material
from .meshes import BAR_CLAMPED, BAR_CONTACT, bar_mesh, load_mesh, save_mesh
from .model import ContactProblem
from .obstacles import PlaneObstacle, SignedDistanceObstacle
from .output import read_history
from .parameters import ParameterError
from .schemes import (
    SCHEMES,
    CrankNicolson,
    HybridScheme,
    NewmarkScheme,
    ThetaScheme,
    make_scheme,
)
from .simulation import Simulation
from .solver import SNESSolver, SolverError

__version__ = "0.1.0"

compat.quiet_form_compilation()
form_cache.recover_abandoned_compilations()

__all__ = [
    "BAR_CLAMPED",
    "BAR_CONTACT",
    "BoundaryAverage",
    "ContactProblem",
    "CrankNicolson",
    "HISTORY_COLUMNS",
    "History",
    "HybridScheme",
    "Material",
    "NewmarkScheme",
    "NitscheContact",
    "ParameterError",
    "PlaneObstacle",
    "SCHEMES",
    "SNESSolver",
    "SignedDistanceObstacle",
    "Simulation",
    "SolverError",
    "ThetaScheme",
    "bar_mesh",
    "hybrid_contact_force",
    "load_mesh",
    "make_scheme",
    "positive_part",
    "read_history",
    "save_mesh",
]
