"""The continuum and its data: materials (`material`, `hyperelastic`, `regions`), rigid
obstacles still or moving (`obstacles`, `motion`), the problem's values in space and time
(`expressions` and their walk `expression_walk`, `tables`, `problem_values`, `valueforms`),
Dirichlet conditions (`dirichlet`), damping (`damping`), the mass matrix (`mass`).
"""

from .damping import (
    DampingPower,
    DiagonalDamping,
    RayleighDamping,
    check_damping,
    damped_stable_step,
)
from .dirichlet import DirichletCondition, DirichletDofs
from .expression_walk import MAX_EXPONENT
from .expressions import (
    expression,
    has_text,
    parse_expression,
    parse_vector,
    to_ufl,
    vector_expression,
)
from .hyperelastic import (
    LAWS,
    averaged_stress,
    cauchy_stress,
    first_piola,
    gauss_points,
    neo_hookean,
    strain_energy,
    von_mises_of,
)
from .mass import MassMatrix, density
from .material import Material, MaterialConstants, sigma, sigma_n, sigma_t, von_mises
from .motion import LEVELS, MOTION_KEYS, MovingObstacle
from .obstacles import (
    OBSTACLES,
    CylinderObstacle,
    PlaneObstacle,
    SignedDistanceObstacle,
    SphereObstacle,
)
from .problem_values import ProblemValue, as_array
from .regions import CellwiseMaterial
from .tables import check_table, table_expression
from .valueforms import (
    PROFILES,
    PiecewiseLinear,
    PolynomialField,
    Ramp,
    Sine,
    check_field_value,
    check_time_value,
    field_value,
    time_value,
)

__all__ = [
    "CellwiseMaterial",
    "CylinderObstacle",
    "DampingPower",
    "DiagonalDamping",
    "DirichletCondition",
    "DirichletDofs",
    "LAWS",
    "LEVELS",
    "MAX_EXPONENT",
    "MOTION_KEYS",
    "MassMatrix",
    "Material",
    "MaterialConstants",
    "MovingObstacle",
    "OBSTACLES",
    "PROFILES",
    "PiecewiseLinear",
    "PlaneObstacle",
    "PolynomialField",
    "ProblemValue",
    "Ramp",
    "RayleighDamping",
    "SignedDistanceObstacle",
    "Sine",
    "SphereObstacle",
    "as_array",
    "averaged_stress",
    "cauchy_stress",
    "check_damping",
    "check_field_value",
    "check_table",
    "check_time_value",
    "damped_stable_step",
    "density",
    "expression",
    "field_value",
    "first_piola",
    "gauss_points",
    "has_text",
    "neo_hookean",
    "parse_expression",
    "parse_vector",
    "sigma",
    "sigma_n",
    "sigma_t",
    "strain_energy",
    "table_expression",
    "time_value",
    "to_ufl",
    "vector_expression",
    "von_mises",
    "von_mises_of",
]
