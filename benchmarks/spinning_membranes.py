"""Spinning membranes at real scale: the acceptance cases of issue #15, as scene files run through the API.

    python benchmarks/spinning_membranes.py [CASE ...] [--revolutions R] [--cells 4,8,16]
                                             [--thickness 1e-3,1e-6] [--mass consistent] [--out FILE]
                                             [--steps N] [--every K] [--rho-inf R] [--frame F]
                                             [--adaptive [--tolerance T] | --fixed] [--integrator KEY=VALUE ...]
                                             [--wrinkling] [--repeat K]

``--steps``, ``--every``, ``--rho-inf``, ``--frame``, ``--adaptive``, ``--fixed``, ``--integrator`` and
``--wrinkling`` leave the defaults (100 steps per revolution, a record every 10 steps, the scene's rho_inf, frame
and time stepping: fixed for the annuli, error-controlled for the sail, the linear membrane law) for studies; the acceptance rows use none (``--wrinkling``: the tension-field membrane law, docs/theory.md).
``--repeat K`` runs each case K times and prints the CPU column as "median (min-max)": on a shared machine the
same run varies by a third from one minute to the next (the other columns are the same in every run).

Cases (all start on the steady spin, ``[analysis.initial] state = "steady_spin"``, at default settings):

* ``hub``: the annulus clamped to a hub turning at a constant 20 rad/s (a = 0.2, b = 1, E = 1e9, nu = 0.3,
  rho = 1000), n_radial x 8 n_radial cells, h/R from ``--thickness``, kicked out of plane with
  v_z = 0.05 (r - a)/(b - a) sum_{n=0..3} cos(n theta), 100 steps per revolution. Conserved: the Jacobi integral
  T + W - Omega . L (the hub turns at a constant rate), reported as its drift.
* ``free``: the same annulus without a hub (a/b = 0.1 and 0.5), the same kick: energy and angular-momentum drift.
* ``sail``: ``examples/solar_sail_10m.toml``, a hexagonal film 10 m across (circumradius 5 m, h = 1e-4 m:
  h/L = 1e-5, E = 3 GPa, nu = 0.3, rho = 1420), the inner ring of 4 clamped to a hub at 2 rpm, a sin^2
  out-of-plane pulse of 2 mN in total on the rim nodes over the first fifth of a revolution; error-controlled
  steps (the scene's setting) with a record every 10 of 100 base steps per revolution (``--fixed``: fixed steps).

Each row: completed or where it stopped, DoFs, steps, Newton iterations and factorizations per step, CPU time of
the solve, the dominant frequency of the rim deflection in the turning frame (FFT peak of ``w_rim``, the tracked
rim node turning with the membrane; recorded every 10 steps) and the drift of the conserved quantity. Not run by the tests (a 20-revolution study takes minutes
per case); ``--revolutions 1`` is a quick look.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import textwrap
import time

import numpy as np

from flexbody.scenes.scene import run_scene
from flexbody.scenes.toml_scene import load_toml_scene, scene_from_document
import tomllib

OMEGA = 20.0

ANNULUS = """
name = "{name}"
[mesh]
generator = "annulus"
inner_radius = {a}
outer_radius = 1.0
n_radial = {nr}
n_circ = {nc}
[material]
young = 1e9
poisson = 0.3
thickness = {h}
density = 1000.0
wrinkling = {wrinkling}
[analysis]
type = "dynamic"
dt = {dt}
end_time = {end}
output_every = {every}
mass = "{mass}"
{options}[analysis.initial]
state = "steady_spin"
angular_velocity = [0.0, 0.0, {omega}]
center = [0.0, 0.0, 0.0]
[[analysis.initial.velocity_field]]
direction = [0.0, 0.0, 1.0]
amplitude = 0.05
radial = "linear"
modes = [0, 1, 2, 3]
[[output]]
name = "w_rim"
near = [1.0, 0.0, 0.0]
component = "z"
"""

HUB = """
[analysis.hub]
radius = {a}
angular_velocity = [0.0, 0.0, {omega}]
"""

SAIL = Path(__file__).resolve().parents[1] / "examples" / "solar_sail_10m.toml"


def _scene(text: str):
    return scene_from_document(tomllib.loads(textwrap.dedent(text)), "benchmarks/spinning_membranes.py")


def _drift(summary, omega: float | None) -> tuple[str, float]:
    """The drift of the conserved quantity: the Jacobi integral T + W - Omega L_z (hub at a constant rate), else
    the energy (and the angular momentum, for a free body), relative to max (T + W)."""
    e = summary.energies
    T, W = np.asarray(e["kinetic"]), np.asarray(e["strain"])
    scale = float(np.max(T + W)) or 1.0
    if omega is not None:
        J = T + W - omega * np.asarray(e["angular_momentum"])[:, 2]
        return "Jacobi T + W - Omega L", float(np.max(np.abs(J - J[0])) / scale)
    E = T + W
    L = np.asarray(e["angular_momentum"])
    dl = float(np.max(np.linalg.norm(L - L[0], axis=1)) / (np.linalg.norm(L[0]) or 1.0))
    return f"energy (ang. mom. {dl:.1e})", float(np.max(np.abs(E - E[0])) / scale)


def rim_frequency(summary) -> float:
    """The dominant circular frequency (rad/s) of the rim deflection ``w_rim`` in the turning frame (the tracked
    node turns with the membrane, so its history already is in that frame): the peak of the FFT of w - mean,
    refined by a parabola through the peak bin and its neighbours. NaN without that output."""
    h = summary.history
    if "w_rim" not in h or len(h["w_rim"]) < 8:
        return float("nan")
    t, w = np.asarray(h["time"]), np.asarray(h["w_rim"])
    dt = float(np.mean(np.diff(t)))
    spec = np.abs(np.fft.rfft((w - w.mean()) * np.hanning(w.size)))
    k = int(np.argmax(spec[1:])) + 1
    shift = 0.0
    if 0 < k < spec.size - 1:
        a, b, c = np.log(spec[k - 1:k + 2] + 1e-300)
        shift = 0.5 * (a - c) / (a - 2 * b + c)
    return 2 * math.pi * (k + shift) / (w.size * dt)


def compressive_fraction(body, state) -> float:
    """The fraction of Gauss points whose smaller principal membrane force (N11 + N22)/2 - sqrt(((N11 - N22)/2)^2
    + N12^2) is negative (compressed: without a wrinkling model these regions are not physical)."""
    n = body.stresses(state)[:, :, :3]
    n11, n22, n12 = n[..., 0], n[..., 1], n[..., 2]
    radius = np.sqrt((0.5 * (n11 - n22)) ** 2 + n12 ** 2)
    smallest, largest = 0.5 * (n11 + n22) - radius, 0.5 * (n11 + n22) + radius
    # below round-off of the largest force: a wrinkled point of the tension-field law has smallest = 0 exactly
    return float(np.mean(smallest < -1e-9 * np.abs(largest).max()))


def _cpu_column(seconds: list[float]) -> str:
    """One run's CPU seconds, or the median (min-max) of several."""
    if len(seconds) == 1:
        return f"{seconds[0]:.1f}"
    return f"{float(np.median(seconds)):.1f} ({min(seconds):.1f}-{max(seconds):.1f})"


def _run(label: str, build, omega: float | None, compression: bool = False, repeat: int = 1) -> str:
    """One row: ``build()`` makes the scene; run ``repeat`` times (the CPU column: :func:`_cpu_column`)."""
    seconds = []
    for _ in range(repeat):
        try:
            scene = build()
        except Exception as exc:  # a bad case is reported in its row, the study goes on
            return f"| {label} | - | - | - | - | - | - | build failed: {exc} |"
        t0 = time.process_time()
        try:
            summary = run_scene(scene)
        except (ValueError, ArithmeticError, RuntimeError) as exc:
            return f"| {label} | {scene.model.n_dof} | - | - | - | - | - | failed: {str(exc)[:120]} |"
        seconds.append(time.process_time() - t0 - getattr(summary, "compile_time_s", 0.0))
    res = summary.result
    steps = res.steps or 1
    rejected = (f"; {res.rejected_error} + {res.rejected_newton} steps rejected, h {res.min_step:.2e} to "
                f"{res.max_step:.2e}") if res.adaptive else ""
    what, drift = _drift(summary, omega)
    state = ("completed" if res.converged else f"stopped: {res.message[:100]}") + f"; {summary.frame} frame"
    if compression:
        state += f"; compressive Gauss points at the end {100 * compressive_fraction(scene.model.body, res.state):.0f} %"
    return (f"| {label} | {scene.model.n_dof} | {steps} | {res.stats.iterations / steps:.2f} | "
            f"{res.stats.factorizations / steps:.3f} | {_cpu_column(seconds)} | {rim_frequency(summary):.2f} | "
            f"{state}; {what} drift {drift:.1e}{rejected} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", default=["hub", "free", "sail"])
    parser.add_argument("--revolutions", type=float, default=20.0)
    parser.add_argument("--cells", default="4,8,16", help="radial cells of the annuli")
    parser.add_argument("--thickness", default="1e-3,1e-4,1e-5,1e-6", help="h/R of the hub annulus")
    parser.add_argument("--mass", default="lumped", choices=("lumped", "consistent"), help="the mass matrix")
    parser.add_argument("--steps", type=int, default=100, help="time steps per revolution (adaptive: the base step)")
    parser.add_argument("--every", type=int, default=10, help="record every k-th (base) step")
    stepping = parser.add_mutually_exclusive_group()
    stepping.add_argument("--adaptive", action="store_true", help="error-controlled time steps")
    stepping.add_argument("--fixed", action="store_true", help="fixed time steps (the sail scene's are adaptive)")
    parser.add_argument("--tolerance", type=float, default=1e-5, help="adaptive: the local error tolerance")
    parser.add_argument("--rho-inf", type=float, default=None, help="the integrator's rho_inf (default: the scene's)")
    parser.add_argument("--frame", default=None, choices=("inertial", "turning"), help="default: the scene's")
    parser.add_argument("--wrinkling", action="store_true", help="the tension-field membrane law ([material])")
    parser.add_argument("--integrator", action="append", default=[], metavar="KEY=VALUE",
                        help="an [analysis.integrator] setting (e.g. atol=1e-8), repeatable")
    parser.add_argument("--repeat", type=int, default=1, help="runs per case (CPU: median and range)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    if args.repeat < 1:
        parser.error(f"--repeat must be >= 1, got {args.repeat}")
    period = 2 * math.pi / OMEGA
    dt, end = period / args.steps, args.revolutions * period
    options = "" if args.rho_inf is None else f"rho_inf = {args.rho_inf}\n"
    options += "" if args.frame is None else f"frame = \"{args.frame}\"\n"
    integrator = list(args.integrator)
    if args.adaptive:
        options += "adaptive = true\n"
        integrator.append(f"error_tolerance = {args.tolerance}")
    if integrator:
        options += "[analysis.integrator]\n" + "".join(f"{item}\n" for item in integrator)
    extra = dict(every=args.every, options=options, wrinkling=str(args.wrinkling).lower())
    rows = ["| case | DoFs | steps | iterations / step | factorizations / step | CPU s | rim w peak rad/s | outcome |",
            "|---|---|---|---|---|---|---|---|"]
    cells = [int(c) for c in args.cells.split(",")]
    for case in args.cases:
        if case == "hub":
            for h in (float(v) for v in args.thickness.split(",")):
                for nr in cells:
                    text = ANNULUS.format(name="hub", a=0.2, nr=nr, nc=8 * nr, h=h, dt=dt, end=end, omega=OMEGA,
                                          mass=args.mass, **extra)
                    text += HUB.format(a=0.2, omega=OMEGA)
                    rows.append(_run(f"hub annulus {nr}x{8 * nr}, h/R {h:g}", lambda t=text: _scene(t), OMEGA,
                                     repeat=args.repeat))
                    print(rows[-1], flush=True)
        elif case == "free":
            for a in (0.1, 0.5):
                nr = cells[0]
                text = ANNULUS.format(name="free", a=a, nr=nr, nc=8 * nr, h=1e-3, dt=dt, end=end, omega=OMEGA,
                                      mass=args.mass, **extra)
                rows.append(_run(f"free annulus a/b {a}, {nr}x{8 * nr}", lambda t=text: _scene(t), None,
                                 repeat=args.repeat))
                print(rows[-1], flush=True)
        elif case == "sail":                                   # examples/solar_sail_10m.toml, 2 rpm
            sail_period = 60.0 / 2
            overrides = {"dt": sail_period / args.steps, "end_time": args.revolutions * sail_period, "mass": args.mass,
                         "output_every": args.every}
            if args.frame is not None:
                overrides["frame"] = args.frame
            if args.wrinkling:
                overrides["wrinkling"] = True
            if args.rho_inf is not None:
                overrides["rho_inf"] = args.rho_inf
            if args.adaptive or args.fixed:
                overrides["adaptive"] = not args.fixed
            for item in integrator:                        # "key = value" (TOML values), the --integrator settings
                key, value = item.split("=", 1)
                overrides[f"analysis.integrator.{key.strip()}"] = tomllib.loads(f"v = {value}")["v"]
            rows.append(_run("10 m hexagonal sail, 4 rings, 2 rpm, 2 mN rim pulse",
                             lambda: load_toml_scene(SAIL, overrides), 2 * 2 * math.pi / 60, compression=True,
                             repeat=args.repeat))
            print(rows[-1], flush=True)
        else:
            raise SystemExit(f"unknown case {case!r}: hub, free or sail")
    table = "\n".join(rows)
    print(table)
    if args.out:
        with open(args.out, "w") as f:
            f.write(table + "\n")


if __name__ == "__main__":
    main()
