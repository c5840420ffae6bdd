"""The model: `ContactProblem`, a mesh, a material, obstacles, bodies, loads and conditions,
and the UFL terms the steppers assemble.
"""

from .problem import ContactProblem

__all__ = [
    "ContactProblem",
]
