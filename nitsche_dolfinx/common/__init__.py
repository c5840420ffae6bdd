"""What every layer uses: dolfinx version differences (`compat`), reductions over the ranks
(`collective`) and how the ranks agree on errors (`agreement`), keys and validated
parameters (`keys`, `parameters`), FFCx's form cache (`form_cache`), clean stops on signals
(`signals`).
"""

from .agreement import ERROR_AGREEMENT_SECONDS, FailureChannel, agree
from .collective import (
    any_rank,
    collect_garbage_together,
    garbage_collected_together,
    max_over_ranks,
    sum_over_ranks,
)
from .compat import function_space, gmsh_model_to_mesh
from .keys import KINDS, LARGEST, REQUIRED, Key, is_number, toml_text
from .parameters import (
    CONTACT_METHODS,
    GAMMA0_SCALINGS,
    MASS_MATRICES,
    Discretisation,
    NitscheParameters,
    OutputParameters,
    ParameterError,
    SolverParameters,
    TimeStepping,
    require,
    require_choice,
    require_positive,
    require_real,
)
from .signals import RunInterrupted, StopSignals

__all__ = [
    "CONTACT_METHODS",
    "Discretisation",
    "ERROR_AGREEMENT_SECONDS",
    "FailureChannel",
    "GAMMA0_SCALINGS",
    "KINDS",
    "Key",
    "LARGEST",
    "MASS_MATRICES",
    "NitscheParameters",
    "OutputParameters",
    "ParameterError",
    "REQUIRED",
    "RunInterrupted",
    "SolverParameters",
    "StopSignals",
    "TimeStepping",
    "agree",
    "any_rank",
    "collect_garbage_together",
    "function_space",
    "garbage_collected_together",
    "gmsh_model_to_mesh",
    "is_number",
    "max_over_ranks",
    "require",
    "require_choice",
    "require_positive",
    "require_real",
    "sum_over_ranks",
    "toml_text",
]
