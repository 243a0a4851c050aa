"""Isotropic linear elastic stress resultants of a Reissner-Mindlin shell (paper Eq. 14)."""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np


@dataclass(frozen=True)
class ShellMaterial:
    """Isotropic elastic shell section.

    Parameters
    ----------
    young : Young's modulus E > 0
    poisson : Poisson's ratio, -1 < nu < 0.5
    thickness : shell thickness h > 0
    density : mass density rho >= 0 (only dynamics uses it)
    shear_correction : transverse shear correction factor (5/6)
    wrinkling : the tension-field membrane law (a film that wrinkles instead of carrying compression:
        :func:`flexbody.shell.reference.material.tension_field_membrane`, docs/theory.md); bending and
        transverse shear stay linear. False: the linear law.
    """

    young: float
    poisson: float
    thickness: float
    density: float = 0.0
    shear_correction: float = 5.0 / 6.0
    wrinkling: bool = False

    def __post_init__(self) -> None:
        for name in ("young", "poisson", "thickness", "density", "shear_correction"):
            value = getattr(self, name)
            if (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.floating, np.integer))
                    or not math.isfinite(value)):
                raise ValueError(f"material {name} must be a finite number, got {value!r}")
        if not isinstance(self.wrinkling, (bool, np.bool_)):
            raise ValueError(f"material wrinkling must be true or false, got {self.wrinkling!r}")
        object.__setattr__(self, "wrinkling", bool(self.wrinkling))
        if self.young <= 0:
            raise ValueError(f"material young (E) must be > 0, got {self.young!r}")
        if not -1.0 < self.poisson < 0.5:
            raise ValueError(f"material poisson (nu) must lie in (-1, 0.5), got {self.poisson!r}")
        if self.thickness <= 0:
            raise ValueError(f"material thickness must be > 0, got {self.thickness!r}")
        if self.density < 0:
            raise ValueError(f"material density must be >= 0, got {self.density!r}")
        if self.shear_correction <= 0:
            raise ValueError(f"material shear_correction must be > 0, got {self.shear_correction!r}")

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + nu))."""
        return self.young / (2.0 * (1.0 + self.poisson))

    def plane_stress(self) -> np.ndarray:
        """Plane-stress matrix for [e11, e22, 2 e12] (Voigt, engineering shear)."""
        nu = self.poisson
        return self.young / (1 - nu**2) * np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])

    def membrane(self) -> np.ndarray:
        """C_m = h C (membrane forces per unit length)."""
        return self.thickness * self.plane_stress()

    def bending(self) -> np.ndarray:
        """C_b = h^3/12 C (bending moments per unit length)."""
        return self.thickness**3 / 12.0 * self.plane_stress()

    def shear(self) -> np.ndarray:
        """C_s = k G h I_2 (transverse shear forces per unit length)."""
        return self.shear_correction * self.shear_modulus * self.thickness * np.eye(2)

    def section(self) -> np.ndarray:
        """Block-diagonal 8x8 matrix for [membrane (3), bending (3), shear (2)] Cartesian strains."""
        c = np.zeros((8, 8))
        c[:3, :3] = self.membrane()
        c[3:6, 3:6] = self.bending()
        c[6:, 6:] = self.shear()
        return c
