"""The result fields of one step for the output files: displacements, directors, stress resultants,
fibre stresses, strain energies and support reactions (:mod:`flexbody.results`), as named arrays.

Point data (per node) and cell data (per element) as the XDMF writer and the HDF5 ``--stresses`` fields
store them; names and units in docs/output_formats.md.
"""

from __future__ import annotations

import numpy as np

from flexbody import results


def load_level(scene, where: float):
    """The load factor of a step: the static step's own, or lambda(t) of a dynamic scene at time ``where``."""
    if scene.kind != "dynamic":
        return where
    f = scene.analysis.load_factor
    if f is None:
        return 1.0
    value = np.asarray(f(where), dtype=float)
    return float(value) if value.ndim == 0 else scene.model.group_factors(value)


def gravity_forces(scene) -> np.ndarray | None:
    """The nodal gravity forces s_I g (n, 3) of a dynamic scene with gravity (None otherwise): s_I the row
    sums of the scene's mass matrix, lumped (m_I) or consistent (int rho h N_I dA), with its point masses."""
    if scene.kind != "dynamic" or not np.any(np.asarray(scene.analysis.gravity, dtype=float)):
        return None
    from flexbody.shell.inertia import shell_mass
    mass = shell_mass(scene.model.body, scene.analysis.mass, list(scene.analysis.point_masses)).nodal
    return mass[:, None] * np.asarray(scene.analysis.gravity, dtype=float)


def step_fields(model, state, lam, gravity_force=None) -> tuple[dict, dict]:
    """(point_data, cell_data) of one state at load factor ``lam``: dicts of float64 arrays."""
    body = model.body
    r = results.stress_resultants(body, state)
    rea = results.reactions(model, state, lam, gravity_force)
    point = {
        "displacement": np.asarray(state.x, float) - body.mesh.nodes,
        "director": np.ascontiguousarray(state.frames[:, :, 2]),
        "membrane_force": r.nodal[:, 0:3], "bending_moment": r.nodal[:, 3:6], "shear_force": r.nodal[:, 6:8],
        "principal_membrane_force": r.principal_membrane, "principal_direction": r.principal_direction,
        "von_mises_top": r.von_mises_top, "von_mises_bottom": r.von_mises_bottom,
        "reaction_force": rea.force, "reaction_moment": rea.moment,
    }
    cell = {
        "membrane_force": r.element[:, 0:3], "bending_moment": r.element[:, 3:6], "shear_force": r.element[:, 6:8],
        "strain_energy": r.element_energy,
        "von_mises_top_max": r.gauss_von_mises_top.max(axis=1),
        "von_mises_bottom_max": r.gauss_von_mises_bottom.max(axis=1),
    }
    return point, cell


def stress_field_shapes(n_nodes: int, n_elements: int) -> dict[str, tuple[int, ...]]:
    """The HDF5 ``--stresses`` fields and their per-step shapes."""
    return {"resultants_gauss": (n_elements, 7, 8), "resultants_nodal": (n_nodes, 8),
            "element_resultants": (n_elements, 8), "element_strain_energy": (n_elements,),
            "von_mises_top": (n_nodes,), "von_mises_bottom": (n_nodes,),
            "reaction_force": (n_nodes, 3), "reaction_moment": (n_nodes, 3)}


def stress_field_values(model, state, lam, gravity_force=None) -> dict[str, np.ndarray]:
    """The values of :func:`stress_field_shapes` for one state."""
    r = results.stress_resultants(model.body, state)
    rea = results.reactions(model, state, lam, gravity_force)
    return {"resultants_gauss": r.gauss, "resultants_nodal": r.nodal, "element_resultants": r.element,
            "element_strain_energy": r.element_energy, "von_mises_top": r.von_mises_top,
            "von_mises_bottom": r.von_mises_bottom, "reaction_force": rea.force, "reaction_moment": rea.moment}
