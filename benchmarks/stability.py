"""Stability and linear buckling studies of issue 16 (items 3, 4); tables in docs/stability.md.

    PYTHONPATH=. python benchmarks/stability.py [plate] [cylinder] [overhead]

plate: simply supported plate a/b = 2 in uniaxial compression against k pi^2 D / b^2 (k = 4, m = 2) under
refinement; cylinder: axially compressed cylinder (R/h = 50, L = 2R) against E h / (R sqrt(3(1 - nu^2))),
full and as a 1/16 sector; overhead: the wall time of static runs with and without the stability count
(measured in the same run).
"""

import importlib.util
from pathlib import Path
import sys
import time

import numpy as np

from flexbody.buckling import linear_buckling
from flexbody.scenes.builtin import build as build_builtin
from flexbody.scenes.scene import warm_up_kernels
from flexbody.scenes.sources import open_scene
from integrators.static import load_control

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _example(name):
    path = EXAMPLES / name
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return str(path), module


def plate() -> None:
    path, module = _example("compressed_plate_scene.py")
    exact, m = module.classical_factor()
    print(f"plate a/b = 2, h/b = 0.01, nu = 0.3: classical factor {exact:.6g} (k = 4, m = {m})")
    print("| mesh | DoFs | lam_1 / classical | error | lam_2 / lam_1(m=3 classical) | time (s) |")
    k3 = (3 / 2 + 2 / 3) ** 2 / 4
    for nx, ny in ((4, 2), (8, 4), (16, 8), (32, 16)):
        model = open_scene(path).build(dict(nx=nx, ny=ny)).model
        warm_up_kernels(model)
        t = time.perf_counter()
        r = linear_buckling(model, 2)
        print(f"| {nx} x {ny} x 2 | {model.n_dof} | {r.load_factors[0] / exact:.4f} | "
              f"{r.load_factors[0] / exact - 1:+.2%} | {r.load_factors[1] / exact / k3:.4f} | "
              f"{time.perf_counter() - t:.2f} |", flush=True)


def cylinder() -> None:
    path, module = _example("compressed_cylinder_scene.py")
    print("cylinder R/h = 50, L = 2R, ends held radially and circumferentially")
    print("| model | nu | mesh | DoFs | lam_1 / classical | lam_8 / classical | time (s) |")
    cases = [(16, 4, 16, 0.0), (16, 4, 32, 0.0), (16, 6, 48, 0.0), (16, 8, 64, 0.0),
             (1, 32, 16, 0.0), (1, 48, 24, 0.0), (1, 48, 24, 0.3)]
    for sectors, nc, na, nu in cases:
        model = open_scene(path).build(dict(sectors=sectors, n_circ=nc, n_axial=na, poisson=nu)).model
        exact = module.classical_factor(poisson=nu)
        warm_up_kernels(model)
        t = time.perf_counter()
        r = linear_buckling(model, 8)
        what = "full" if sectors == 1 else f"1/{sectors} sector"
        print(f"| {what} | {nu} | {nc} x {na} x 2 | {model.n_dof} | {r.load_factors[0] / exact:.4f} | "
              f"{r.load_factors[-1] / exact:.4f} | {time.perf_counter() - t:.1f} |", flush=True)


def overhead() -> None:
    print("| scene | DoFs | steps | solve without count (s) | with count (s) | ratio |")
    for name, params in (("hemisphere", {}), ("slit_annular_plate", {}), ("cantilever_end_moment", {})):
        scene = build_builtin(name, **params)
        model, a = scene.model, scene.analysis
        warm_up_kernels(model)
        times = {}
        for check in (False, True, False, True):
            t = time.perf_counter()
            r = load_control(model, a.load_factors, settings=a.newton, check_stability=check)
            times.setdefault(check, []).append(time.perf_counter() - t)
        off, on = min(times[False]), min(times[True])
        print(f"| {name} | {model.n_dof} | {len(r.records)} | {off:.2f} | {on:.2f} | {on / off:.2f} |", flush=True)


if __name__ == "__main__":
    studies = sys.argv[1:] or ["plate", "cylinder", "overhead"]
    for study in studies:
        {"plate": plate, "cylinder": cylinder, "overhead": overhead}[study]()
