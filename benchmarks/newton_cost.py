"""Cost of one Newton iteration and of one cached (modified-Newton) iteration at about 1e4 and 1e5 DoF.

    python benchmarks/newton_cost.py [--sizes 32 100] [--repeat 3]

A square plate 2 x n x n (clamped on one edge) in a random deformed state. Times (best of ``--repeat``):
element force+tangent, element force only, assembly of the global tangent (residual_and_tangent minus the
element part), sparse LU factorization, back-substitution, then

- a full Newton iteration  = residual_and_tangent + factorize + solve + update,
- a cached iteration       = residual + solve + update (the factorization of an earlier tangent reused),

and the peak resident memory of the process. Targets of issue 5: full iteration at 1e5 DoF within 3 s,
cached within 0.2 s.
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from integrators.linear import LinearSolver


def best_of(fn, repeat: int) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def plate_model(n: int) -> Model:
    mesh = generators.strip(1.0, 1.0, n, n, diagonal="alternate")
    body = ShellBody(mesh, ShellMaterial(1.0e6, 0.3, 0.01))
    return Model(body, [Fix(mesh.node_set("clamped"), "all")])


def measure(n: int, repeat: int) -> dict:
    model = plate_model(n)
    rng = np.random.default_rng(0)
    state = model.update(model.initial_state(), 1e-3 * rng.normal(size=model.n_dof))
    body = model.body
    body.element_forces(state)  # compile / load the numba cache
    t_el, _ = best_of(lambda: body.element_forces(state, True), repeat)
    t_el_f, _ = best_of(lambda: body.element_forces(state, False), repeat)
    t_rt, (r, K) = best_of(lambda: model.residual_and_tangent(state, 1.0), repeat)
    t_res, _ = best_of(lambda: model.residual(state, 1.0), repeat)
    solver = LinearSolver()
    t_fac, _ = best_of(lambda: solver.factorize(K), repeat)
    t_sol, dq = best_of(lambda: solver.solve(-r), repeat)
    t_up, _ = best_of(lambda: model.update(state, dq), repeat)
    lu = solver._lu
    return dict(mesh=f"2x{n}x{n}", dofs=model.n_dof, elements=body.mesh.n_elements, element_ft=t_el,
                element_f=t_el_f, assembly=t_rt - t_el, tangent=t_rt, residual=t_res, factorize=t_fac,
                solve=t_sol, update=t_up, full_iteration=t_rt + t_fac + t_sol + t_up,
                cached_iteration=t_res + t_sol + t_up, lu_nnz=int(lu.L.nnz + lu.U.nnz),
                peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[32, 100])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    cols = ["mesh", "dofs", "elements", "element_ft", "element_f", "assembly", "factorize", "solve", "update",
            "full_iteration", "cached_iteration", "lu_nnz", "peak_rss_mb"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for n in args.sizes:
        m = measure(n, args.repeat)
        cells = [f"{m[c]:.3f}" if isinstance(m[c], float) else str(m[c]) for c in cols]
        print("| " + " | ".join(cells) + " |", flush=True)
    print("\ntimes in seconds (best of repeats); element_ft / element_f: all elements, force+tangent / force only")


if __name__ == "__main__":
    main()
