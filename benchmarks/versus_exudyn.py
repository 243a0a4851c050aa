"""Work against precision, flexbody and exudyn's ANCF thin plate on the same problems, in one run.

    python benchmarks/versus_exudyn.py [SCENE ...] [--quick] [--json FILE] [--also-tying mitc7] [--repeat N]

For each of the paper's shell benchmarks (slit annular plate, pulled cylinder, hemisphere) both codes run a
ladder of meshes. Every run reports its CPU time (process time of the solve, no model building, no numba
compilation) and its maximum relative error against the reference table over the whole load path
(``flexbody.scenes.scene.compare_with_reference``, the same measure for both codes).

The ratio answers issue 5's question "how much less time for the same or better accuracy": for every
exudyn run, the cheapest flexbody run of the ladder whose error is at most exudyn's, and the ratio of the
two CPU times (> 1: flexbody is faster). Where no flexbody run of the ladder is as accurate, the ratio is
not given. ``--also-tying mitc7`` runs the flexbody ladder a second time with that element variant; both
variants then compete for the cheapest run at exudyn's accuracy.

CPU time, not wall time: the machine has two cores and benchmarks share it with other work; both codes
run single-threaded here (exudyn's EigenSparse LU, scipy's SuperLU; the element kernel's second thread is
excluded by timing the process CPU, which counts both threads). The CPU time of one run still varies by
up to 30 % from run to run on this virtual machine (both codes alike): ``--repeat N`` runs every mesh of
both ladders N times and keeps the least CPU time of each.
"""

from __future__ import annotations

import argparse
import json
import time

from flexbody.scenes import build, run_scene

#: mesh ladders: flexbody scene parameters, and exudyn ANCF quads (nx, ny) in the adapter's convention
LADDERS = {
    "slit_annular_plate": dict(
        flexbody=[dict(n_radial=6, n_circ=30), dict(n_radial=10, n_circ=30), dict(n_radial=8, n_circ=45),
                  dict(n_radial=8, n_circ=60), dict(n_radial=8, n_circ=90), dict(n_radial=8, n_circ=120)],
        exudyn=[(6, 16), (10, 30), (8, 48)]),
    "pullout_cylinder": dict(
        flexbody=[dict(n_circ=8, n_axial=6), dict(n_circ=10, n_axial=6), dict(n_circ=12, n_axial=8),
                  dict(n_circ=16, n_axial=12)],
        exudyn=[(12, 8), (16, 16)]),
    "hemisphere": dict(
        flexbody=[dict(n_meridian=8, n_circ=8), dict(n_meridian=10, n_circ=10), dict(n_meridian=12, n_circ=12),
                  dict(n_meridian=14, n_circ=14), dict(n_meridian=16, n_circ=16), dict(n_meridian=20, n_circ=20)],
        exudyn=[(12, 12), (16, 16), (20, 20)]),
}
QUICK = {  # one run per code: a smoke test of the script (about a minute)
    "pullout_cylinder": dict(flexbody=[dict(n_circ=8, n_axial=6)], exudyn=[(8, 6)]),
}


def least_cpu(run, repeat: int) -> dict:
    """The run with the least CPU time of ``repeat`` runs (the others differ only in their times)."""
    return min((run() for _ in range(max(1, repeat))), key=lambda r: r["cpu_s"])


def run_flexbody(scene_name: str, params: dict) -> dict:
    scene = build(scene_name, **params)
    scene.model.warm_up()
    c0 = time.process_time()
    summary = run_scene(scene)
    cpu = time.process_time() - c0
    d = summary.as_dict()
    mesh = "2x" + "x".join(str(v) for k, v in params.items() if k != "tying")
    if "tying" in params:
        mesh += f" {scene.model.body.element_name}"
    return dict(code="flexbody", mesh=mesh, dofs=d["dofs"],
                steps=d["steps"], iterations=d["newton_iterations"], factorizations=d["factorizations"],
                cpu_s=cpu, wall_s=d["wall_time_s"], error=d["max_rel_error"], converged=d["converged"],
                outputs=d["outputs"])


def run_exudyn(scene_name: str, nx: int, ny: int) -> dict:
    from flexbody.adapters.exudyn import run_reference

    run = run_reference(scene_name, {"exudyn_nx": nx, "exudyn_ny": ny})
    d = run.as_dict()
    return dict(code="exudyn ANCF", mesh=f"{nx}x{ny}", dofs=d["dofs"], steps=d["steps"],
                iterations=d["newton_iterations"], factorizations=None, cpu_s=d["cpu_time_s"],
                wall_s=d["wall_time_s"], error=d["max_rel_error"], converged=d["converged"],
                outputs=d["outputs"])


def time_to_accuracy(ours: list[dict], theirs: list[dict]) -> list[dict]:
    """For every exudyn run: the cheapest flexbody run at the same or better accuracy, and the CPU ratio."""
    rows = []
    for x in theirs:
        if not x["converged"]:
            continue
        good = [f for f in ours if f["converged"] and f["error"] <= x["error"]]
        best = min(good, key=lambda f: f["cpu_s"]) if good else None
        rows.append(dict(exudyn_mesh=x["mesh"], exudyn_error=x["error"], exudyn_cpu_s=x["cpu_s"],
                         flexbody_mesh=best["mesh"] if best else None,
                         flexbody_error=best["error"] if best else None,
                         flexbody_cpu_s=best["cpu_s"] if best else None,
                         ratio=x["cpu_s"] / best["cpu_s"] if best else None))
    return rows


def _fmt(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=None)
    parser.add_argument("--quick", action="store_true", help="one coarse run per code (smoke test)")
    parser.add_argument("--json", default=None, help="write all runs and ratios as JSON")
    parser.add_argument("--also-tying", default=None, choices=("mitc7", "point"),
                        help="also run the flexbody ladder with this element variant")
    parser.add_argument("--repeat", type=int, default=1, help="runs per mesh, the least CPU time kept")
    args = parser.parse_args()
    ladders = QUICK if args.quick else LADDERS
    names = args.scenes or list(ladders)
    unknown = [n for n in names if n not in ladders]
    if unknown:
        parser.error(f"no ladder for {unknown}; choose from {list(ladders)}")
    out = {}
    for name in names:
        params = list(ladders[name]["flexbody"])
        if args.also_tying:
            params += [{**p, "tying": args.also_tying} for p in ladders[name]["flexbody"]]
        runs_f = [least_cpu(lambda: run_flexbody(name, p), args.repeat) for p in params]
        runs_x = [least_cpu(lambda: run_exudyn(name, nx, ny), args.repeat) for nx, ny in ladders[name]["exudyn"]]
        print(f"\n## {name}\n")
        print("| code | mesh | DoFs | steps | Newton it. | factorizations | CPU [s] | wall [s] | max rel. error "
              "| outputs at the last level |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for r in runs_f + runs_x:
            err = f"{100 * r['error']:.2f} %" if r["converged"] else "did not converge"
            last = ", ".join(f"{k} {v:.5g}" for k, v in r["outputs"].items())
            print(f"| {r['code']} | {r['mesh']} | {r['dofs']} | {r['steps']} | {r['iterations']} | "
                  f"{_fmt(r['factorizations'], 'd')} | {r['cpu_s']:.2f} | {r['wall_s']:.2f} | {err} | {last} |")
        ratios = time_to_accuracy(runs_f, runs_x)
        print("\n| exudyn mesh | exudyn error | exudyn CPU [s] | cheapest flexbody at <= that error | its error | "
              "its CPU [s] | exudyn / flexbody CPU |")
        print("|---|---|---|---|---|---|---|")
        for q in ratios:
            print(f"| {q['exudyn_mesh']} | {100 * q['exudyn_error']:.2f} % | {q['exudyn_cpu_s']:.2f} | "
                  f"{q['flexbody_mesh'] or 'none in the ladder'} | "
                  f"{_fmt(q['flexbody_error'] and 100 * q['flexbody_error'], '.2f')} % | "
                  f"{_fmt(q['flexbody_cpu_s'], '.2f')} | {_fmt(q['ratio'], '.2f')} |", flush=True)
        out[name] = dict(flexbody=runs_f, exudyn=runs_x, ratios=ratios)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(out, fh, indent=2)


if __name__ == "__main__":
    main()
