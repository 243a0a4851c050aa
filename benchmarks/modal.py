"""Modal analysis studies (docs/modal.md): convergence against references, the transient route, and timings.

    PYTHONPATH=. python benchmarks/modal.py [plate] [annulus] [fft] [timing]      (default: all)

* plate: a simply supported square plate (h / a = 1e-3) against the exact frequencies pi^2 (m^2 + n^2) (Leissa,
  NASA SP-160, eq. 4.21), meshes 4x4 .. 16x16;
* annulus: the hub annulus a = 0.2, b = 1, E = 1e9, nu = 0.3, rho = 1000, Omega = 20 rad/s, pinned
  (translations held) and clamped to the hub, h = 1e-3 and 1e-4, against the 1-D radial membrane eigenproblem
  (tests/membrane_reference.py);
* fft: examples/kicked_spinning_annulus.toml run for 20 revolutions from its steady spin: the spatial Fourier
  component n of the rim's transverse motion, then its temporal spectrum (Hann window, zero padding, parabolic
  peak interpolation), against the modal frequencies of the same mesh;
* timing: the first 20 modes of a ~1e5-DoF plate; a 10-point Campbell sweep of a ~5e3-DoF spinning annulus.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel
from flexbody.mesh import generators
from flexbody.modal import describe_modes, modal_problem_at_rest, modal_problem_in_spin, solve_modes
from flexbody.shell.material import ShellMaterial
from tests.membrane_reference import radial_membrane_frequencies

A, B, E, NU, RHO, OMEGA = 0.2, 1.0, 1e9, 0.3, 1000.0, 20.0


def ss_plate(ne: int, h: float = 1e-3, a: float = 1.0) -> DynamicModel:
    mesh = generators.strip(a, a, ne, ne)
    edges = np.unique(np.concatenate([mesh.node_set(s) for s in ("clamped", "tip", "bottom", "top")]))
    x = mesh.nodes
    c0 = np.flatnonzero(np.linalg.norm(x[:, :2], axis=1) < 1e-12)
    c1 = np.flatnonzero(np.linalg.norm(x[:, :2] - [a, 0.0], axis=1) < 1e-12)
    return DynamicModel(Model(ShellBody(mesh, ShellMaterial(E, NU, h, density=RHO)),
                              [Fix(edges, "z"), Fix(c0, ("x", "y")), Fix(c1, "y")]))


def annulus(n_radial, n_circ, hub="translations", thickness=1e-4):
    mesh = generators.annulus(A, B, n_radial, n_circ)
    cons = [Fix(mesh.node_set("inner"), hub)] if hub else []
    return DynamicModel(Model(ShellBody(mesh, ShellMaterial(E, NU, thickness, density=RHO)), cons))


def plate_study() -> None:
    h, a = 1e-3, 1.0
    D = E * h ** 3 / (12 * (1 - NU ** 2))
    exact = np.sort([np.pi ** 2 * (m * m + n * n) for m in range(1, 4) for n in range(1, 4)])[:6]
    print("\n### Simply supported square plate, h/a = 1e-3: omega a^2 sqrt(rho h / D)\n")
    print("| mesh | DoFs | " + " | ".join(f"mode {k + 1}" for k in range(6)) + " | max error |")
    print("|---|---|" + "---|" * 7)
    for ne in (4, 8, 16):
        dyn = ss_plate(ne, h, a)
        w = solve_modes(modal_problem_at_rest(dyn), 6).frequencies * a * a * np.sqrt(RHO * h / D)
        err = np.abs(w / exact - 1)
        print(f"| {ne}x{ne} | {dyn.n_dof} | " + " | ".join(f"{v:.3f}" for v in w) + f" | {err.max():.2e} |")
    print("| exact | | " + " | ".join(f"{v:.3f}" for v in exact) + " | |")


def annulus_study() -> None:
    ref = {n: radial_membrane_frequencies(n, 2, OMEGA, A, B, E, NU, RHO, "hub", 800) for n in range(5)}
    print("\n### Spinning hub annulus, transverse modes (rad/s, co-rotating frame), Omega = 20 rad/s\n")
    print("| hub | h | mesh | DoFs | (0,0) | (1,0) | (2,0) | (3,0) | (4,0) | (0,1) | max error |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    refs = [ref[0][0], ref[1][0], ref[2][0], ref[3][0], ref[4][0], ref[0][1]]
    for hub in ("translations", "all"):
        for h in (1e-3, 1e-4):
            for nr, nc in ((2, 16), (4, 32), (8, 64)):
                dyn = annulus(nr, nc, hub, h)
                modes = solve_modes(modal_problem_in_spin(dyn, [0, 0, OMEGA], [0, 0, 0]), 12)
                found = {}
                for r in describe_modes(modes):
                    found.setdefault((r.nodal_diameters, r.nodal_circles), r.frequency_rad_s)
                keys = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (0, 1)]
                vals = [found.get(k, np.nan) for k in keys]
                err = np.nanmax(np.abs(np.array(vals) / refs - 1))
                print(f"| {'pinned' if hub == 'translations' else 'clamped'} | {h:g} | {nr}x{nc} | {dyn.n_dof} | "
                      + " | ".join(f"{v:.3f}" for v in vals) + f" | {err:.2e} |")
    print("| membrane, 1-D radial (800 quadratic elements) | | | | " + " | ".join(f"{v:.3f}" for v in refs) + " | |")



def fft_study(revolutions: int = 20) -> None:
    from flexbody.scenes.scene import run_scene
    from flexbody.scenes.sources import open_scene
    scene = open_scene("examples/kicked_spinning_annulus.toml").build({"end_time": revolutions * 2 * np.pi / OMEGA})
    rim = scene.model.body.mesh.node_set("outer")
    theta = np.arctan2(scene.model.body.mesh.nodes[rim, 1], scene.model.body.mesh.nodes[rim, 0])
    times, w = [], []

    def on_step(rec, state, history):
        times.append(rec.time)
        w.append(state.x[rim, 2].copy())

    t0 = time.perf_counter()
    run_scene(scene, on_step=on_step)
    run_time = time.perf_counter() - t0
    t, w = np.array(times), np.array(w)
    dt = t[1] - t[0]
    p = modal_problem_in_spin(DynamicModel(scene.model), [0, 0, OMEGA], [0, 0, 0])
    reports = describe_modes(solve_modes(p, 12))
    modal = {}
    for r in reports:
        modal.setdefault((r.nodal_diameters, r.nodal_circles), r.frequency_rad_s)
    print(f"\n### Kicked annulus (4x32), {revolutions} revolutions ({len(t) - 1} steps, {run_time:.0f} s): FFT peaks "
          "of the rim's n-th Fourier component against the modal frequencies (co-rotating frame)\n")
    print("| n | FFT peak (rad/s) | modal (n, 0) (rad/s) | difference | resolution 2 pi / T |")
    print("|---|---|---|---|---|")
    T = t[-1] - t[0]
    for n in range(4):
        c = (w * np.cos(n * theta)[None, :]).mean(axis=1)
        c = c - c.mean()
        pad = 32 * len(c)
        spec = np.abs(np.fft.rfft(c * np.hanning(len(c)), pad))
        freqs = 2 * np.pi * np.fft.rfftfreq(pad, dt)
        k = int(np.argmax(spec[1:])) + 1
        a_, b_, c_ = np.log(spec[k - 1:k + 2])
        shift = 0.5 * (a_ - c_) / (a_ - 2 * b_ + c_)
        peak = freqs[k] + shift * (freqs[1] - freqs[0])
        ref = modal[(n, 0)]
        print(f"| {n} | {peak:.3f} | {ref:.3f} | {peak / ref - 1:+.2e} | {2 * np.pi / T:.2f} |")


def timing_study() -> None:
    print("\n### Timings (this machine, one numba thread)\n")
    print("| case | DoFs | set-up (tangent, steady spin) s | eigen-solution s | total s | target s |")
    print("|---|---|---|---|---|---|")
    dyn = ss_plate(70, 1e-3)
    dyn.model.residual_and_tangent(dyn.model.initial_state(), 0.0)   # kernels loaded
    t0 = time.perf_counter()
    p = modal_problem_at_rest(dyn)
    t1 = time.perf_counter()
    modes = solve_modes(p, 20)
    t2 = time.perf_counter()
    print(f"| first 20 modes, SS plate 70x70 | {dyn.n_dof} | {t1 - t0:.1f} | {t2 - t1:.1f} | {t2 - t0:.1f} | 60 |")
    dyn = annulus(5, 44, "all", 1e-3)
    t0 = time.perf_counter()
    setup = solve = 0.0
    for omega in np.linspace(2.0, 20.0, 10):
        a = time.perf_counter()
        p = modal_problem_in_spin(dyn, [0, 0, omega], [0, 0, 0])
        b = time.perf_counter()
        solve_modes(p, 10)
        c = time.perf_counter()
        setup, solve = setup + b - a, solve + c - b
    print(f"| 10-point Campbell sweep (10 modes), hub annulus 5x44 | {dyn.n_dof} | {setup:.1f} | {solve:.1f} | "
          f"{time.perf_counter() - t0:.1f} | 30 |")
    print(f"\n(the plate's 20th frequency {modes.frequencies[-1]:.4g} rad/s)")


if __name__ == "__main__":
    studies = sys.argv[1:] or ["plate", "annulus", "fft", "timing"]
    for name in studies:
        {"plate": plate_study, "annulus": annulus_study, "fft": fft_study, "timing": timing_study}[name]()
