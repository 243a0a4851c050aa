"""The flexible shell body: mesh + material + reference geometry + nodal states on SE(3).

A ``ShellBody`` evaluates the element internal forces and tangents in the nodal local frames
(per node [u (3), theta (3)], drilling component included); the assembly decides which DoFs are solved.
"""

from __future__ import annotations

import warnings
from dataclasses import InitVar, dataclass, field

import numpy as np

from flexbody.frames import frames_from_directors
from flexbody.lie import kernels
from flexbody.mesh import Tri6Mesh
from flexbody.shell.geometry import N_GAUSS, element_geometry_batch
from flexbody.shell.maps import SectionStiffness, checked_section
from flexbody.shell.material import ShellMaterial
from flexbody.shell.reference.material import section_increments, section_stresses
from flexbody.shell.variants import MITC6, ElementBatch, ElementVariant, variant_from_key


@dataclass
class ShellState:
    """Nodal configuration: positions x_I (n, 3) and frames R_I (n, 3, 3); director t_I = R_I e3.

    ``x`` is in the user's coordinates. The solvers compute with the positions relative to a model origin
    (:func:`model_origin`), ``local``, which the state carries at full precision: far from the origin
    (x ~ 1e5 L) the rounding of x itself (1e-11 L) would be membrane-strain noise far above a thin shell's
    bending forces. ``x`` is ``local + origin`` rounded; a node whose ``x`` was written directly since
    takes ``x - origin`` (:meth:`relative_positions`).
    """

    x: np.ndarray
    frames: np.ndarray
    #: Stress resultants (m, 7, 8) at the Gauss points iterated as unknowns of their own by the mixed Newton
    #: iteration (:meth:`ShellBody.stresses`); None outside it. Only the iteration matrix reads them.
    stress: np.ndarray | None = None
    local: np.ndarray | None = None    # positions relative to ``origin`` (None: x - origin)
    origin: np.ndarray | None = None   # (3,) the model origin (None: the coordinate origin)

    def __post_init__(self) -> None:
        if self.origin is None:
            self.origin = np.zeros(3)
        if self.local is None:
            self.local = np.asarray(self.x, dtype=float) - self.origin

    def copy(self) -> "ShellState":
        """A deep copy (the origin is shared: it never changes)."""
        return ShellState(self.x.copy(), self.frames.copy(), None if self.stress is None else self.stress.copy(),
                          self.local.copy(), self.origin)

    def relative_positions(self, origin: np.ndarray | None = None) -> np.ndarray:
        """The positions relative to ``origin`` (default: the state's own), at full precision where the
        state carries them (``local``, for the nodes whose ``x`` was not written directly since)."""
        if origin is not None and not np.array_equal(origin, self.origin):
            return self.x - origin
        changed = self.x != self.local + self.origin
        if changed.any():                                # rare: the row test only then
            stale = np.any(changed, axis=1)
            self.local[stale] = self.x[stale] - self.origin
        return self.local

    @property
    def directors(self) -> np.ndarray:
        """The directors t_I = R_I e3 (n, 3)."""
        return self.frames[:, :, 2]


@dataclass
class ReferenceGeometry:
    """Per-element reference data, stacked over the elements."""

    e_ref: np.ndarray      # (m, 17, 8)
    to_cart: np.ndarray    # (m, 7, 8, 8)
    weights: np.ndarray    # (m, 7)


def model_origin(nodes: np.ndarray) -> np.ndarray:
    """The origin the body computes from: the centre of the nodes' bounding box, rounded to a multiple of
    q = 2^ceil(log2(size)) (q >= the model size). Relative coordinates are then at most 1.5 q, the
    subtraction nodes - origin is exact for a model far from the coordinate origin, and a model near it
    (centre within q / 2) keeps the origin 0 (bit for bit its old results)."""
    nodes = np.asarray(nodes, dtype=float)
    size = float(np.ptp(nodes, axis=0).max()) or 1.0
    q = 2.0 ** np.ceil(np.log2(size))
    centre = 0.5 * (nodes.min(axis=0) + nodes.max(axis=0))
    return np.round(centre / q) * q + 0.0


def build_reference(mesh: Tri6Mesh, frames0: np.ndarray, origin: np.ndarray | None = None) -> ReferenceGeometry:
    """The elements' reference data, from the node positions relative to ``origin`` (default 0), all
    elements at once (:func:`flexbody.shell.geometry.element_geometry_batch`; element by element it is
    :func:`flexbody.shell.geometry.element_geometry`)."""
    nodes = mesh.nodes if origin is None else mesh.nodes - origin
    conn = mesh.elements
    return ReferenceGeometry(*element_geometry_batch(nodes[conn], frames0[conn]))


@dataclass
class ShellBody:
    """A shell body.

    Parameters
    ----------
    mesh : the six-node triangle mesh (reference configuration)
    material : section properties
    element : the element variant (:mod:`flexbody.shell.variants`): ``MITC6()`` (default; or
        ``MITC6(membrane="point")``), ``MITC7()`` (MITC6 plus a condensed rotation bubble and the canonical
        shear tying: converges faster in bending, costs more per element) or ``NoTying()``
        (displacement-based strains, locks)
    frame_axis : axis projected onto the tangent planes to orient the nodal frames (default: automatic)
    kernel : "numba" (fast) or "reference" (the readable numpy element)
    tying : deprecated, the scene files' key for the element (True, False, "mean", "point", "mitc7"):
        mapped by :func:`flexbody.shell.variants.variant_from_key`, with a DeprecationWarning. An init-only
        argument: the body keeps ``element`` (``element.key`` is the scene key)
    """

    mesh: Tri6Mesh
    material: ShellMaterial
    element: ElementVariant = MITC6()
    frame_axis: np.ndarray | None = None
    kernel: str = "numba"
    tying: InitVar[bool | str | None] = None
    frames0: np.ndarray = field(init=False)
    reference: ReferenceGeometry = field(init=False, repr=False)
    origin: np.ndarray = field(init=False)   # the model origin of the computation (:func:`model_origin`)
    # the material's section stiffness checked once (:func:`flexbody.shell.maps.checked_section`), and of which
    # material: a body given another material checks that one's anew
    _section: tuple[ShellMaterial, SectionStiffness] | None = field(init=False, default=None, repr=False,
                                                                     compare=False)

    def __post_init__(self, tying: bool | str | None) -> None:
        if not isinstance(self.mesh, Tri6Mesh):
            raise TypeError(f"mesh must be a Tri6Mesh, got {type(self.mesh).__name__}")
        if not isinstance(self.material, ShellMaterial):
            raise TypeError(f"material must be a ShellMaterial, got {type(self.material).__name__}")
        if tying is not None or not isinstance(self.element, ElementVariant):
            key = self.element if tying is None else tying
            if tying is not None and self.element != MITC6():
                raise ValueError(f"give the element variant once: element={self.element!r} and tying={tying!r}")
            if tying is None and not isinstance(key, (bool, np.bool_, str)):
                raise TypeError("element must be an element variant of flexbody.shell.variants (MITC6(), "
                                f"MITC6(membrane='point'), MITC7(), NoTying()), got {key!r}")
            given = "tying" if tying is not None else "element"
            self.element = variant_from_key(key, given)
            warnings.warn(f"ShellBody({given}={key!r}) is deprecated: pass element={self.element!r} "
                          "(flexbody.shell.variants)", DeprecationWarning, stacklevel=3)
        if self.kernel not in ("numba", "reference"):
            raise ValueError(f"kernel must be 'numba' or 'reference', got {self.kernel!r}")
        if self.material.wrinkling and not self.element.supports_wrinkling:
            raise ValueError(f"the tension-field membrane (material wrinkling = true) needs an MITC6 element, not "
                             f"{self.element.name} (tying = {self.element.key!r})")
        self.frames0 = frames_from_directors(self.mesh.directors, self.frame_axis)
        self.origin = model_origin(self.mesh.nodes)
        self.reference = build_reference(self.mesh, self.frames0, self.origin)
        # the variant's per-element state (MITC7: the condensed bubbles of the last evaluation, the warm start
        # of the next one; the results do not depend on it beyond the bubble tolerance, flexbody.shell.reference.bubble)
        self._element_state = self.element.element_state(self.mesh.n_elements)

    @property
    def element_name(self) -> str:
        """The element variant, for reports: "MITC6", "MITC6 (point membrane tying)", "MITC7" or "no tying"."""
        return self.element.name

    def set_reference_frames(self, nodes: np.ndarray, frames: np.ndarray) -> None:
        """Override reference frames of some nodes (e.g. to align with a symmetry plane) and rebuild."""
        self.frames0 = self.frames0.copy()
        self.frames0[nodes] = frames
        self.reference = build_reference(self.mesh, self.frames0, self.origin)

    # -- state -------------------------------------------------------------------------------------------
    def initial_state(self) -> ShellState:
        """The reference configuration: the mesh's positions and the reference frames."""
        x = self.mesh.nodes.astype(float)
        return ShellState(x.copy(), self.frames0.copy(), local=x - self.origin, origin=self.origin)

    @property
    def n_nodes(self) -> int:
        """The number of nodes of the mesh."""
        return self.mesh.n_nodes

    # -- element evaluation -------------------------------------------------------------------------------
    @property
    def supports_mixed_iteration(self) -> bool:
        """Whether the mixed Newton iteration (independent Gauss-point stresses) is available: the MITC6
        variants with the linear law; MITC7 condenses its bubble against the strains' own stresses, and the
        tension-field membrane (``material.wrinkling``) is not linear (the iteration's stress update
        C (eps + B dh) assumes it is): the solvers then take the displacement iteration."""
        return self.element.supports_mixed_iteration and not self.material.wrinkling

    def element_forces(self, state: ShellState, want_tangent: bool = True):
        """Element internal forces (m, 36) and tangents (m, 36, 36) in the nodal local frames."""
        return self.element.forces(self._batch(state), want_tangent)

    def mixed_element_forces(self, state: ShellState,
                             stress: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The mixed Newton iteration's element terms for given Gauss-point stress resultants (m, 7, 8):
        the internal forces of the strains f (m, 36), the iteration matrices K (m, 36, 36), whose
        geometric terms carry the given stresses, and the forces of these stresses f_stress (m, 36)
        (:func:`flexbody.shell.reference.loops.force_tangent`). MITC6 variants only."""
        batch = self._batch(state)
        if self.material.wrinkling:
            raise ValueError("the mixed Newton iteration assumes a linear section law; the tension-field membrane "
                             "(material wrinkling = true) is not: use the displacement iteration")
        if not self.element.supports_mixed_iteration:
            return self.element.mixed_forces(batch, stress)          # raises: says why
        stress = np.asarray(stress, dtype=float)
        if stress.shape != (len(batch), N_GAUSS, 8):
            raise ValueError(f"stress must have shape ({len(batch)}, {N_GAUSS}, 8), got {stress.shape}")
        return self.element.mixed_forces(batch, stress)

    def stress_forces(self, state: ShellState, stress: np.ndarray) -> np.ndarray:
        """The element forces sum_g w_g B_g^T stress_g (m, 36) of given Gauss-point stress resultants
        (m, 7, 8), in the nodal local frames, without a tangent (the reference kernel takes
        :meth:`mixed_element_forces`). MITC6 variants."""
        if self.kernel != "numba":
            return self.mixed_element_forces(state, stress)[2]
        return self.element.stress_forces(self._batch(state), np.asarray(stress, dtype=float))

    def _batch(self, state: ShellState) -> ElementBatch:
        """The elements in ``state``: nodal positions (relative to the model origin) and frames per element,
        the reference data, the section, the kernel and the variant's element state."""
        conn = self.mesh.elements
        ref = self.reference
        section = self._section_stiffness()
        # np.take: the same gather as x[conn], 3-4x faster for the (m, 6) index array
        x_el = np.take(self.relative_positions(state), conn, axis=0)
        return ElementBatch(x_el, np.take(state.frames, conn, axis=0), ref.e_ref, ref.to_cart, ref.weights,
                            section.matrix, self.kernel, self._element_state, section, self.material.wrinkling)

    def _section_stiffness(self) -> SectionStiffness:
        """The material's section stiffness, checked once (shape, symmetry, block coupling) for the kernels."""
        if self._section is None or self._section[0] is not self.material:
            self._section = (self.material, checked_section(self.material.section()))
        return self._section[1]

    def relative_positions(self, state: ShellState) -> np.ndarray:
        """The state's positions relative to the model origin (n, 3): what the elements compute with."""
        return state.relative_positions(self.origin)

    def stresses(self, state: ShellState, dh_el: np.ndarray | None = None) -> np.ndarray:
        """Stress resultants C (eps_g + B_g dh) (m, 7, 8) at the Gauss points: of the state (dh_el None), or
        linearized along local nodal motions dh_el (m, 36), per node [du, dtheta] -- the stress update of
        the mixed Newton iteration (MITC6 variants). With the tension-field membrane (``material.wrinkling``)
        sigma(eps_g) + C_t(eps_g) B_g dh (:mod:`flexbody.shell.reference.material`)."""
        eps, deps = self._linearized_strains(state, dh_el)
        section = self.material.section()
        if not self.material.wrinkling:
            return (eps + deps) @ section.T
        return section_stresses(eps, section, True) + section_increments(eps, deps, section, True)

    def stress_rates(self, state: ShellState, hdot_el: np.ndarray) -> np.ndarray:
        """The linearized stress increments C B_g hdot (m, 7, 8) of local nodal motions hdot_el (m, 36) alone
        (without the stresses of the state): with nodal velocities, the Kelvin-Voigt stresses of the strain
        rates B v (zero for a rigid velocity). MITC6 variants. With the tension-field membrane the point
        tangent C_t(eps_g) of the state takes the place of C."""
        eps, deps = self._linearized_strains(state, hdot_el)
        return section_increments(eps, deps, self.material.section(), self.material.wrinkling)

    def _linearized_strains(self, state: ShellState, dh_el: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Strains eps_g (m, 7, 8) of the state and their linearized increments B_g dh (m, 7, 8)."""
        batch = self._batch(state)
        if not self.element.supports_linearized_stresses:
            return self.element.linearized_strains(batch, dh_el)      # raises: says why
        m = len(batch)
        dh_el = np.zeros((m, 36)) if dh_el is None else np.asarray(dh_el, dtype=float)
        if dh_el.shape != (m, 36):
            raise ValueError(f"dh_el must have shape ({m}, 36), got {dh_el.shape}")
        return self.element.linearized_strains(batch, dh_el)

    def strains(self, state: ShellState) -> np.ndarray:
        """The Cartesian strains (m, 7, 8) [membrane e11, e22, 2 e12 | bending | shear] at the Gauss points
        (MITC7: at the bubbles in equilibrium with the state)."""
        return self.element.strains(self._batch(state))

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) the element kernels on one element, so that the first real
        evaluation and the timings of a run do not include compilation."""
        if self.kernel != "numba":
            return
        conn = self.mesh.elements[:1]
        ref = self.reference
        self.element.warm_up(ElementBatch(self.mesh.nodes[conn].astype(float), self.frames0[conn], ref.e_ref[:1],
                                          ref.to_cart[:1], ref.weights[:1], self.material.section(),
                                          wrinkling=self.material.wrinkling))

    def strain_energy(self, state: ShellState, strain_kernel: str = "reference") -> float:
        """Elastic energy of the body, 1/2 sum_g w_g eps^T C eps (the tension-field membrane: its relaxed energy,
        1/2 sum_g w_g eps^T sigma(eps)), with the strains of the numpy reference element
        ("reference", element by element) or the numba strain kernel ("numba"; the dynamic energy records).
        MITC7: at the condensed bubbles, found with the body's kernel."""
        if strain_kernel not in ("numba", "reference"):
            raise ValueError(f"strain_kernel must be 'numba' or 'reference', got {strain_kernel!r}")
        return self.element.strain_energy(self._batch(state), strain_kernel)


def update_state(state: ShellState, du: np.ndarray, dtheta: np.ndarray,
                 global_translation: np.ndarray | None = None) -> ShellState:
    """The 5-DoF nodal update: x_I += R_I du_I (or du_I itself where global), R_I <- R_I exp(th1 e1 + th2 e2).

    du : (n, 3) translation increments (local, or global where ``global_translation``)
    dtheta : (n, 2) in-plane rotation increments
    """
    dx = np.einsum("nij,nj->ni", state.frames, du)
    if global_translation is not None:
        dx[global_translation] = du[global_translation]
    return moved_state(state, dx, dtheta)


def moved_state(state: ShellState, dx: np.ndarray, dtheta: np.ndarray) -> ShellState:
    """The state moved by global translations dx (n, 3) and turned by in-plane rotations dtheta (n, 2):
    x_I += dx_I, R_I <- R_I exp(th1 e1 + th2 e2) (the stresses copied)."""
    dtheta = np.ascontiguousarray(dtheta, dtype=float)
    if dtheta.shape != (len(dx), 2):
        raise ValueError(f"dtheta must have shape ({len(dx)}, 2), got {dtheta.shape}")
    local = state.relative_positions() + dx           # at full precision, relative to the model origin
    frames = np.empty_like(state.frames)
    kernels.update_frames_into(np.ascontiguousarray(state.frames), dtheta, frames)
    return ShellState(local + state.origin, frames, None if state.stress is None else state.stress.copy(), local,
                      state.origin)
