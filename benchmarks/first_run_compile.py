"""First-run compilation cost: CPU time of ``flexbody run SCENE`` with an empty numba cache, per scene.

Every scene runs in a subprocess with a fresh, empty ``XDG_CACHE_HOME`` (so numba compiles every kernel the
scene needs) and one numba thread; the table gives the user and system CPU time of that process (the number
to trust on a shared machine: wall time depends on the load) and the wall time the run reported for its
compilation (``compile_time_s``). With ``--warm`` each scene runs a second time on the filled cache, which
gives the cost of the run without compiling (user CPU), and the kernel count of the cache.

    python benchmarks/first_run_compile.py                      # the default scene
    python benchmarks/first_run_compile.py --scenes all --warm  # every built-in scene, small settings

Scenes run with small settings (``SMALL``: a coarse mesh, few steps) so that the solve adds little to the
compilation; the kernels compiled do not depend on the mesh size or the step count.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: the --set overrides of each built-in scene that keep its solve short (the default scene runs as it is)
SMALL: dict[str, list[str]] = {
    "cantilever_end_moment": [],
    "cantilever_end_shear": ["nx=2", "steps=3"],
    "slit_annular_plate": ["steps=2"],
    "pullout_cylinder": ["n_circ=4", "n_axial=2"],
    "hemisphere": ["steps=2"],
    "spinning_plate": ["nx=1", "ny=1", "end_time=0.004"],
    "spinning_membrane": ["ramp_time=0.002", "end_time=0.004"],
    "spinning_sail": ["ramp_time=0.002", "end_time=0.004"],
    "tumbling_plate": ["end_time=0.01"],
    "swinging_strip": ["end_time=0.004"],
}


def run_once(scene: str, overrides: list[str], cache: Path, env: dict[str, str]) -> dict:
    """Run ``flexbody run scene`` in a child process with ``XDG_CACHE_HOME=cache``; its CPU times and summary."""
    out = cache / "run.json"
    cmd = [sys.executable, "-m", "flexbody.cli", "run", scene, "--quiet", "--json", str(out)]
    for item in overrides:
        cmd += ["--set", item]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(cmd, env={**env, "XDG_CACHE_HOME": str(cache)}, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{scene} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    summary = json.loads(out.read_text())
    kernels = sum(1 for _ in cache.rglob("*.nbc"))
    return dict(user=after.ru_utime - before.ru_utime, sys=after.ru_stime - before.ru_stime,
                compile=summary.get("compile_time_s", float("nan")), kernels=kernels)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="cantilever_end_moment",
                        help="comma-separated built-in scenes, or 'all' (default: the default scene)")
    parser.add_argument("--warm", action="store_true", help="also run each scene on the filled cache")
    parser.add_argument("--full", action="store_true", help="run the scenes with their own settings, not SMALL")
    args = parser.parse_args(argv)
    scenes = list(SMALL) if args.scenes == "all" else args.scenes.split(",")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    env.setdefault("NUMBA_NUM_THREADS", "1")
    env.pop("NUMBA_CACHE_DIR", None)
    header = f"{'scene':<24} {'user s':>8} {'sys s':>7} {'compile wall s':>15}"
    if args.warm:
        header += f" {'warm user s':>12} {'cached kernels':>15}"
    print(header, flush=True)
    for scene in scenes:
        overrides = [] if args.full else SMALL.get(scene, [])
        cache = Path(tempfile.mkdtemp(prefix="flexbody-first-run-"))
        try:
            cold = run_once(scene, overrides, cache, env)
            line = f"{scene:<24} {cold['user']:8.1f} {cold['sys']:7.1f} {cold['compile']:15.1f}"
            if args.warm:
                warm = run_once(scene, overrides, cache, env)
                line += f" {warm['user']:12.1f} {warm['kernels']:15d}"
            print(line, flush=True)
        finally:
            shutil.rmtree(cache, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
