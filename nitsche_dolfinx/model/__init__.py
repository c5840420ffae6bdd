"""The model: `ContactProblem` (`problem`), a mesh, a material, obstacles, bodies, loads and
conditions, and the UFL terms the steppers assemble; its parts: the terms of the weak form
(`terms`), the obstacles and contact pairs (`contacts`), the loads, conditions and initial
values (`data`).
"""

from .problem import ContactProblem

__all__ = [
    "ContactProblem",
]
