"""Time stepping: the schemes (`schemes`), the time levels (`timelevels`), what every stepper
shares (`base`) and what the Nitsche steppers share (`balance`), the implicit Nitsche and
penalty steps (`implicit`, with their solver `step_solver`), the explicit steps (`explicit`,
`explicit_force`, `explicit_mass`, `stable_step`, `blowup`), the mixed method (`mixed`),
the stepper of a problem (`factory`), and the parts a step may carry (`parts`): friction
(`friction`), damping (`damping_work`), the work of loads and supports (`work`), of moving
obstacles (`obstacle_work`).
"""

from .base import Stepper, UncontrolledStep, energy_controlled
from .blowup import UnstableStep
from .explicit import ExplicitStepper
from .factory import make_stepper, step_linear_solver
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
    "make_stepper",
    "reaction_columns",
    "round_down",
    "scheme_parameters",
    "step_linear_solver",
]
