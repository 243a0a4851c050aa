"""Fewer Newton iterations, tangents and factorizations on the static benchmarks, for the same answers.

    python benchmarks/fewer_iterations.py [SCENE ...] [--variants classical displacement default secant modified ...]

For each scene and variant: load steps, Newton iterations, tangent updates, factorizations, wall and CPU
time (``time.process_time``, all threads: on a shared machine the wall time is an upper bound), the max
relative error against the reference and the largest change of the tracked outputs at the reference load
levels against the first variant (relative to max |reference|).

Variants (all with the scene's own tolerances):

- ``classical``: the solver as it was until 2026-12: the displacement Newton iteration with a tangent and
  a factorization at every iteration (``lazy_tangent=0, mixed=False``) and steps that grow only after <= 4
  iterations (``grow_iterations=4``);
- ``default``: the current defaults (the mixed Newton iteration, docs/theory.md; the lazy tangent near
  convergence: round-off floor and force tests on the residual alone, chord steps, the factorization
  carried into the next step or arc-length predictor; steps that grow after at most half of
  ``max_iterations``);
- ``displacement``: the defaults with the displacement iteration (``mixed=False``: the defaults until
  2026-12-02);
- ``mixed``: the defaults with ``mixed=True`` (the same as ``default`` now);
- ``secant``: the defaults with the secant predictor (``load_control(predictor="secant")``);
- ``modified``, ``line_search``: the defaults with ``policy="modified"`` or ``line_search=True``.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import time

import numpy as np

import flexbody.scenes.runner as runner_module
from flexbody.scenes import build, run_scene
from flexbody.scenes.compare import compare_with_reference
from integrators.static import load_control

DEFAULT = ["slit_annular_plate", "hemisphere", "pullout_cylinder", "cantilever_end_shear", "cantilever_end_moment"]
VARIANTS = {
    "classical": (dict(lazy_tangent=0.0, mixed=False), dict(grow_iterations=4)),
    "default": ({}, {}),
    "secant": ({}, dict(predictor="secant")),
    "modified": (dict(policy="modified"), {}),
    "line_search": (dict(line_search=True), {}),
    "mixed": (dict(mixed=True), {}),
    "displacement": (dict(mixed=False), {}),
}


def run(name: str, variant: str) -> dict:
    newton_changes, load_control_kwargs = VARIANTS[variant]
    scene = build(name)
    newton = dataclasses.replace(scene.analysis.newton, **newton_changes)
    scene.analysis = dataclasses.replace(scene.analysis, newton=newton)
    # run_scene calls load_control with the scene's settings only: pass the path-following options through
    original = runner_module.load_control
    runner_module.load_control = functools.partial(load_control, **load_control_kwargs)
    try:
        scene.model.warm_up()
        cpu = time.process_time()
        summary = run_scene(scene)
        cpu = time.process_time() - cpu
    finally:
        runner_module.load_control = original
    st = summary.result.stats
    return dict(summary=summary, steps=len(summary.result.records), iterations=st.iterations,
                tangents=st.tangent_updates, factorizations=st.factorizations, wall=summary.wall_time_s, cpu=cpu,
                error=summary.max_rel_error, converged=summary.result.converged, reference=scene.reference)


def output_change(a: dict, b: dict) -> float:
    """max |value_b - value_a| / max |reference| over the outputs at the reference load levels."""
    ref = a["reference"]
    ea = compare_with_reference(a["summary"].history, ref)
    eb = compare_with_reference(b["summary"].history, ref)
    scale = {q: float(np.abs(v).max()) or 1.0 for q, v in ref.values.items()}
    pairs = [(x, y) for x, y in zip(ea, eb) if (x["quantity"], x["load_factor"]) == (y["quantity"], y["load_factor"])]
    if len(pairs) != len(ea) or len(ea) != len(eb):
        return float("nan")        # not the same levels reached
    return max((abs(x["value"] - y["value"]) / scale[x["quantity"]] for x, y in pairs), default=float("nan"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=DEFAULT)
    parser.add_argument("--variants", nargs="+", default=["classical", "default"], choices=list(VARIANTS))
    args = parser.parse_args()
    print("| scene | variant | steps | Newton it. | tangents | factorizations | wall [s] | CPU [s] | max rel. error "
          "| output change |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.scenes:
        first = None
        for variant in args.variants:
            d = run(name, variant)
            first = first or d
            change = "-" if d is first else f"{output_change(first, d):.1e}"
            print(f"| {name} | {variant} | {d['steps']} | {d['iterations']} | {d['tangents']} | "
                  f"{d['factorizations']} | {d['wall']:.2f} | {d['cpu']:.2f} | {d['error']:.3e} | {change}"
                  f"{'' if d['converged'] else ' (NOT converged)'} |", flush=True)


if __name__ == "__main__":
    main()
