"""The paper's static benchmarks at the paper's meshes and one finer mesh: error against run time.

    python benchmarks/static_benchmarks.py [--out FILE] [--tying mitc7] [SCENE ...]

Writes a Markdown table (mesh, DoFs, steps, Newton iterations, tangent updates, factorizations, wall time,
max relative error against the reference) and prints it. ``--tying`` runs every study with that element
variant (``mitc7``, ``point``; default: the MITC6 default).
"""

from __future__ import annotations

import argparse
import platform
import time

from flexbody.scenes import build, run_scene

STUDIES = {
    "cantilever_end_moment": [dict(nx=16, ny=1, thickness=0.01), dict(nx=16, ny=1, thickness=0.1),
                              dict(nx=32, ny=2, thickness=0.01)],
    "cantilever_end_shear": [dict(nx=16, ny=1), dict(nx=32, ny=2)],
    "slit_annular_plate": [dict(n_radial=10, n_circ=30), dict(n_radial=10, n_circ=60), dict(n_radial=16, n_circ=48)],
    "pullout_cylinder": [dict(n_circ=12, n_axial=8), dict(n_circ=24, n_axial=16)],
    "hemisphere": [dict(n_meridian=20, n_circ=20), dict(n_meridian=32, n_circ=32)],
}


def mesh_label(params: dict) -> str:
    keys = [k for k in params if k.startswith("n")]
    return "2x" + "x".join(str(params[k]) for k in keys) + "".join(
        f", {k}={v}" for k, v in params.items() if not k.startswith("n"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=list(STUDIES))
    parser.add_argument("--out", default=None)
    parser.add_argument("--tying", default=None, choices=("mitc7", "point", "mean"),
                        help="element variant for every study (default: MITC6)")
    args = parser.parse_args()
    rows = ["| scene | mesh | DoFs | steps | Newton it. | tangents | factorizations | wall time [s] | max rel. error | converged |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for name in args.scenes:
        for params in STUDIES[name]:
            if args.tying is not None:
                params = {**params, "tying": args.tying}
            t0 = time.perf_counter()
            s = run_scene(build(name, **params))
            d = s.as_dict()
            rows.append(f"| {name} | {mesh_label(params)} | {d['dofs']} | {d['steps']} | {d['newton_iterations']} | "
                        f"{d['tangent_updates']} | {d['factorizations']} | {d['wall_time_s']:.2f} | "
                        f"{d['max_rel_error']:.2e} | {'yes' if d['converged'] else 'NO: ' + d['message'][:60]} |")
            print(rows[-1], f"(total incl. setup {time.perf_counter() - t0:.1f} s)", flush=True)
    text = "\n".join(rows)
    header = (f"Measured with `python benchmarks/static_benchmarks.py` on {platform.processor() or platform.machine()}, "
              f"Python {platform.python_version()}.\n\n")
    if args.out:
        with open(args.out, "w") as fh:
            fh.write("# Static benchmarks: error against run time\n\n" + header + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
