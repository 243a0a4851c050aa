"""Throughput of the numba shell-element kernel: element force+tangent (and force-only) evaluations per second.

    python benchmarks/element_throughput.py [--elements 2000] [--repeat 5] [--no-tying]

Random large-rotation deformed states of a curved (cylinder, radius 2) reference element; timings after a
warm-up call, best of ``--repeat``, with 1 and 2 numba threads.
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from flexbody.frames import frames_from_directors
from flexbody.lie import so3
from flexbody.shell.kernels.loops import internal_force_tangent_batch
from flexbody.shell.geometry import element_geometry
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, NoTying

PARAM = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], float)


def batch(m: int, seed: int = 0):
    """m random deformed copies of a curved element (cylinder of radius 2, axis y)."""
    radius = 2.0
    uv = PARAM * 0.8 + np.array([0.1, 0.2])
    X = np.array([[radius * np.sin(u / radius), v, radius * np.cos(u / radius)] for u, v in uv])
    n = np.array([[np.sin(u / radius), 0.0, np.cos(u / radius)] for u, _ in uv])
    frames = frames_from_directors(n, np.array([0.0, 1.0, 0.0]))
    geom = element_geometry(X, frames)
    rng = np.random.default_rng(seed)
    x = np.empty((m, 6, 3))
    fr = np.empty((m, 6, 3, 3))
    for e in range(m):
        Rg = so3.exp(1.5 * rng.normal(size=3))
        x[e] = (X + 0.05 * rng.normal(size=X.shape)) @ Rg.T
        fr[e] = [Rg @ frames[i] @ so3.exp(0.3 * rng.normal(size=3)) for i in range(6)]
    return (x, fr, np.tile(geom.e_ref, (m, 1, 1)), np.tile(geom.to_cart, (m, 1, 1, 1)),
            np.tile(geom.weights, (m, 1)))


def rate(args, C, A, want_tangent: bool, repeat: int) -> float:
    internal_force_tangent_batch(*args, C, A, want_tangent)  # warm-up (and compilation)
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        internal_force_tangent_batch(*args, C, A, want_tangent)
        best = min(best, time.perf_counter() - t)
    return len(args[0]) / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--no-tying", action="store_true")
    opts = parser.parse_args()
    C = ShellMaterial(young=1.0e3, poisson=0.3, thickness=0.1).section()
    A = (NoTying() if opts.no_tying else MITC6()).compressed_maps
    args = batch(opts.elements)
    t = time.perf_counter()
    internal_force_tangent_batch(*[a[:1] for a in args], C, A)
    print(f"first call (compile or cache load): {time.perf_counter() - t:.2f} s")
    print(f"{opts.elements} elements, tying={'off' if opts.no_tying else 'on'}, "
          f"{numba.config.NUMBA_NUM_THREADS} threads available")
    for threads in (1, 2):
        if threads > numba.config.NUMBA_NUM_THREADS:
            continue
        numba.set_num_threads(threads)
        full = rate(args, C, A, True, opts.repeat)
        force = rate(args, C, A, False, opts.repeat)
        print(f"threads={threads}: force+tangent {full:10.0f} el/s ({full / threads:8.0f} /s/core), "
              f"force only {force:10.0f} el/s ({force / threads:8.0f} /s/core)")


if __name__ == "__main__":
    main()
