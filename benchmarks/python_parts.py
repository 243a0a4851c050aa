"""The pure-Python parts of a run before and after vectorising them, measured in the same run.

    python benchmarks/python_parts.py [--n 32] [--plate 8] [--repeat 3]

"Before" swaps the element-by-element reference implementations back in (they stay in the code, and the
tests check the fast versions against them): the follower pressure load and its tangent
(``loads.pressure_contribution_reference``), the reference geometry of the elements
(``shell.geometry.element_geometry`` in a loop) and numpy's hash-based ``np.unique`` for the sparse pattern.
Prints a markdown table of the least of ``--repeat`` wall times; docs/performance.md keeps it.
"""

from __future__ import annotations

import argparse
import platform
import time
from contextlib import contextmanager
from pathlib import Path
from unittest import mock

import numpy as np

import flexbody.assembly as assembly
import flexbody.body as body
from flexbody import loads
from flexbody.body import ReferenceGeometry
from flexbody.mesh import generators
from flexbody.scenes import builtin, open_scene, run_scene
from flexbody.shell.geometry import element_geometry


def _reference_geometry_loop(mesh, frames0, origin=None) -> ReferenceGeometry:
    """The set-up as it was: element_geometry element by element."""
    nodes = mesh.nodes if origin is None else mesh.nodes - origin
    parts = [element_geometry(nodes[c], frames0[c]) for c in mesh.elements]
    return ReferenceGeometry(np.array([g.e_ref for g in parts]), np.array([g.to_cart for g in parts]),
                             np.array([g.weights for g in parts]))


@contextmanager
def before():
    """The reference (element-by-element) implementations in place of the fast ones."""
    with mock.patch.object(assembly, "pressure_contribution", loads.pressure_contribution_reference), \
            mock.patch.object(body, "build_reference", _reference_geometry_loop), \
            mock.patch.object(assembly, "_sorted_unique", np.unique):
        yield


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=32, help="hemisphere mesh n x n (2 n^2 elements)")
    ap.add_argument("--plate", type=int, default=8, help="clamped pressure plate mesh n x n")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    mesh = generators.spherical_cap(10.0, 18.0, args.n, args.n)
    rng = np.random.default_rng(0)
    x = mesh.nodes + 0.01 * rng.standard_normal(mesh.nodes.shape)
    hemi = lambda: builtin.hemisphere(n_meridian=args.n, n_circ=args.n)
    plate_file = Path(__file__).resolve().parents[1] / "examples" / "clamped_plate_scene.py"
    source = open_scene(str(plate_file))
    plate = lambda: run_scene(source.build({"n": args.plate}))
    run_scene(source.build({"n": 2}))                               # load the kernels once

    rows = []
    def row(what, slow, fast):
        with before():
            t0 = best(slow, args.repeat)
        t1 = best(fast, args.repeat)
        rows.append((what, t0, t1))
        print(f"| {what} | {t0:.3f} | {t1:.3f} | {t0 / t1:.1f}x |", flush=True)

    print(f"machine: {platform.processor() or platform.machine()}, {time.strftime('%Y-%m-%d %H:%M')}")
    print("| part | before [s] | after [s] | speed-up |\n|---|---|---|---|")
    press = lambda: assembly.pressure_contribution(mesh, x, 1.0)
    row(f"follower pressure load + tangent, {mesh.n_elements} elements", press, press)
    geo = lambda: body.build_reference(mesh, np.tile(np.eye(3), (mesh.n_nodes, 1, 1)))
    row(f"reference geometry, {mesh.n_elements} elements", geo, geo)
    hemi_dofs = hemi().model.n_dof
    row(f"hemisphere scene set-up ({args.n}x{args.n}, {hemi_dofs} DoFs)", hemi, hemi)
    row(f"clamped pressure plate ({args.plate}x{args.plate}), whole run", plate, plate)


if __name__ == "__main__":
    main()
