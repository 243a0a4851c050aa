"""The residual-only element kernel (no tangent, linear section) on the 4 x 32 hub annulus (256 MITC6 elements).

    python benchmarks/residual_kernel.py [--compare DIR] [--run] [--rounds N] [--reps N] [--calls N]

Measures, per call, the best of ``--rounds`` fresh processes x ``--reps`` repetitions of ``--calls`` calls (the
machine is shared: the best, not the mean, is the cost of the code):

* ``element_forces``: ``body.element_forces(state, False)`` (the kernel and the gather of the element arrays),
  hot (called back to back) and cold (a 4 MB numpy update between calls evicts the caches, as the rest of a
  time step does);
* ``kernel``: :func:`flexbody.shell.kernels.loops.internal_force_tangent_batch` alone on gathered arrays, hot
  and cold;
* with ``--run``: the kernel inside a real run, 200 steps (two revolutions of the hub): the mean and the median
  time of its residual-only ``_chunk`` calls.

The state: the reference configuration stretched radially (1e-3 r), bent out of plane (0.02 (r - a) times the
sum of cos(n theta), n < 4), its positions perturbed by 1e-3 and its frames turned by random rotations of up to
0.05 rad. ``--compare DIR`` measures the code in DIR (PYTHONPATH, e.g. /work/main) in processes alternating with
this one's, prints the ratios and the largest relative difference of the forces.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
from pathlib import Path
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import spinning_membranes as sm   # noqa: E402

from flexbody.lie.so3 import exp_many   # noqa: E402
from flexbody.scenes.scene import run_scene   # noqa: E402
from flexbody.shell.kernels import loops   # noqa: E402
from flexbody.shell.kernels.loops import internal_force_tangent_batch   # noqa: E402

PERIOD = 2 * math.pi / sm.OMEGA


def _scene(revolutions: float):
    text = sm.ANNULUS.format(name="residual", a=0.2, nr=4, nc=32, h=1e-3, dt=PERIOD / 100, end=revolutions * PERIOD,
                             mass="lumped", omega=sm.OMEGA, every=10, options="", wrinkling="false")
    return sm._scene(text + sm.HUB.format(a=0.2, omega=sm.OMEGA))


def _state():
    """The body and a deformed state of it (deterministic; see the module docstring)."""
    body = _scene(0.05).model.body
    state = body.initial_state()
    x = state.local
    r, theta = np.hypot(x[:, 0], x[:, 1]), np.arctan2(x[:, 1], x[:, 0])
    rng = np.random.default_rng(7)
    x[:, :2] *= 1.0 + 1e-3 * r[:, None]
    x[:, 2] += 0.02 * (r - 0.2) * sum(np.cos(n * theta) for n in range(4))
    x += 1e-3 * rng.standard_normal(x.shape)
    state.x = x + state.origin
    state.frames = np.einsum("nij,njk->nik", state.frames, exp_many(0.05 * rng.uniform(-1.0, 1.0, (len(x), 3))))
    return body, state


def _per_call(call, reps: int, calls: int, evict: np.ndarray | None) -> float:
    """Best over reps of the mean time of one call (ms); with evict, a 4 MB update between calls, not timed."""
    best = math.inf
    for _ in range(reps):
        total = 0.0
        for _ in range(calls):
            if evict is not None:
                evict += 1.0
            t = time.perf_counter()
            call()
            total += time.perf_counter() - t
        best = min(best, total / calls)
    return 1e3 * best


def _in_run() -> tuple[float, float]:
    """Mean and median time (ms) of the residual-only _chunk calls (no tangent, no stress) of a 200-step run.

    (cProfile's ``_chunk`` tottime / ncalls mixes them with a part of the tangent calls' time.)
    """
    params = list(inspect.signature(loops._chunk.py_func).parameters)
    iw, ius = params.index("want_tangent"), params.index("use_stress")
    kernel, times = loops._chunk, []

    def timed(*args):
        t = time.perf_counter()
        kernel(*args)
        if not args[iw] and not args[ius] and args[1] - args[0] > 1:
            times.append(time.perf_counter() - t)

    loops._chunk = timed
    try:
        run_scene(_scene(2.0))
    finally:
        loops._chunk = kernel
    return 1e3 * float(np.mean(times)), 1e3 * float(np.median(times))


def measure(reps: int, calls: int, in_run: bool, forces_out: str | None) -> dict:
    body, state = _state()
    variant = body.element
    arrays = body._batch(state).checked_arrays()

    def kernel():
        return internal_force_tangent_batch(*arrays, variant.compressed_maps, False, workspaces=variant.workspaces)

    f = body.element_forces(state, False)[0]
    if forces_out:
        np.save(forces_out, f)
    evict = np.zeros(4 * 2**20 // 8)
    out = {"element_forces hot": _per_call(lambda: body.element_forces(state, False), reps, calls, None),
           "element_forces cold": _per_call(lambda: body.element_forces(state, False), reps, calls, evict),
           "kernel hot": _per_call(kernel, reps, calls, None),
           "kernel cold": _per_call(kernel, reps, calls, evict)}
    if in_run:
        out["_chunk in run, mean"], out["_chunk in run, median"] = _in_run()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--compare", help="also measure the code in this directory (PYTHONPATH) and compare")
    parser.add_argument("--run", action="store_true", help="also time the kernel in a 200-step run")
    parser.add_argument("--rounds", type=int, default=3, help="measurements (alternating with --compare); best")
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--calls", type=int, default=40)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--forces", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.reps, args.calls, args.run, args.forces)))
        return
    files = {"this": f"/tmp/residual_kernel_{os.getpid()}_this.npy",
             "other": f"/tmp/residual_kernel_{os.getpid()}_other.npy"}
    best: dict[str, dict[str, float]] = {"this": {}, "other": {}}
    for _ in range(args.rounds):
        for who in ("this", "other") if args.compare else ("this",):
            cmd = [sys.executable, __file__, "--json", "--forces", files[who], "--reps", str(args.reps),
                   "--calls", str(args.calls)] + (["--run"] if args.run else [])
            env = dict(os.environ, PYTHONPATH=args.compare) if who == "other" else None
            result = json.loads(subprocess.run(cmd, env=env, check=True, capture_output=True, text=True).stdout)
            for key, ms in result.items():
                best[who][key] = min(best[who].get(key, math.inf), ms)
    for key, ms in best["this"].items():
        row = f"{key:24s} {ms:8.3f} ms"
        if args.compare:
            row += f"   {args.compare}: {best['other'][key]:8.3f} ms   ratio {ms / best['other'][key]:.3f}"
        print(row)
    if args.compare:
        a, b = np.load(files["this"]), np.load(files["other"])
        diff = np.max(np.abs(a - b)) / np.max(np.abs(b))
        print(f"forces: largest difference {diff:.3g} of the largest force; bit-identical: {np.array_equal(a, b)}")
    for path in files.values():
        if os.path.exists(path):
            os.remove(path)


if __name__ == "__main__":
    main()
