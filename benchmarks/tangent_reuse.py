"""The effect of tangent reuse on the static benchmarks: full Newton against modified Newton.

    python benchmarks/tangent_reuse.py [SCENE ...] [--refresh-ratio 0.5]

For each scene: Newton iterations, tangent updates, factorizations, wall time and max relative error with
the "full" policy (a new tangent and factorization every iteration) and the "modified" policy (the
factorization is kept across iterations and load steps and refreshed only when the residual no longer drops
by the refresh ratio per iteration). Both solve the same equations to the same tolerance.
"""

from __future__ import annotations

import argparse
import dataclasses

from flexbody.scenes import build, run_scene

DEFAULT = ["cantilever_end_shear", "cantilever_end_moment", "hemisphere", "pullout_cylinder"]


def run(name: str, policy: str, ratio: float) -> dict:
    scene = build(name)
    newton = dataclasses.replace(scene.analysis.newton, policy=policy, refresh_ratio=ratio)
    scene.analysis = dataclasses.replace(scene.analysis, newton=newton)
    return run_scene(scene).as_dict()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=DEFAULT)
    parser.add_argument("--refresh-ratio", type=float, default=0.5)
    args = parser.parse_args()
    print("| scene | policy | Newton it. | tangent updates | factorizations | wall time [s] | max rel. error | converged |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.scenes:
        for policy in ("full", "modified"):
            d = run(name, policy, args.refresh_ratio)
            print(f"| {name} | {policy} | {d['newton_iterations']} | {d['tangent_updates']} | {d['factorizations']} | "
                  f"{d['wall_time_s']:.2f} | {d['max_rel_error']:.2e} | {'yes' if d['converged'] else 'NO'} |",
                  flush=True)


if __name__ == "__main__":
    main()
