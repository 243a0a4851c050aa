"""Linear convergence of MITC6 and MITC7 (the condensed rotation bubble) under mesh refinement.

    python benchmarks/element_convergence.py

Two linear problems, solved with one Newton step from the unstressed state (the element's linearisation):

* the clamped square plate under uniform pressure, h/a = 1e-3, centre deflection / Kirchhoff
  (Timoshenko & Woinowsky-Krieger: 0.00126532 q a^4 / D), meshes 2xnxn;
* the slit annular plate of Sze et al. 3.3 (h = 0.03) under a small line force, W_A per unit line force,
  meshes 2x10xn: no closed form, compared with the finest MITC7 mesh.

The study behind docs/locking.md, section "Convergence rate: MITC6 against MITC7".
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse.linalg as spla

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad, nodal_vectors_from_area, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, MITC7

VARIANTS = {"MITC6": dict(element=MITC6(), kernel="numba"), "MITC7": dict(element=MITC7(), kernel="numba")}


def linear_solution(model: Model):
    state = model.initial_state()
    r, K = model.residual_and_tangent(state, 1.0)
    return model.update(state, spla.spsolve(K, -r))


def _nodal_loads(f: np.ndarray) -> list[NodalLoad]:
    return [NodalLoad([i], force=f[i]) for i in np.flatnonzero(np.any(f != 0, axis=1))]


def clamped_plate(n: int, variant: str, h: float = 1e-3) -> float:
    """Centre deflection / Kirchhoff value of the clamped unit square plate (nu = 0.3, unit pressure)."""
    a, E, nu = 1.0, 1.0e6, 0.3
    mesh = generators.strip(a, a, n, n)
    x = mesh.nodes
    edge = np.flatnonzero((np.abs(x[:, 0]) < 1e-9) | (np.abs(x[:, 0] - a) < 1e-9)
                          | (np.abs(x[:, 1]) < 1e-9) | (np.abs(x[:, 1] - a) < 1e-9))
    f = nodal_vectors_from_area(mesh, np.array([0, 0, 1.0]))
    f[edge] = 0.0
    model = Model(ShellBody(mesh, ShellMaterial(E, nu, h), **VARIANTS[variant]), [Fix(edge, "all")],
                  _nodal_loads(f))
    state = linear_solution(model)
    D = E * h**3 / (12 * (1 - nu**2))
    return state.x[mesh.nearest_node([a / 2, a / 2, 0]), 2] / (0.00126532 * a**4 / D)


def slit_plate(n_circ: int, variant: str, n_radial: int = 10) -> float:
    """Linear W_A per unit line force of the slit annular plate (Ri = 6, Ro = 10, h = 0.03, E = 21e6)."""
    mesh = generators.slit_annulus(6.0, 10.0, n_radial, n_circ)
    q = 1e-6
    f = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("loaded"), np.array([0, 0, q]), mesh.n_nodes)
    model = Model(ShellBody(mesh, ShellMaterial(21e6, 0.0, 0.03), **VARIANTS[variant]),
                  [Fix(mesh.node_set("clamped"), "all")], _nodal_loads(f))
    state = linear_solution(model)
    a = int(mesh.node_set("A")[0])
    return (state.x[a, 2] - mesh.nodes[a, 2]) / q


def main() -> None:
    print("## Clamped square plate, h/a = 1e-3: centre deflection / Kirchhoff\n")
    print("| element | " + " | ".join(f"2x{n}x{n}" for n in (4, 8, 16, 32)) + " | time [s] |")
    print("|---|---|---|---|---|---|")
    for variant in VARIANTS:
        t = time.perf_counter()
        values = [clamped_plate(n, variant) for n in (4, 8, 16, 32)]
        print(f"| {variant} | " + " | ".join(f"{v:.5f}" for v in values) + f" | {time.perf_counter() - t:.1f} |")
    print("\n## Slit annular plate, linear: W_A per unit line force, error against MITC7 2x10x120\n")
    meshes = (15, 30, 60, 120)
    results = {v: [slit_plate(n, v) for n in meshes] for v in VARIANTS}
    limit = results["MITC7"][-1]
    print("| element | " + " | ".join(f"2x10x{n}" for n in meshes) + " |")
    print("|---|---|---|---|---|")
    for variant, values in results.items():
        print(f"| {variant} | " + " | ".join(f"{v:.4f} ({100 * (v - limit) / limit:+.3f} %)" for v in values) + " |")


if __name__ == "__main__":
    main()
