"""Time stepping: the schemes (`schemes`), the time levels (`timelevels`), what every stepper
shares (`base`), the implicit Nitsche and penalty steps (`implicit`), the explicit steps
(`explicit`, `explicit_mass`, `stable_step`), the mixed method (`mixed`), and the parts a
step may carry: friction (`friction`), the work of loads and supports (`work`), of moving
obstacles (`obstacle_work`).
"""

from .base import Stepper, UncontrolledStep, energy_controlled
from .explicit import ExplicitStepper, UnstableStep
from .implicit import NitscheStepper
from .mixed import MixedStepper
from .schemes import (
    SCHEMES,
    CrankNicolson,
    HybridScheme,
    NewmarkScheme,
    ThetaScheme,
    TimeScheme,
    VerletScheme,
    make_scheme,
    scheme_parameters,
)
from .stable_step import contact_stiffness_form, round_down
from .work import reaction_columns

__all__ = [
    "CrankNicolson",
    "ExplicitStepper",
    "HybridScheme",
    "MixedStepper",
    "NewmarkScheme",
    "NitscheStepper",
    "SCHEMES",
    "Stepper",
    "ThetaScheme",
    "TimeScheme",
    "UncontrolledStep",
    "UnstableStep",
    "VerletScheme",
    "contact_stiffness_form",
    "energy_controlled",
    "make_scheme",
    "reaction_columns",
    "round_down",
    "scheme_parameters",
]
