"""The command line: the `nitsche-dolfinx` command (`command`), the demos' shared flags
(`arguments`), errors reported as one line with an exit status (`errors`).
"""

from .arguments import (
    add_mass_argument,
    add_method_arguments,
    add_parameter_argument,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    petsc_option,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from .command import main
from .errors import one_line_errors, under_its_flag

__all__ = [
    "add_mass_argument",
    "add_method_arguments",
    "add_parameter_argument",
    "add_run_arguments",
    "add_terminal_arguments",
    "check_output_folder",
    "finite_float",
    "main",
    "method_parameters",
    "one_line_errors",
    "petsc_option",
    "scheme_from_arguments",
    "scheme_mass",
    "step_taken",
    "under_its_flag",
]
