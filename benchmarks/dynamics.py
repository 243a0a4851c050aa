"""Lie-group generalized-alpha on the shell: error against run time over a sweep of time steps.

    python benchmarks/dynamics.py [--out FILE] [--threads N] [--quick] [--adaptive]

Two studies (not run by the tests):

* ``tumbling``: a free stiff plate (1 x 0.5 x 0.01, E = 1e9, rho = 1000, 2 x 2 x 1 elements) spun about its
  intermediate axis at 5 rad/s with a 1 % perturbation, 3 s. Error: max |omega - omega_ref| / |omega_0| over
  the run against Euler's rigid-body equations (scipy DOP853, rtol 1e-11) with the discrete inertia; also
  the relative drifts of energy and angular momentum. Both iteration-matrix policies.
* ``cantilever``: a clamped strip (1 x 0.1 x 0.01, E = 1e9, nu = 0, 2 x 6 x 1 elements) released with the
  first beam mode's velocity (tip 0.2 m/s), half a period. Error: max nodal position difference to a run
  with h = T/1280.

With ``--adaptive``: fixed steps against error-controlled ones (``AlphaSettings(adaptive=True)``) on both, and
on the cantilever released at 8 m/s (fixed T/40 fails without cut-backs): error against run time.

Prints a Markdown table per study (and writes them to ``--out``).
"""

from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np
from scipy.integrate import solve_ivp

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.dynamics import DynamicModel
from flexbody.lie import so3
from flexbody.mesh import generators
from flexbody.shell.material import ShellMaterial
from flexbody.energy import integrate_motion
from integrators.generalized_alpha import AlphaSettings, generalized_alpha

HEADER = ("| study | h | steps | policy | iterations | tangents | factorizations | wall time [s] | error "
          "| energy drift | ang. mom. drift |\n|---|---|---|---|---|---|---|---|---|---|---|")


def _row(study, h, steps, policy, res, err, e_drift="", l_drift="") -> str:
    s = res.stats
    fmt = lambda v: v if isinstance(v, str) else f"{v:.2e}"
    return (f"| {study} | {h:.3g} | {steps} | {policy} | {s.iterations} | {s.tangent_updates} | "
            f"{s.factorizations} | {res.wall_time:.2f} | {fmt(err)} | {fmt(e_drift)} | {fmt(l_drift)} |")


def _tumbling_setup():
    """The settled tumbling plate: (dyn, settled start, reference solution, omega_0, t_end)."""
    mesh = generators.strip(1.0, 0.5, 2, 1)
    dyn = DynamicModel(Model(ShellBody(mesh, ShellMaterial(1e9, 0.3, 0.01, density=1000.0))))
    s0 = dyn.model.initial_state()
    c, _ = dyn.rigid_inertia_tensor(s0)
    # settle into the centrifugal stretch first (an unstressed spinning body vibrates), rho_inf = 0
    pre = generalized_alpha(dyn, 0.1, 0.005, state=s0, velocity=dyn.rigid_velocity(s0, [0.05, 5.0, 0.05], center=c),
                            settings=AlphaSettings(rho_inf=0.0))
    t_end = 3.0
    Q0 = dyn.body_rotation(s0.x, pre.state.x)
    _, I = dyn.rigid_inertia_tensor(pre.state)
    Ib = Q0.T @ I @ Q0
    w0 = dyn.rigid_angular_velocity(pre.state, pre.velocity)

    def rhs(t, y):
        Q, wb = y[:9].reshape(3, 3), y[9:]
        return np.concatenate([(Q @ so3.hat(wb)).ravel(), np.linalg.solve(Ib, -np.cross(wb, Ib @ wb))])

    ref = solve_ivp(rhs, (0, t_end), np.concatenate([Q0.ravel(), Q0.T @ w0]), method="DOP853", dense_output=True,
                    rtol=1e-11, atol=1e-12)
    return dyn, pre, ref, w0, t_end


def tumbling_study(steps_list, policies) -> list[str]:
    dyn, pre, ref, w0, t_end = _tumbling_setup()
    rows = []
    for n in steps_list:
        for policy in policies:
            hist = []
            run = integrate_motion(dyn, t_end, t_end / n, state=pre.state, velocity=pre.velocity,
                                   settings=AlphaSettings(rho_inf=0.9, policy=policy),
                                   on_step=lambda rec, q, v: hist.append((rec.time, dyn.rigid_angular_velocity(q, v))))
            res = run.result
            if not res.converged:
                rows.append(f"| tumbling | {t_end / n:.3g} | {n} | {policy} | failed: {res.message} |")
                continue
            err = max(np.linalg.norm(w - ref.sol(t)[:9].reshape(3, 3) @ ref.sol(t)[9:]) for t, w in hist)
            recs = [run.initial] + run.records
            E = np.array([r.total_energy for r in recs])
            L = np.array([r.angular_momentum for r in recs])
            rows.append(_row("tumbling", t_end / n, n, policy, res, err / np.linalg.norm(w0),
                             np.abs(E - E[0]).max() / E[0], np.abs(L - L[0]).max() / np.linalg.norm(L[0])))
            print(rows[-1], flush=True)
    return rows


def _cantilever_setup(tip_velocity: float = 0.2):
    """The clamped strip released in its first mode: (dyn, v0, t_end, tight settings, reference run)."""
    L, W, H, E, rho, beta1 = 1.0, 0.1, 0.01, 1e9, 1000.0, 1.8751040687119611
    mesh = generators.strip(L, W, 6, 1)
    dyn = DynamicModel(Model(ShellBody(mesh, ShellMaterial(E, 0.0, H, density=rho)),
                             [Fix(mesh.node_sets["clamped"], "all")]))
    b = beta1 / L
    sig = (math.cosh(beta1) + math.cos(beta1)) / (math.sinh(beta1) + math.sin(beta1))
    x = mesh.nodes[:, 0]
    phi = np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x))
    dphi = b * (np.sinh(b * x) + np.sin(b * x) - sig * (np.cosh(b * x) - np.cos(b * x)))
    v0 = np.zeros(dyn.n_dof)
    z, r2 = dyn.is_translation & (dyn.comp == 2), dyn.comp == 4
    v0[z] = tip_velocity / phi.max() * phi[dyn.node[z]]
    v0[r2] = -tip_velocity / phi.max() * dphi[dyn.node[r2]]
    period = 2 * math.pi * L**2 / beta1**2 / math.sqrt(E * H**2 / (12 * rho))
    t_end = 0.5 * period
    tight = dict(rho_inf=0.9, rtol=1e-10, atol=1e-12)
    ref = generalized_alpha(dyn, t_end, t_end / 1280, velocity=v0, settings=AlphaSettings(**tight))
    return dyn, v0, t_end, tight, ref


def cantilever_study(steps_list, policies) -> list[str]:
    dyn, v0, t_end, tight, ref = _cantilever_setup()
    rows = []
    for n in steps_list:
        for policy in policies:
            res = generalized_alpha(dyn, t_end, t_end / n, velocity=v0, settings=AlphaSettings(policy=policy, **tight))
            if not res.converged:
                rows.append(f"| cantilever | {t_end / n:.3g} | {n} | {policy} | failed: {res.message} |")
                continue
            rows.append(_row("cantilever", t_end / n, n, policy, res, float(np.abs(res.state.x - ref.state.x).max())))
            print(rows[-1], flush=True)
    return rows


ADAPTIVE_HEADER = ("| study | steps | tolerance | accepted | rejected (error / Newton) | h min - max | iterations "
                   "| factorizations | wall time [s] | error |\n|---|---|---|---|---|---|---|---|---|---|")


def _adaptive_row(study, label, tol, res, err) -> str:
    s = res.stats
    fmt = lambda v: f"{v:.2e}" if np.isfinite(v) else "failed"
    return (f"| {study} | {label} | {tol} | {res.steps} | {res.rejected_error} / {res.rejected_newton} | "
            f"{res.min_step:.3g} - {res.max_step:.3g} | {s.iterations} | {s.factorizations} | {res.wall_time:.2f} "
            f"| {fmt(err)} |")


def adaptive_study(tolerances, tumbling_steps, cantilever_steps) -> list[str]:
    """Error against run time, fixed steps against error-controlled ones (default settings otherwise).

    Tumbling plate: the error of omega at every 0.1 s (the adaptive run's output times: steps <= 0.1 s);
    cantilever (tip 0.2 m/s; and 8 m/s, a release that fails at the fixed step T/40 without cut-backs): the
    final positions against the T/1280 reference (adaptive: a single output at the end).
    """
    rows = []
    dyn, pre, ref, w0, t_end = _tumbling_setup()

    def tumble(settings, h, every):
        hist = []
        res = integrate_motion(dyn, t_end, h, state=pre.state, velocity=pre.velocity, settings=settings,
                               record_every=every,
                               on_step=lambda rec, q, v: hist.append((rec.time, dyn.rigid_angular_velocity(q, v)))).result
        err = max((np.linalg.norm(w - ref.sol(t)[:9].reshape(3, 3) @ ref.sol(t)[9:]) for t, w in hist
                   if abs(t / 0.1 - round(t / 0.1)) < 1e-9), default=float("nan"))
        return res, err / np.linalg.norm(w0) if res.converged else float("nan")

    for n in tumbling_steps:
        res, err = tumble(AlphaSettings(rho_inf=0.9), t_end / n, 1)
        rows.append(_adaptive_row("tumbling", f"fixed {n}", "-", res, err))
        print(rows[-1], flush=True)
    for tol in tolerances:
        res, err = tumble(AlphaSettings(rho_inf=0.9, adaptive=True, error_tolerance=tol), 0.1, 1)
        rows.append(_adaptive_row("tumbling", "adaptive", f"{tol:g}", res, err))
        print(rows[-1], flush=True)
    for tip in (0.2, 8.0):
        dyn_c, v0, t_c, tight, ref_c = _cantilever_setup(tip)
        study = f"cantilever {tip:g} m/s"
        for n in cantilever_steps:
            res = generalized_alpha(dyn_c, t_c, t_c / n, velocity=v0, settings=AlphaSettings(rho_inf=0.9))
            err = float(np.abs(res.state.x - ref_c.state.x).max()) if res.converged else float("nan")
            rows.append(_adaptive_row(study, f"fixed {n}", "-", res, err))
            print(rows[-1], flush=True)
        for tol in tolerances:
            res = generalized_alpha(dyn_c, t_c, t_c, velocity=v0,
                                    settings=AlphaSettings(rho_inf=0.9, adaptive=True, error_tolerance=tol))
            err = float(np.abs(res.state.x - ref_c.state.x).max()) if res.converged else float("nan")
            rows.append(_adaptive_row(study, "adaptive", f"{tol:g}", res, err))
            print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None)
    parser.add_argument("--threads", type=int, default=1,
                        help="numba threads (1 is fastest for these small models)")
    parser.add_argument("--quick", action="store_true", help="fewer time steps")
    parser.add_argument("--adaptive", action="store_true",
                        help="only the study of fixed against error-controlled time steps")
    args = parser.parse_args()
    numba.set_num_threads(args.threads)
    policies = ("modified", "full")
    t0 = time.perf_counter()
    if args.adaptive:
        print(ADAPTIVE_HEADER)
        rows = [ADAPTIVE_HEADER] + adaptive_study((1e-4, 1e-5, 1e-6, 1e-7), (150, 300, 600, 1200),
                                                  (10, 20, 40, 80, 160))
        text = "\n".join(rows) + f"\n\nTotal {time.perf_counter() - t0:.1f} s.\n"
        if args.out:
            with open(args.out, "w") as fh:
                fh.write(text)
        return
    print(HEADER)
    rows = [HEADER]
    rows += tumbling_study((150, 300, 600) if args.quick else (150, 300, 600, 1200), policies)
    rows += cantilever_study((10, 20, 40) if args.quick else (10, 20, 40, 80, 160), policies)
    text = "\n".join(rows) + f"\n\nTotal {time.perf_counter() - t0:.1f} s.\n"
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
