"""Linear elastic material and the stress quantities of the contact conditions.

Conventions of docs/method.md section 1: ``sigma(u) = lambda tr(eps(u)) I + 2 mu eps(u)``
(plane strain in 2D, ``sigma = E u'`` in 1D), ``sigma_n(u) = (sigma(u) n) . n_c``
with ``n`` the outward unit normal of the mesh and ``n_c`` the obstacle normal,
and ``sigma_t(u) = sigma(u) n - sigma_n(u) n_c``.

The formulas take a :class:`Material` (its values enter a form as numbers) or its
:class:`MaterialConstants` (runtime constants: a form compiled once serves every
material, docs/method.md section 10).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import ufl

from ..common.parameters import require, require_positive, require_real
from .hyperelastic import LAWS

__all__ = ["Material", "MaterialConstants", "eps", "sigma", "sigma_n", "sigma_t", "von_mises"]


@dataclass(frozen=True)
class Material:
    """Isotropic elastic material: linear (small strains) or hyperelastic (finite strains).

    Args:
        E: Young's modulus (> 0); with a hyperelastic ``law``, its value at small strains.
        nu: Poisson's ratio, in (-1, 1/2); likewise.
        rho: Density (> 0), per unit reference volume.
        law: ``"linear"`` (the default: linear elasticity, small strains), a name of
            :data:`~nitsche_dolfinx.physics.hyperelastic.LAWS` (``"svk"``: St Venant-Kirchhoff,
            ``"neo_hookean"``: compressible neo-Hookean) or a strain energy
            ``W(C, constants)``: a function of the 3 x 3 right Cauchy-Green tensor C (UFL;
            C_33 = 1 in 2D) and of the runtime constants (``lmbda``, ``mu``, ``E``, ``nu``)
            that returns W per unit reference volume (docs/method.md section 15).
    """

    E: float
    nu: float
    rho: float = 1.0
    law: str | Callable = "linear"

    def __post_init__(self):
        require_positive(self.E, "E", "Young's modulus")
        require_real(self.nu, "nu", "Poisson's ratio")
        require(-1.0 < self.nu < 0.5, "nu", self.nu, "Poisson's ratio must lie in (-1, 1/2)")
        require_positive(self.rho, "rho", "the density")
        require(
            callable(self.law) or (isinstance(self.law, str) and self.law in ("linear", *LAWS)),
            "law", self.law,
            f"the material law must be 'linear', one of {sorted(LAWS)} or a strain energy "
            "W(C, constants)",
        )  # fmt: skip

    @property
    def finite(self) -> bool:
        """Whether the law is hyperelastic (finite strains), not linear elasticity."""
        return not (isinstance(self.law, str) and self.law == "linear")

    @property
    def strain_energy(self) -> Callable | None:
        """The strain energy W(C, constants) of a hyperelastic law (None if linear)."""
        if not self.finite:
            return None
        return LAWS[self.law] if isinstance(self.law, str) else self.law

    @classmethod
    def from_lame(
        cls, lmbda: float, mu: float, rho: float = 1.0, law: str | Callable = "linear"
    ) -> Material:
        """The material with Lame coefficients ``lmbda`` and ``mu`` (and ``law``)."""
        require_positive(mu, "mu", "the shear modulus")
        require_real(lmbda, "lmbda", "the first Lame coefficient")
        # 3 lmbda + 2 mu > 0 (a positive bulk modulus) is E > 0 and -1 < nu < 1/2
        require(
            3 * lmbda + 2 * mu > 0,
            "lmbda",
            lmbda,
            f"the bulk modulus lmbda + 2 mu / 3 must be positive (mu={mu!r})",
        )
        E = mu * (3 * lmbda + 2 * mu) / (lmbda + mu)
        nu = lmbda / (2 * (lmbda + mu))
        return cls(E=E, nu=nu, rho=rho, law=law)

    @property
    def lmbda(self) -> float:
        """First Lame coefficient lambda."""
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    @property
    def mu(self) -> float:
        """Shear modulus mu."""
        return self.E / (2 * (1 + self.nu))


class MaterialConstants:
    """The parameters of a :class:`Material` as runtime constants of the forms, so that a
    form compiled for one material serves every other (a sweep over E, nu or rho
    compiles its forms once).

    Args:
        material: The material; kept as :attr:`material` for the code that needs
            numbers (mass matrices, time step estimates, messages).
        constant: Makes a constant of the forms from a number (for dolfinx:
            ``lambda value: fem.Constant(mesh, value)``).

    Attributes ``E``, ``nu``, ``lmbda``, ``mu`` and ``rho`` are the constants, with the
    numbers of ``material`` (``lmbda`` and ``mu`` computed as :class:`Material` does).
    """

    def __init__(self, material: Material, constant):
        self.material = material
        self.E = constant(material.E)
        self.nu = constant(material.nu)
        self.lmbda = constant(material.lmbda)
        self.mu = constant(material.mu)
        self.rho = constant(material.rho)


def eps(u):
    """Linearised strain eps(u) = sym(grad u)."""
    return ufl.sym(ufl.grad(u))


def sigma(u, material: Material | MaterialConstants):
    """Cauchy stress of linear elasticity; ``E u'`` on a 1D mesh, plane strain in 2D."""
    dim = u.ufl_shape[0]
    if dim == 1:
        return material.E * eps(u)
    return material.lmbda * ufl.tr(eps(u)) * ufl.Identity(dim) + 2 * material.mu * eps(u)


def sigma_n(stress, n, n_c):
    """Normal stress ``(sigma n) . n_c`` on the contact boundary."""
    return ufl.dot(ufl.dot(stress, n), n_c)


def sigma_t(stress, n, n_c):
    """Tangential stress ``sigma n - sigma_n n_c``."""
    return ufl.dot(stress, n) - sigma_n(stress, n, n_c) * n_c


def von_mises(u, material: Material | MaterialConstants):
    """Von Mises equivalent stress; the out-of-plane stress of plane strain is included in 2D."""
    dim = u.ufl_shape[0]
    stress = sigma(u, material)
    if dim == 1:
        return abs(stress[0, 0])
    if dim == 2:  # plane strain: sigma_zz = lambda tr(eps)
        szz = material.lmbda * ufl.tr(eps(u))
        s = ufl.as_matrix(
            [[stress[0, 0], stress[0, 1], 0], [stress[1, 0], stress[1, 1], 0], [0, 0, szz]]
        )
    else:
        s = stress
    deviator = s - ufl.tr(s) / 3 * ufl.Identity(3)
    return ufl.sqrt(3.0 / 2.0 * ufl.inner(deviator, deviator))
