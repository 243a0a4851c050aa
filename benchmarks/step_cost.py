"""Where the CPU time of a dynamic step goes, on the kicked 4 x 32 hub annulus (2 560 DoFs, h/R 1e-3, 100 steps
per revolution, the turning frame at the defaults: the cost target's case of ``spinning_membranes.py hub``).

    python benchmarks/step_cost.py [--revolutions 4] [--baseline PATH] [--repeat 3]

Prints the CPU seconds of the run (after a short warm-up run that compiles the kernels), the Newton iterations and
factorizations per step, and a table of the parts of a step: each wrapped in a timer (the CPU time of the
calling thread, which does the element loop of this size: other jobs on the machine do not count; about 1 us
added per call), per step and per call. With ``--baseline PATH`` (a checkout of another commit, e.g. made with
``git worktree add /tmp/base <commit>``) the run alternates with the same run of that checkout in a child process
(``PYTHONPATH=PATH``), ``--repeat`` times each, and prints both CPU times and their ratio: on a shared machine
the absolute seconds move by half their value from one minute to the next, the ratio of interleaved runs much
less.
"""

from __future__ import annotations

import argparse
import collections
import math
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

PERIOD = 2.0 * math.pi / 20.0


def scene_text(revolutions: float) -> str:
    import spinning_membranes as s
    return (s.ANNULUS.format(name="hub", a=0.2, nr=4, nc=32, h=1e-3, dt=PERIOD / 100, end=revolutions * PERIOD,
                             mass="lumped", omega=20.0, every=10, options="", wrinkling="false")
            + s.HUB.format(a=0.2, omega=20.0))


def _parts() -> list[tuple[object, str, str]]:
    """(owner, attribute, label) of the parts timed: the integrator's step and its calls into the model."""
    import flexbody.assembly as assembly
    import flexbody.body as body
    import flexbody.shell.variants as variants
    import flexbody.spinning as spinning
    import flexbody.turning_frame as turning
    import integrators.generalized_alpha as ga
    import integrators.linear as linear
    return [(ga.GeneralizedAlpha, "_attempt", "step (Newton iteration)"),
            (turning.TurningFrameModel, "residual", "  residual"),
            (assembly.Model, "residual", "    internal forces, assembled"),
            (variants, "internal_force_tangent_batch", "      element kernel"),
            (spinning.SpinningModel, "spin_load", "    centrifugal load"),
            (turning.TurningFrameModel, "coriolis_force", "    Coriolis forces"),
            (linear.LinearSolver, "solve", "  LU solve"),
            (ga.GeneralizedAlpha, "_refresh", "  fresh matrix (tangent + factorization)"),
            (turning.TurningFrameModel, "update", "  configuration update"),
            (turning.TurningFrameModel, "transfer", "  transfer of the kept matrix"),
            (turning.TurningFrameModel, "apply_transfer", "  transfer applied"),
            (turning.InertialObservers, "__call__", "observers (outputs every 10 steps)")]


def timed_run(revolutions: float) -> dict:
    """Run the scene once with the parts wrapped; CPU seconds, counts and the parts' wall times."""
    from flexbody.scenes.scene import run_scene
    from flexbody.scenes.toml_scene import scene_from_document
    import tomllib
    spent, calls = collections.defaultdict(float), collections.Counter()

    def wrap(owner, name, label):
        inner = getattr(owner, name)

        def timed(*args, **kwargs):
            t0 = time.thread_time()
            try:
                return inner(*args, **kwargs)
            finally:
                spent[label] += time.thread_time() - t0
                calls[label] += 1
        setattr(owner, name, timed)

    def scene(revs):
        return scene_from_document(tomllib.loads(scene_text(revs)), "step_cost")

    run_scene(scene(0.05))                      # compiles (or loads) the kernels
    for owner, name, label in _parts():
        wrap(owner, name, label)
    spent.clear()
    calls.clear()
    t0 = time.process_time()
    summary = run_scene(scene(revolutions))
    cpu = time.process_time() - t0
    r = summary.result
    return dict(cpu=cpu, steps=r.steps, iterations=r.stats.iterations / r.steps,
                factorizations=r.stats.factorizations / r.steps,
                parts=[(label, spent[label], calls[label]) for _, _, label in _parts()])


def cpu_of(path: Path, revolutions: float) -> float:
    """The CPU seconds of the run of the checkout at ``path`` (a child process, its own kernel cache)."""
    env = dict(os.environ, PYTHONPATH=str(path), XDG_CACHE_HOME=f"/tmp/step-cost-cache-{path.name}")
    code = ("import sys; sys.path.insert(0, %r); import step_cost; print(step_cost.timed_run(%r)['cpu'])"
            % (str(HERE), revolutions))
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=str(path), capture_output=True, text=True,
                         check=True)
    return float(out.stdout.split()[-1])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revolutions", type=float, default=4.0)
    ap.add_argument("--baseline", type=Path, help="a checkout to compare with (interleaved child processes)")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    if a.revolutions <= 0 or a.repeat < 1:
        ap.error("--revolutions must be > 0 and --repeat >= 1")
    if a.baseline is not None and not (a.baseline / "flexbody").is_dir():
        ap.error(f"--baseline {a.baseline} is not a flexbody checkout (no flexbody/ in it)")
    run = timed_run(a.revolutions)
    steps = run["steps"]
    print(f"{steps} steps, {run['iterations']:.2f} iterations and {run['factorizations']:.3f} factorizations per "
          f"step, {run['cpu']:.2f} s CPU\n")
    print("| part | ms / step | calls / step | ms / call |\n|---|---|---|---|")
    for label, seconds, n in run["parts"]:
        if n:
            print(f"| {label.strip()} | {seconds / steps * 1e3:.3f} | {n / steps:.2f} | {seconds / n * 1e3:.3f} |")
    if a.baseline is None:
        return
    here = Path(__file__).resolve().parents[1]
    rows = []
    for _ in range(a.repeat):
        rows.append((cpu_of(a.baseline, a.revolutions), cpu_of(here, a.revolutions)))
    print("\n| run | baseline CPU s | this checkout CPU s | ratio |\n|---|---|---|---|")
    for k, (base, this) in enumerate(rows, 1):
        print(f"| {k} | {base:.2f} | {this:.2f} | {this / base:.3f} |")


if __name__ == "__main__":
    main()
