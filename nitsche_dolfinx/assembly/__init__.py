"""Assembly: compiled forms and their quadratures (`forms`), the systems F(x) = 0 a Newton
solver works on (`systems`, and `affine_system` with its constant Jacobian), the contact
Jacobian near the contact (`facet_jacobian`, `jacobian_sum`) and between bodies
(`pair_coupling`).
"""

from .affine_system import AffineSystem, StepForms
from .forms import CellResidualAtZero, Forms, split_cell_integrals
from .pair_coupling import PairCoupling, add_partner_terms
from .systems import FormSystem

__all__ = [
    "AffineSystem",
    "CellResidualAtZero",
    "FormSystem",
    "Forms",
    "PairCoupling",
    "StepForms",
    "add_partner_terms",
    "split_cell_integrals",
]
