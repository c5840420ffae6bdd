"""nitsche-dolfinx: dynamic contact in elastodynamics by Nitsche's method, for FEniCSx.

The method of Chouly, Hild & Renard, "A Nitsche finite element method for
dynamic contact", M2AN 49 (2015) 481-528. One module per idea, in folders that are
layers and look only down (:data:`LAYERS`, lowest first): what every layer uses
(:mod:`~nitsche_dolfinx.common`), meshes (:mod:`~nitsche_dolfinx.meshing`), the
continuum and its data (:mod:`~nitsche_dolfinx.physics`), the contact terms
(:mod:`~nitsche_dolfinx.contact`), assembly (:mod:`~nitsche_dolfinx.assembly`), what a
run measures and writes (:mod:`~nitsche_dolfinx.output`), the model
(:mod:`~nitsche_dolfinx.model`), the solvers (:mod:`~nitsche_dolfinx.solvers`), the time
steps (:mod:`~nitsche_dolfinx.steppers`), the run driver
(:mod:`~nitsche_dolfinx.simulation`), the test cases (:mod:`~nitsche_dolfinx.cases`),
after a run (:mod:`~nitsche_dolfinx.post`), TOML files (:mod:`~nitsche_dolfinx.config`)
and the command line (:mod:`~nitsche_dolfinx.cli`). docs/layout.md lists every module.

Importing the package silences the compiler lines that form compilation logs on
dolfinx 0.5 (set ``NITSCHE_DOLFINX_VERBOSE=1`` to see them).
"""

from .common import compat, form_cache
from .common.parameters import ParameterError
from .contact.nitsche import NitscheContact, hybrid_contact_force, positive_part
from .meshing.meshes import BAR_CLAMPED, BAR_CONTACT, bar_mesh, load_mesh, save_mesh
from .model.problem import ContactProblem
from .output.history import HISTORY_COLUMNS, History
from .output.probes import BoundaryAverage
from .output.writers import read_history
from .physics.material import Material
from .physics.motion import MovingObstacle
from .physics.obstacles import PlaneObstacle, SignedDistanceObstacle
from .simulation import Simulation
from .solvers.solver import SNESSolver, SolverError
from .steppers.schemes import (
    SCHEMES,
    CrankNicolson,
    HybridScheme,
    NewmarkScheme,
    ThetaScheme,
    VerletScheme,
    make_scheme,
)

__version__ = "0.1.0"

#: The package's layers, lowest first: a folder (or top-level module) imports only those
#: before it (tests/test_layers.py checks it).
LAYERS = (
    "common",
    "meshing",
    "physics",
    "contact",
    "assembly",
    "output",
    "model",
    "solvers",
    "steppers",
    "simulation",
    "cases",
    "post",
    "config",
    "cli",
)

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
    "LAYERS",
    "Material",
    "NewmarkScheme",
    "NitscheContact",
    "MovingObstacle",
    "ParameterError",
    "PlaneObstacle",
    "SCHEMES",
    "SNESSolver",
    "SignedDistanceObstacle",
    "Simulation",
    "SolverError",
    "ThetaScheme",
    "VerletScheme",
    "bar_mesh",
    "hybrid_contact_force",
    "load_mesh",
    "make_scheme",
    "positive_part",
    "read_history",
    "save_mesh",
]
