"""Element variants of the six-node SE(3) shell, as objects: what a :class:`flexbody.body.ShellBody` computes
its elements with.

A variant is a small frozen dataclass that carries its metadata and its two kernels:

* ``name``: the variant for reports ("MITC6", "MITC6 (point membrane tying)", "MITC7", "no tying");
* ``key``: the value of the scene files' ``tying`` key that names it (:func:`variant_from_key`);
* ``maps``: its assumed-strain map A (7, 8, 17, 8) (:func:`flexbody.shell.reference.material.assumed_strain_maps`)
  and ``compressed_maps``, the numba kernel's form of it, both built once per object and cached on it;
* its capabilities, as attributes: ``supports_mixed_iteration`` (the iteration matrix with given
  Gauss-point stresses), ``supports_stress_forces`` (forces of given stresses), ``supports_linearized_stresses``
  (stresses C (eps + B dh) linearized along nodal motions), ``supports_wrinkling`` (the tension-field membrane
  law of ``ShellMaterial.wrinkling``, the batch's ``wrinkling``); ``condenses_bubble`` (an element unknown solved
  element by element, kept between evaluations as the warm start: :meth:`ElementVariant.element_state`);
* the element computations the body calls, on an :class:`ElementBatch` (all elements of a body in one state):
  ``forces``, ``mixed_forces``, ``stress_forces``, ``linearized_strains``, ``strains``, ``strain_energy``,
  ``warm_up``, each with the readable numpy kernel (:mod:`flexbody.shell.reference.loops`,
  :mod:`flexbody.shell.reference.bubble`) or the numba kernel (:mod:`flexbody.shell.kernels`,
  :mod:`flexbody.shell.kernels.mitc7`), as the batch's ``kernel`` says; and the readable kernel for one
  element (``element_force_tangent``, ``element_strains``, ``element_strain_energy``).

The variants:

=============================  =====================================================================  ==========
variant                        element                                                                scene key
=============================  =====================================================================  ==========
``MITC6()``                    MITC6: MITC6a transverse shear tying, "mean" membrane tying (default)  ``true``,
                                                                                                      ``"mean"``
``MITC6(membrane="point")``    MITC6 with the point-value membrane tying (locks in membrane-bending   ``"point"``
                               coupled thin shells: kept for comparison, docs/locking.md)
``MITC7()``                    MITC6 plus a condensed rotation bubble and the canonical shear tying   ``"mitc7"``
                               (:mod:`flexbody.shell.reference.bubble`): converges faster in bending, costs
                               about four MITC6 elements; no mixed iteration
``NoTying()``                  displacement-based strains (locks; for comparison)                     ``false``
=============================  =====================================================================  ==========

Scene files (TOML ``[element] tying``, the built-in scenes' ``tying`` parameter, ``--set tying=...``) keep
these keys; :func:`variant_from_key` maps them to the objects.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from flexbody.shell.reference import bubble, loops
from flexbody.shell.reference.material import assumed_strain_maps, section_stresses
from flexbody.shell.kernels.loops import (element_strains_batch, internal_force_tangent_batch,
                                          linearized_strains_batch)
from flexbody.shell.maps import CompressedMaps, SectionStiffness, compress_maps
from flexbody.chunks import Workspaces
from flexbody.shell.geometry import N_GAUSS, ElementGeometry
from flexbody.shell.kernels.mitc7.loops import condensed_force_tangent_batch
from flexbody.shell.kernels.mitc7.maps import MapNonzeros, map_nonzeros
from flexbody.shell.mitc6 import DEFAULT_SCHEME, MEMBRANE_SCHEMES

#: The values of the scene files' ``tying`` key (:func:`variant_from_key`), besides true and false.
VARIANT_KEYS = (*MEMBRANE_SCHEMES, "mitc7")


@dataclass
class ElementBatch:
    """All elements of a body in one state, as the variants' kernels take them.

    ``element_state`` is the variant's per-element state (:meth:`ElementVariant.element_state`; MITC7: the
    rotation bubbles of the last evaluation, the warm start of the next), owned by the body and updated in
    place by the variant; None for the variants without one.
    """

    x: np.ndarray               # (m, 6, 3) nodal positions, relative to the model origin
    frames: np.ndarray          # (m, 6, 3, 3) nodal frames R_I
    e_ref: np.ndarray           # (m, 17, 8) reference covariant strains
    to_cart: np.ndarray         # (m, 7, 8, 8) covariant-to-Cartesian maps at the Gauss points
    weights: np.ndarray         # (m, 7) Gauss weights times area elements
    section: np.ndarray         # (8, 8) section stiffness
    kernel: str = "numba"       # "numba" or "reference" (the readable numpy element)
    element_state: np.ndarray | None = None
    checked_section: SectionStiffness | None = None   # ``section`` checked once by its owner (the body)
    wrinkling: bool = False     # the tension-field membrane law (ShellMaterial.wrinkling) instead of the linear

    def __len__(self) -> int:
        return len(self.x)

    def geometry(self, e: int) -> ElementGeometry:
        """The reference data of element e."""
        return ElementGeometry(self.e_ref[e], self.to_cart[e], self.weights[e])

    def fast_arrays(self) -> tuple:
        """(x, frames, e_ref, to_cart, weights, section): the first arguments of the numba entry points."""
        return self.x, self.frames, self.e_ref, self.to_cart, self.weights, self.section

    def checked_arrays(self) -> tuple:
        """:meth:`fast_arrays` with the section as its :class:`flexbody.shell.maps.SectionStiffness` (checked
        here only when the batch's owner did not)."""
        section = self.checked_section if self.checked_section is not None else self.section
        return self.x, self.frames, self.e_ref, self.to_cart, self.weights, section


@runtime_checkable
class ElementVariant(Protocol):
    """The contract of an element variant (see the module docstring); :class:`flexbody.body.ShellBody` calls
    nothing else. The computations on a batch return per-element arrays in the nodal local frames, per node
    [u (3), theta (3)]."""

    name: str
    key: bool | str
    supports_mixed_iteration: bool
    supports_stress_forces: bool
    supports_linearized_stresses: bool
    supports_wrinkling: bool
    condenses_bubble: bool

    @property
    def maps(self) -> np.ndarray:
        """The assumed-strain map A (7, 8, 17, 8): Gauss-point strains from the evaluation points' (read-only)."""
        ...

    def element_state(self, n_elements: int) -> np.ndarray | None:
        """The element unknowns a body keeps between evaluations (m, ...), or None when there are none."""
        ...

    def forces(self, batch: ElementBatch, want_tangent: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Internal forces (m, 36) and, if asked, tangents (m, 36, 36) of a batch of elements (eq. numbers in
        :mod:`flexbody.shell.kernels`)."""
        ...

    def mixed_forces(self, batch: ElementBatch, stress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forces, tangents and the Gauss-point stress terms of the mixed Newton iteration at the given
        independent stresses (m, 7, 8)."""
        ...

    def stress_forces(self, batch: ElementBatch, stress: np.ndarray) -> np.ndarray:
        """Internal forces (m, 36) of given Gauss-point stress resultants (m, 7, 8) at the batch's state."""
        ...

    def linearized_strains(self, batch: ElementBatch, dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-point strains (m, 7, 8) and their linearization along the local nodal motions dh (m, 36)."""
        ...

    def strains(self, batch: ElementBatch) -> np.ndarray:
        """Cartesian Gauss-point strains (m, 7, 8) of the batch at its state."""
        ...

    def strain_energy(self, batch: ElementBatch, strain_kernel: str = "reference") -> float:
        """Strain energy of the batch, with the readable (``"reference"``) or the numba (``"numba"``) strains."""
        ...

    def warm_up(self, batch: ElementBatch) -> None:
        """Compile (or load from the cache) the kernels this variant uses, on a small batch."""
        ...

    def element_force_tangent(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Force (36) and tangent (36, 36) of one element with the readable numpy kernel (``wrinkling``: the
        tension-field membrane law)."""
        ...

    def element_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                        bubble: np.ndarray | None = None) -> np.ndarray:
        """Gauss-point strains (7, 8) of one element with the readable numpy kernel."""
        ...

    def element_linearized_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                                   dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Strains (7, 8) of one element and their linearization along dh (36), readable kernel."""
        ...

    def element_strain_energy(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> float:
        """Strain energy of one element with the readable numpy kernel (``wrinkling``: the relaxed energy)."""
        ...


def _read_only(A: np.ndarray) -> np.ndarray:
    A.flags.writeable = False
    return A


def _energy(weights: np.ndarray, eps: np.ndarray, section: np.ndarray, wrinkling: bool = False) -> float:
    """1/2 sum_e sum_g w_g eps_g^T C eps_g of the Gauss-point strains eps (m, 7, 8); with ``wrinkling`` the
    relaxed energy 1/2 sum w_g eps_g^T sigma(eps_g) of the tension-field membrane."""
    if wrinkling:
        return 0.5 * float(np.einsum("eg,egi,egi->", weights, eps, section_stresses(eps, section, True)))
    # C eps_g first: the four-operand einsum "eg,egi,ij,egj->" loops over every index combination (1.7 ms against
    # 0.14 ms for 256 elements, an energy record at every output step of a dynamic run)
    return 0.5 * float(np.einsum("eg,egi,egi->", weights, eps @ section.T, eps))


class _AssumedStrains:
    """The variants without element unknowns: the strains are the assumed-strain map A applied to the
    covariant strains of the evaluation points (MITC6, NoTying). A subclass sets ``maps``."""

    supports_mixed_iteration: ClassVar[bool] = True
    supports_stress_forces: ClassVar[bool] = True
    supports_linearized_stresses: ClassVar[bool] = True
    supports_wrinkling: ClassVar[bool] = True
    condenses_bubble: ClassVar[bool] = False
    maps: np.ndarray

    @cached_property
    def compressed_maps(self) -> CompressedMaps:
        """The numba kernel's form of ``maps`` (:class:`flexbody.shell.maps.CompressedMaps`), built once."""
        return compress_maps(self.maps)

    @cached_property
    def workspaces(self) -> Workspaces:
        """The numba kernels' per-thread scratch arrays (:class:`flexbody.chunks.Workspaces`), reused by every
        evaluation of this variant's bodies."""
        return Workspaces()

    def element_state(self, n_elements: int) -> None:
        """The element unknowns a body keeps between evaluations (m, ...), or None when there are none."""
        return None

    # -- batches ------------------------------------------------------------------------------------------
    def forces(self, batch: ElementBatch, want_tangent: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Internal forces (m, 36) and tangents (m, 36, 36) (None without ``want_tangent``)."""
        if batch.kernel == "numba":
            return internal_force_tangent_batch(*batch.checked_arrays(), self.compressed_maps, want_tangent,
                                                workspaces=self.workspaces, wrinkling=batch.wrinkling)
        m = len(batch)
        f = np.zeros((m, 36))
        K = np.zeros((m, 36, 36)) if want_tangent else None
        for e in range(m):
            fe, Ke = loops.force_tangent(batch.x[e], batch.frames[e], batch.geometry(e), batch.section, self.maps,
                                         wrinkling=batch.wrinkling)
            f[e] = fe
            if want_tangent:
                K[e] = Ke
        return f, K

    def mixed_forces(self, batch: ElementBatch, stress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The mixed Newton iteration's terms for Gauss-point stresses (m, 7, 8): the forces of the strains
        (m, 36), the iteration matrices (m, 36, 36), the forces of the given stresses (m, 36)."""
        if batch.kernel == "numba":
            return internal_force_tangent_batch(*batch.checked_arrays(), self.compressed_maps, True, stress,
                                                workspaces=self.workspaces, wrinkling=batch.wrinkling)
        parts = [loops.force_tangent(batch.x[e], batch.frames[e], batch.geometry(e), batch.section,
                                     self.maps, stress=stress[e], wrinkling=batch.wrinkling)
                 for e in range(len(batch))]
        return tuple(np.array([p[k] for p in parts]) for k in range(3))

    def stress_forces(self, batch: ElementBatch, stress: np.ndarray) -> np.ndarray:
        """The forces sum_g w_g B_g^T stress_g (m, 36) of given Gauss-point stresses (m, 7, 8), no tangent."""
        if batch.kernel == "numba":
            return internal_force_tangent_batch(*batch.checked_arrays(), self.compressed_maps, False, stress,
                                                workspaces=self.workspaces, wrinkling=batch.wrinkling)[2]
        return self.mixed_forces(batch, stress)[2]

    def linearized_strains(self, batch: ElementBatch, dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Strains eps_g (m, 7, 8) and their increments B_g dh (m, 7, 8) along local nodal motions dh (m, 36)."""
        if batch.kernel == "numba":
            return linearized_strains_batch(batch.x, batch.frames, batch.e_ref, batch.to_cart,
                                            self.compressed_maps, dh, workspaces=self.workspaces)
        m = len(batch)
        pairs = [loops.linearized_strains(batch.x[e], batch.frames[e], batch.geometry(e), dh[e], self.maps)
                 for e in range(m)]
        return (np.array([p[0] for p in pairs]).reshape(m, N_GAUSS, 8),
                np.array([p[1] for p in pairs]).reshape(m, N_GAUSS, 8))

    def strains(self, batch: ElementBatch) -> np.ndarray:
        """The Cartesian strains (m, 7, 8) at the Gauss points."""
        return self.linearized_strains(batch, np.zeros((len(batch), 36)))[0]

    def strain_energy(self, batch: ElementBatch, strain_kernel: str = "reference") -> float:
        """The elastic energy of the batch, from the numpy element ("reference", element by element) or the
        numba strain kernel ("numba")."""
        if strain_kernel == "numba":
            eps = element_strains_batch(batch.x, batch.frames, batch.e_ref, batch.to_cart, self.compressed_maps,
                                        workspaces=self.workspaces)
            return _energy(batch.weights, eps, batch.section, batch.wrinkling)
        total = 0.0
        for e in range(len(batch)):
            total += loops.strain_energy(batch.x[e], batch.frames[e], batch.geometry(e), batch.section, self.maps,
                                         wrinkling=batch.wrinkling)
        return total

    def warm_up(self, batch: ElementBatch) -> None:
        """Compile (or load) the numba kernels this variant uses, on the batch (one element is enough): the
        element loop's specialisation with the tension-field law when ``batch.wrinkling``, else without it."""
        for want_tangent, stress in ((True, None), (False, None), (False, np.zeros((len(batch), N_GAUSS, 8)))):
            internal_force_tangent_batch(*batch.checked_arrays(), self.compressed_maps, want_tangent, stress,
                                         workspaces=self.workspaces, wrinkling=batch.wrinkling)
        linearized_strains_batch(batch.x, batch.frames, batch.e_ref, batch.to_cart, self.compressed_maps,
                                 np.zeros((len(batch), 36)), workspaces=self.workspaces)

    # -- one element, readable kernel ---------------------------------------------------------------------
    def element_force_tangent(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Internal force (36,) and tangent (36, 36) of one element (numpy reference; ``wrinkling``: the
        tension-field membrane law)."""
        return loops.force_tangent(x, frames, geom, section, self.maps, wrinkling=wrinkling)

    def element_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                        bubble: np.ndarray | None = None) -> np.ndarray:
        """Cartesian strains (7, 8) at the Gauss points of one element (numpy reference; no bubble)."""
        if bubble is not None:
            raise ValueError(f"{self!r} has no rotation bubble, got bubble={bubble!r}")
        return loops.element_strains(x, frames, geom, self.maps)

    def element_linearized_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                                   dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Strains (7, 8) of one element and their linearization B_g dh along dh (36,) or (36, k)."""
        return loops.linearized_strains(x, frames, geom, dh, self.maps)

    def element_strain_energy(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> float:
        """Elastic energy of one element (numpy reference; ``wrinkling``: the relaxed energy)."""
        return loops.strain_energy(x, frames, geom, section, self.maps, wrinkling=wrinkling)


@dataclass(frozen=True)
class MITC6(_AssumedStrains):
    """MITC6: the MITC6a transverse shear tying and a membrane tying scheme (``mitc6.MEMBRANE_SCHEMES``):
    "mean" (the default: element means of the membrane strains, no membrane locking on the benchmarks) or
    "point" (point values at interior tying points; locks in thin membrane-bending shells, docs/locking.md)."""

    membrane: str = DEFAULT_SCHEME

    def __post_init__(self) -> None:
        if self.membrane not in MEMBRANE_SCHEMES:
            raise ValueError(f"MITC6 membrane must be one of {', '.join(map(repr, MEMBRANE_SCHEMES))}, "
                             f"got {self.membrane!r}")

    @property
    def name(self) -> str:
        """The variant's name in reports (e.g. "MITC6", "MITC6 (point membrane tying)")."""
        return "MITC6" if self.membrane == DEFAULT_SCHEME else f"MITC6 ({self.membrane} membrane tying)"

    @property
    def key(self) -> bool | str:
        """The value of the scene files' ``tying`` key that gives this variant (:func:`variant_from_key`)."""
        return True if self.membrane == DEFAULT_SCHEME else self.membrane

    @cached_property
    def maps(self) -> np.ndarray:
        """The assumed-strain map A (7, 8, 17, 8) (read-only)."""
        return _read_only(assumed_strain_maps(self.membrane, "mitc6"))


@dataclass(frozen=True)
class NoTying(_AssumedStrains):
    """Displacement-based strains (no assumed strains): locks in bending of thin shells; for comparison."""

    name: ClassVar[str] = "no tying"
    key: ClassVar[bool] = False

    @cached_property
    def maps(self) -> np.ndarray:
        """The assumed-strain map A (7, 8, 17, 8): the Gauss points' own strains (read-only)."""
        return _read_only(assumed_strain_maps(None, None))


@dataclass(frozen=True)
class MITC7:
    """MITC7: MITC6 plus a cubic rotation bubble, condensed element by element, and the canonical shear tying
    (:mod:`flexbody.shell.reference.bubble`; membrane: the default scheme). The bubbles of the last evaluation are the
    warm start of the next (the results do not depend on it beyond the bubble tolerance). It has no mixed
    iteration, no forces of given stresses and no linearized stresses: its bubble is condensed against the
    strains' own stresses."""

    name: ClassVar[str] = "MITC7"
    key: ClassVar[str] = "mitc7"
    supports_mixed_iteration: ClassVar[bool] = False
    supports_stress_forces: ClassVar[bool] = False
    supports_linearized_stresses: ClassVar[bool] = False
    supports_wrinkling: ClassVar[bool] = False
    condenses_bubble: ClassVar[bool] = True

    @property
    def maps(self) -> np.ndarray:
        """The assumed-strain map A (7, 8, 17, 8) (read-only, :data:`flexbody.shell.reference.bubble.MITC7_MAPS`)."""
        return bubble.MITC7_MAPS

    @cached_property
    def compressed_maps(self) -> MapNonzeros:
        """The numba kernel's form of ``maps`` (:class:`flexbody.shell.kernels.mitc7.maps.MapNonzeros`), built
        once."""
        return map_nonzeros(self.maps)

    def element_state(self, n_elements: int) -> np.ndarray:
        """The rotation bubbles b (m, 2), zero: the warm start of the first evaluation."""
        return np.zeros((n_elements, 2))

    def _unavailable(self, what: str) -> ValueError:
        return ValueError(f"the MITC7 element (tying = 'mitc7') does not provide {what}: its rotation bubble is "
                          "condensed against the strains' own stresses")

    def forces(self, batch: ElementBatch, want_tangent: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Condensed internal forces (m, 36) and tangents (m, 36, 36), the bubbles solved from the warm start
        ``batch.element_state`` and written back to it. An element whose bubble does not converge returns NaN
        (a non-finite residual stops Newton) and keeps its start value."""
        if batch.wrinkling:
            raise self._unavailable("the tension-field membrane law (wrinkling)")
        bubbles = batch.element_state
        if batch.kernel == "numba":
            f, K, b = condensed_force_tangent_batch(*batch.fast_arrays(), self.compressed_maps, bubbles,
                                                    want_tangent)
            bubbles[...] = b
            return f, (K if want_tangent else None)
        m = len(batch)
        f = np.zeros((m, 36))
        K = np.zeros((m, 36, 36)) if want_tangent else None
        for e in range(m):
            try:
                fe, Ke, bubbles[e] = bubble.condense(batch.x[e], batch.frames[e], batch.geometry(e), batch.section,
                                                     bubbles[e])
            except FloatingPointError:
                f[e] = np.nan
                continue
            f[e] = fe
            if want_tangent:
                K[e] = Ke
        return f, K

    def mixed_forces(self, batch: ElementBatch, stress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Forces, tangents and the Gauss-point stress terms of the mixed Newton iteration at the given
        independent stresses (m, 7, 8)."""
        raise self._unavailable("the mixed Newton iteration")

    def stress_forces(self, batch: ElementBatch, stress: np.ndarray) -> np.ndarray:
        """Internal forces (m, 36) of given Gauss-point stress resultants (m, 7, 8) at the batch's state."""
        raise self._unavailable("forces of given stresses")

    def linearized_strains(self, batch: ElementBatch, dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-point strains (m, 7, 8) and their linearization along the local nodal motions dh (m, 36)."""
        raise self._unavailable("linearized stresses")

    def strains(self, batch: ElementBatch) -> np.ndarray:
        """The Cartesian strains (m, 7, 8) at the Gauss points, at the bubbles in equilibrium with the state
        (found by the cheap warm-started force-only evaluation; the strains from the numpy element)."""
        self.forces(batch, want_tangent=False)
        return np.array([self.element_strains(batch.x[e], batch.frames[e], batch.geometry(e),
                                              batch.element_state[e]) for e in range(len(batch))])

    def strain_energy(self, batch: ElementBatch, strain_kernel: str = "reference") -> float:
        """The elastic energy at the condensed bubbles (:meth:`strains`, whatever ``strain_kernel``)."""
        return _energy(batch.weights, self.strains(batch), batch.section)

    def warm_up(self, batch: ElementBatch) -> None:
        """Compile (or load) the numba kernels this variant uses, on the batch (one element is enough)."""
        for want_tangent in (True, False):
            condensed_force_tangent_batch(*batch.fast_arrays(), self.compressed_maps, np.zeros((len(batch), 2)),
                                          want_tangent)

    # -- one element, readable kernel ---------------------------------------------------------------------
    def element_force_tangent(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Condensed internal force (36,) and tangent (36, 36) of one element (numpy reference; no wrinkling)."""
        if wrinkling:
            raise self._unavailable("the tension-field membrane law (wrinkling)")
        return bubble.condensed_force_tangent(x, frames, geom, section)

    def element_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                        bubble: np.ndarray | None = None) -> np.ndarray:
        """Cartesian strains (7, 8) at the Gauss points of one element for the rotation bubble b (2,)
        (:func:`flexbody.shell.reference.bubble.condensed_bubble`)."""
        if bubble is None:
            raise ValueError("MITC7 strains need the rotation bubble: pass bubble=condensed_bubble(...)")
        return loops.element_strains(x, frames, geom, self.maps, bubble)

    def element_linearized_strains(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                                   dh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Strains (7, 8) of one element and their linearization along dh (36), readable kernel."""
        raise self._unavailable("linearized stresses")

    def element_strain_energy(self, x: np.ndarray, frames: np.ndarray, geom: ElementGeometry,
                              section: np.ndarray, wrinkling: bool = False) -> float:
        """Elastic energy of one element at its condensed bubble (numpy reference; no wrinkling)."""
        if wrinkling:
            raise self._unavailable("the tension-field membrane law (wrinkling)")
        b = bubble.condensed_bubble(x, frames, geom, section)
        return loops.strain_energy(x, frames, geom, section, self.maps, b)


def variant_from_key(value: object, name: str = "tying") -> ElementVariant:
    """The element variant that a scene file's ``tying`` value names (``name``: the key or argument that gave
    it, for the error message).

    ======================  ==========================
    ``tying``               variant
    ======================  ==========================
    ``True``, ``"mean"``    ``MITC6()``
    ``"point"``             ``MITC6(membrane="point")``
    ``False``               ``NoTying()``
    ``"mitc7"``             ``MITC7()``
    ======================  ==========================

    A variant object is returned as it is. Anything else raises a one-line ValueError naming the value and
    the allowed ones.
    """
    if isinstance(value, ElementVariant):
        return value
    if isinstance(value, (bool, np.bool_)):
        return MITC6() if value else NoTying()
    if isinstance(value, str):
        if value in MEMBRANE_SCHEMES:
            return MITC6(membrane=value)
        if value == "mitc7":
            return MITC7()
    raise ValueError(f"{name} must be true, false or one of {', '.join(map(repr, VARIANT_KEYS))}, got {value!r}")
