"""Stiff and extreme cases: very thin shells, rotations past 4 pi, distorted meshes, the whole load in one
step, nearly incompressible material, a sharp snap-back under arc-length.

    python benchmarks/stress.py [--quick] [--out docs/robustness_results.md] [CASE ...]
    python benchmarks/stress.py --dynamic [--quick] [CASE ...]      # the thin spinning membrane, large dt

Prints one row per case: what was checked, the measured figure, pass or fail. ``--quick`` skips the slow
cases (those the test suite does not run). The fast cases also run in tests/test_stress.py and
tests/test_stress_dynamics.py, through the functions of this file. ``--dynamic`` runs the dynamic cases (a
very thin membrane spinning fast, time steps 10-1000 times the explicit limit, rho_inf from 0 to 1) instead
of the static ones. The table and its discussion are in docs/robustness.md.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from dataclasses import dataclass

import numpy as np

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.lie import so3
from flexbody.loads import NodalLoad, nodal_vectors_from_edges
from flexbody.mesh import ELEMENT_EDGES, Tri6Mesh, generators
from flexbody.scenes import build, run_scene
from flexbody.scenes.reference import read_reference_csv
from flexbody.shell.material import ShellMaterial
from integrators.static import load_control

L_SHEAR, E_SHEAR = 10.0, 1.2e6


@dataclass
class Row:
    case: str
    checked: str
    figure: str
    passed: bool
    seconds: float = 0.0
    note: str = ""


# -- the end-shear strip (Sze et al. 2004, 3.1), built here so that mesh and material can vary ---------------
def shear_reference():
    cols, _ = read_reference_csv("ref_cantilever_end_shear.csv")
    return cols["load_factor_P_over_Pmax"], cols["W_tip"], cols["minus_U_tip"]


def end_shear_model(mesh: Tri6Mesh, thickness: float = 0.1, poisson: float = 0.0, width: float | None = None):
    """Clamped at x = 0, a transverse line load on the tip edge of 4 (h/0.1)^3 per unit width (so the
    normalised response is that of the benchmark for any width and thickness). Returns (model, tip node)."""
    b = float(np.ptp(mesh.nodes[:, 1])) if width is None else width
    body = ShellBody(mesh, ShellMaterial(E_SHEAR, poisson, thickness))
    q = 4.0 * (thickness / 0.1) ** 3
    forces = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("tip"), np.array([0, 0, q]), mesh.n_nodes)
    loads = [NodalLoad([i], force=forces[i]) for i in np.flatnonzero(np.any(forces != 0, axis=1))]
    model = Model(body, [Fix(mesh.node_set("clamped"), "all")], loads)
    return model, mesh.nearest_node([mesh.nodes[:, 0].max(), b / 2, 0.0])


def run_end_shear(model, tip, load_factors, settings=None):
    """Load control; the tip's (W, -U) at every converged step; the max error against the reference,
    relative to the reference's largest value (as the scenes measure it)."""
    history = []
    res = load_control(model, load_factors, settings=settings,
                       on_step=lambda rec, q: history.append(
                           (rec.load_factor, *(q.x[tip] - model.body.mesh.nodes[tip])[[2, 0]])))
    lam_ref, w_ref, u_ref = shear_reference()
    if not history:
        return res, float("nan"), history
    lam, w, u = np.array(history).T
    lam, w, u = np.r_[0, lam], np.r_[0, w], np.r_[0, -u]
    err = 0.0
    for lf, wr, ur in zip(lam_ref, w_ref, u_ref):
        if 0 < lf <= lam.max() + 1e-12:
            err = max(err, abs(np.interp(lf, lam, w) - wr) / np.abs(w_ref).max(),
                      abs(np.interp(lf, lam, u) - ur) / np.abs(u_ref).max())
    return res, err, history


def _newton_figures(res) -> str:
    return f"{len(res.records)} steps, {res.stats.iterations} it, {res.cutbacks} cut-backs"


# -- cases -------------------------------------------------------------------------------------------------------
def case_thickness(h_over_l: float, nx: int = 16) -> Row:
    """End-shear strip at h/L: the normalised tip response against the benchmark (h/L = 1e-2) within 1 %."""
    t0 = time.perf_counter()
    model, tip = end_shear_model(generators.strip(L_SHEAR, 1.0, nx, 1), thickness=h_over_l * L_SHEAR)
    res, err, hist = run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
    w_end = hist[-1][1] if hist else float("nan")
    ok = res.converged and err <= 0.01
    return Row(f"thickness h/L = {h_over_l:.0e} (strip 2x{nx}x1)", "normalised W, -U at the tip vs reference "
               "(<= 1 %), Newton converges", f"max error {100 * err:.2f} %; W_tip(P_max) = {w_end:.4f}; "
               f"{_newton_figures(res)}", ok, time.perf_counter() - t0,
               "" if ok else res.message if not res.converged else "")


def case_rotation_4pi(nx: int = 32, steps: int = 80) -> Row:
    """End-moment strip under 2 M_max: it rolls into a double circle (tip rotation 4 pi), exact elastica."""
    t0 = time.perf_counter()
    scene = build("cantilever_end_moment", nx=nx, steps=steps // 2)
    model, L = scene.model, 12.0
    tip = scene.outputs[0].node
    hist = []
    res = load_control(model, np.linspace(0, 2, steps + 1)[1:],
                       on_step=lambda rec, q: hist.append((rec.load_factor, *(q.x[tip] - model.body.mesh.nodes[tip]),
                                                           *q.frames[tip][:, 2])))
    if not hist:
        return Row("rotation 4 pi (2 M_max)", "double circle", "no step converged", False,
                   time.perf_counter() - t0, res.message)
    h = np.array(hist)
    lam, ux, uz = h[:, 0], h[:, 1], h[:, 3]
    theta = 2 * math.pi * lam
    err = max(np.abs(-ux - L * (1 - np.sin(theta) / theta)).max(), np.abs(uz - L * (1 - np.cos(theta)) / theta).max()) / L
    # the tip director's turn, accumulated over the steps (angle in the x-z plane)
    ang = np.unwrap(np.arctan2(-h[:, 4], h[:, 6]))
    turn = abs(ang[-1])
    ok = res.converged and abs(lam[-1] - 2.0) < 1e-12 and err < 0.01 and abs(turn / (4 * math.pi) - 1) < 0.01
    return Row(f"rotation past 4 pi (2 M_max, strip 2x{nx}x1)", "tip path vs exact elastica (error / L < 1 %), "
               "tip rotation = 4 pi", f"max error/L {100 * err:.3f} %; rotation {turn / math.pi:.4f} pi; "
               f"{_newton_figures(res)}", ok, time.perf_counter() - t0, "" if res.converged else res.message)


def case_exp_log() -> Row:
    """log(exp(phi)) near pi and 2 pi: the rotation comes back (angles wrap to [0, pi])."""
    t0 = time.perf_counter()
    rng = np.random.default_rng(1)
    worst = 0.0
    for p in [math.pi - 1e-9, math.pi - 1e-6, math.pi, math.pi + 1e-6, 2 * math.pi - 1e-6, 2 * math.pi,
              2 * math.pi + 1e-6, 4 * math.pi - 1e-3]:
        for _ in range(20):
            n = rng.normal(size=3)
            n /= np.linalg.norm(n)
            R = so3.exp(p * n)
            worst = max(worst, np.abs(so3.exp(so3.log(R)) - R).max(), abs(np.linalg.norm(so3.log(R)) - abs(
                math.remainder(p, 2 * math.pi))))
    ok = worst < 1e-8
    return Row("exp/log near pi and 2 pi", "exp(log(exp(phi))) = exp(phi), |log| = angle wrapped to [0, pi]",
               f"max deviation {worst:.1e}", ok, time.perf_counter() - t0)


def case_aspect(kind: str) -> Row:
    """Elements of aspect ratio 100: long ones (a narrow strip, 10 x 10 cells of 1 x 0.01, h = 0.01) or
    wide ones (a wide strip of one cell across, cells 0.625 x 62.5, h = 0.1)."""
    t0 = time.perf_counter()
    if kind == "long":
        mesh, h, label = generators.strip(L_SHEAR, 0.1, 10, 10), 0.01, "2x10x10, b = 0.1, h = 0.01: cells 1 x 0.01"
    else:
        mesh, h, label = generators.strip(L_SHEAR, 62.5, 16, 1), 0.1, "2x16x1, b = 62.5, h = 0.1: cells 0.625 x 62.5"
    model, tip = end_shear_model(mesh, thickness=h)
    res, err, _ = run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
    ok = res.converged and err <= 0.01
    return Row(f"aspect ratio 100 ({kind} elements)", f"end shear ({label}) vs reference (<= 1 %), converges",
               f"max error {100 * err:.2f} % up to load factor {res.load_factor:.3g}; {_newton_figures(res)}", ok,
               time.perf_counter() - t0, "" if res.converged else res.message[:400] + " ...")


def skewed_strip(shift: float = 0.2, nx: int = 16, ny: int = 2, seed: int = 0) -> Tri6Mesh:
    """The strip with every midside node slid along its (straight) edge by a random fraction in
    [-shift, shift] of the edge: the same surface, a distorted isoparametric map."""
    m = generators.strip(L_SHEAR, 1.0, nx, ny, "alternate")
    x = m.nodes.copy()
    rng = np.random.default_rng(seed)
    triples = m.elements[:, ELEMENT_EDGES].reshape(-1, 3)
    _, first = np.unique(triples[:, 1], return_index=True)
    for a, mid, b in triples[first]:
        x[mid] = 0.5 * (x[a] + x[b]) + rng.uniform(-shift, shift) * (x[b] - x[a])
    return Tri6Mesh(x, m.elements, m.directors, m.node_sets, m.edge_sets)


def case_skewed(shift: float = 0.2, nx: int = 16) -> Row:
    t0 = time.perf_counter()
    model, tip = end_shear_model(skewed_strip(shift, nx))
    res, err, _ = run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
    ok = res.converged and err <= 0.01
    return Row(f"skewed midside nodes (+-{shift} of the edge, strip 2x{nx}x2)", "end shear vs reference (<= 1 %)",
               f"max error {100 * err:.2f} %; {_newton_figures(res)}", ok, time.perf_counter() - t0,
               "" if res.converged else res.message)


def case_coarse() -> Row:
    t0 = time.perf_counter()
    model, tip = end_shear_model(generators.strip(L_SHEAR, 1.0, 4, 1))
    res, err, _ = run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
    ok = res.converged and err <= 0.02
    return Row("very coarse mesh (strip 2x4x1, 8 elements)", "end shear vs reference (<= 2 %)",
               f"max error {100 * err:.2f} %; {_newton_figures(res)}", ok, time.perf_counter() - t0,
               "" if res.converged else res.message)


def case_one_step_shear(h_over_l: float = 1e-2) -> Row:
    """The whole end-shear load as one step: cut-back and re-growth must reach it, on the reference path."""
    t0 = time.perf_counter()
    model, tip = end_shear_model(generators.strip(L_SHEAR, 1.0, 16, 1), thickness=h_over_l * L_SHEAR)
    res, err, hist = run_end_shear(model, tip, [1.0])
    lam_ref, w_ref, u_ref = shear_reference()
    e_end = abs(hist[-1][1] - w_ref[-1]) / abs(w_ref[-1]) if res.converged else float("nan")
    ok = res.converged and e_end <= 0.01
    return Row(f"whole load in one step (end shear, h/L = {h_over_l:.0e})", "reaches P_max; W_tip vs reference "
               "(<= 1 %)", f"W_tip error {100 * e_end:.2f} %; {_newton_figures(res)}", ok,
               time.perf_counter() - t0, "" if res.converged else res.message)


def case_one_step_moment(nx: int = 16) -> Row:
    """The whole end moment (a full circle) as one step."""
    t0 = time.perf_counter()
    scene = build("cantilever_end_moment", nx=nx)
    model, tip = scene.model, scene.outputs[0].node
    res = load_control(model, [1.0])
    u = res.state.x[tip] - model.body.mesh.nodes[tip]
    err = np.linalg.norm(u - np.array([-12.0, 0, 0])) / 12.0 if res.converged else float("nan")
    ok = res.converged and err < 0.01
    return Row("whole load in one step (end moment, full circle)", "reaches M_max; tip back at the clamp "
               "(error / L < 1 %)", f"tip error/L {100 * err:.3f} %; {_newton_figures(res)}", ok,
               time.perf_counter() - t0, "" if res.converged else res.message)


def case_incompressible(nu: float = 0.4999) -> Row:
    """nu = 0.4999: small-load tip deflection between the plate (E/(1-nu^2)) and the beam (E) bounds,
    continuous in nu (against nu = 0.499), and the full nonlinear run converges."""
    t0 = time.perf_counter()
    h, b = 0.1, 1.0
    w = {}
    for v in (nu, 0.499):
        model, tip = end_shear_model(generators.strip(L_SHEAR, b, 16, 4), thickness=h, poisson=v)
        res = load_control(model, [1e-4])
        w[v] = float(res.state.x[tip, 2] - model.body.mesh.nodes[tip, 2])
    P = 4.0 * 1e-4
    w_beam = P * L_SHEAR**3 / (3 * E_SHEAR * b * h**3 / 12) + P * L_SHEAR / (5 / 6 * E_SHEAR / (2 * (1 + nu)) * b * h)
    ratio = w[nu] / w_beam
    cont = abs(w[nu] / w[0.499] - 1)
    model, tip = end_shear_model(generators.strip(L_SHEAR, b, 16, 4), thickness=h, poisson=nu)
    res, err, _ = run_end_shear(model, tip, np.linspace(0, 1, 21)[1:])
    ok = res.converged and (1 - nu**2) * 0.99 <= ratio <= 1.01 and cont < 0.002
    return Row(f"nearly incompressible (nu = {nu}, strip 2x16x4)", "linear W / W_beam in [1 - nu^2, 1] (+-1 %), "
               "W(0.4999) / W(0.499) - 1 < 0.2 %, nonlinear run converges",
               f"W / W_beam = {ratio:.4f} (bounds {1 - nu**2:.4f}..1); continuity {100 * cont:.3f} %; "
               f"nonlinear: {_newton_figures(res)}, vs nu = 0 reference {100 * err:.2f} %", ok,
               time.perf_counter() - t0, "" if res.converged else res.message)


def case_hemisphere_thickness(ratios=(1e-3, 1e-4, 1e-5), n: int = 20) -> list[Row]:
    """The hemisphere (Sze 3.4, quarter, 2 x n x n) in the linear range at h/R = 4e-3 (the benchmark) and
    thinner: the response is bending-dominated, so u h^3 / P must stay constant as h -> 0 (no locking).
    Each thickness gets a load factor 1e-4 (h / h0)^3; the row gives u (h/h0)^3 / lambda against h/R = 4e-3."""
    rows, base = [], None
    for hr in (4e-3, *ratios):
        t0 = time.perf_counter()
        scene = build("hemisphere", thickness=10.0 * hr, n_meridian=n, n_circ=n)
        lam = 1e-4 * (hr / 4e-3) ** 3
        res = load_control(scene.model, [lam])
        u = scene.outputs[0].value(scene.model, res.state) * (hr / 4e-3) ** 3 / lam
        if base is None:
            base = u
            continue
        ratio = u / base
        ok = res.converged and abs(ratio - 1) <= 0.01
        rows.append(Row(f"hemisphere h/R = {hr:.0e} (2x{n}x{n}, linear range)", "normalised radial displacement "
                        "u (h/h0)^3 / lambda vs h/R = 4e-3 (<= 1 %)", f"ratio {ratio:.4f}; {_newton_figures(res)}",
                        ok, time.perf_counter() - t0))
    return rows


def case_snap_back() -> Row:
    """The pull-out cylinder (Sze 3.5) under arc-length: a sharp snap-back near 0.5 P_max."""
    t0 = time.perf_counter()
    s = run_scene(build("pullout_cylinder"))
    lam = np.array(s.history["load_factor"])
    back = bool(np.any(np.diff(lam) < 0))
    ok = s.result.converged and s.max_rel_error < 0.05
    return Row("arc-length through the snap-back (pull-out cylinder, 2x12x8)", "reaches P_max, error vs "
               "reference < 5 %", f"max error {100 * s.max_rel_error:.2f} %; load factor decreases on the path: "
               f"{back}; {_newton_figures(s.result)}", ok, time.perf_counter() - t0,
               "" if s.result.converged else s.result.message)


# -- dynamics: a very thin membrane spinning fast, time steps far above the explicit limit --------------------
# Annulus a = 0.5 .. b = 1 m (or a hexagon of circumradius 1 m), h = 1e-4 (h/L = 1e-4), E = 1e9, nu = 0.3,
# rho = 1000. The explicit (central-difference) limit is dt_crit = 2 / omega_max of the lumped-mass model;
# the multiples below are of the translational (membrane) limit, 2 / omega_max of M^-1/2 K M^-1/2 restricted
# to the translations (7.1e-5 s on the 2x2x16 annulus; the estimate l_min / c, c = sqrt(E / (rho (1 - nu^2))),
# gives 9.4e-5 s). With the rotary inertia rho h^3 / 12 the full model's limit is ~1000x smaller still
# (6.4e-8 s: the transverse-shear / director mode, omega^2 ~ 12 k G / (rho h^2)).
THIN = dict(inner=0.5, outer=1.0, young=1e9, nu=0.3, rho=1000.0, thickness=1e-4)


def thin_membrane(shape: str = "annulus", drive: str = "free", n_radial: int = 2, n_circ: int = 16,
                  n_rings: int = 3):
    """The thin membrane: (DynamicModel, mesh, None) free (drive = "free"), or (Model, mesh, hub nodes) with
    the inner edge (annulus) / the central ring of elements (hexagon) clamped, for a DynamicModel with the
    hub's PrescribedMotion (:func:`spin_up_motion`; it depends on omega and the ramp)."""
    from flexbody.dynamics import DynamicModel
    p = THIN
    if shape == "annulus":
        mesh = generators.annulus(p["inner"], p["outer"], n_radial, n_circ)
        hub = mesh.node_set("inner")
    elif shape == "hexagon":
        mesh = generators.regular_polygon(6, p["outer"], n_rings)
        # the innermost ring of elements (hexagon of circumradius outer / n_rings) is the hub
        k = np.arange(6)
        normals = np.stack([np.cos((2 * k + 1) * np.pi / 6), np.sin((2 * k + 1) * np.pi / 6)], axis=1)
        gauge = (mesh.nodes[:, :2] @ normals.T).max(axis=1) / (p["outer"] * math.cos(math.pi / 6))
        hub = np.flatnonzero(gauge <= 1.0 / n_rings + 1e-9)
    else:
        raise ValueError(f"shape must be 'annulus' or 'hexagon', got {shape!r}")
    body = ShellBody(mesh, ShellMaterial(p["young"], p["nu"], p["thickness"], density=p["rho"]))
    if drive == "free":
        return DynamicModel(Model(body)), mesh, None
    return Model(body, [Fix(hub, "all")]), mesh, hub


def explicit_limits(dyn) -> dict:
    """The central-difference limits 2 / omega_max of the lumped-mass model at its reference state:
    ``membrane`` (translational DoFs only), ``full`` (with the director DoFs), and the estimate
    ``estimate`` = l_min / c with l_min the smallest distance between two nodes of an element."""
    import scipy.sparse as sp
    s = dyn.model.initial_state()
    _, K = dyn.residual_and_tangent(s, np.zeros(dyn.n_dof), np.zeros(dyn.n_dof), 0.0)
    K = 0.5 * (K + K.T)
    m = sp.diags(1.0 / np.sqrt(dyn.mass_matrix().diagonal()))
    A = (m @ K @ m).toarray()
    tr = dyn.is_translation
    w_full = math.sqrt(max(np.linalg.eigvalsh(A).max(), 0.0))
    w_mem = math.sqrt(max(np.linalg.eigvalsh(A[np.ix_(tr, tr)]).max(), 0.0))
    mesh = dyn.model.body.mesh
    x = mesh.nodes[mesh.elements]                                          # (e, 6, 3)
    d = np.linalg.norm(x[:, :, None, :] - x[:, None, :, :], axis=-1)
    l_min = d[d > 0].min()
    p = THIN
    c = math.sqrt(p["young"] / (p["rho"] * (1 - p["nu"] ** 2)))
    return dict(membrane=2.0 / w_mem, full=2.0 / w_full, estimate=l_min / c, omega_membrane=w_mem,
                omega_full=w_full)


_LIMITS: dict = {}


def membrane_dt_crit(shape: str = "annulus") -> dict:
    """:func:`explicit_limits` of the free thin membrane (cached per shape)."""
    if shape not in _LIMITS:
        dyn, _, _ = thin_membrane(shape)
        _LIMITS[shape] = explicit_limits(dyn)
    return _LIMITS[shape]


def rotating_annulus_displacement(r, omega: float, inner: str = "free") -> np.ndarray:
    """Radial displacement of the plane-stress annulus THIN spinning steadily at omega (Timoshenko & Goodier):
    u = C1 r + C2 / r - k r^3, k = (1 - nu^2) rho omega^2 / (8 E); sigma_r(b) = 0 and sigma_r(a) = 0
    (``inner="free"``) or u(a) = 0 (``inner="hub"``); sigma_r = 0 reads (1 + nu) C1 - (1 - nu) C2 / r^2 =
    (3 + nu) k r^2."""
    p = THIN
    a, b, nu = p["inner"], p["outer"], p["nu"]
    k = (1 - nu**2) * p["rho"] * omega**2 / (8 * p["young"])
    rows = [[1 + nu, -(1 - nu) / b**2], [1 + nu, -(1 - nu) / a**2] if inner == "free" else [a, 1.0 / a]]
    rhs = [(3 + nu) * k * b**2, (3 + nu) * k * a**2 if inner == "free" else k * a**3]
    C1, C2 = np.linalg.solve(np.array(rows), rhs)
    r = np.asarray(r, dtype=float)
    return C1 * r + C2 / r - k * r**3


def spin_up_motion(omega: float, ramp: float):
    """t -> (Q(t), 0): a hub spun up about z from rest to omega, omega(t) = omega (1 - cos(pi t / ramp)) / 2
    during the ramp, constant after it."""
    def angle(t):
        if t < ramp:
            return omega * (t / 2 - ramp / (2 * np.pi) * np.sin(np.pi * t / ramp))
        return omega * (ramp / 2 + t - ramp)

    def motion(t):
        return so3.exp(np.array([0.0, 0.0, angle(t)])), np.zeros(3)
    return motion


def _one_thread():
    """The element kernel on one numba thread (these meshes have 54-64 elements: thread start-up would
    dominate); returns the previous count."""
    import numba
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    return n


@dataclass
class SpinRun:
    """Measured figures of one run of a spinning membrane."""

    converged: bool
    message: str
    steps: int
    iterations: int
    factorizations: int
    substeps: int
    energy_growth: float        # max over the records of (E - E0) / E0
    energy_change: float        # (E_end - E0) / E0
    momentum_drift: float       # max |L - L0| / |L0|
    spin_ratio: float           # fitted rigid spin rate at the end / omega
    z_max: float                # max |z| of the nodes at the recorded steps (out-of-plane motion)
    stretch_error: float        # hub: co-rotating outer-edge radial displacement vs the analytic one (relative)
    energy_spread: float        # hub: ptp(E) / E over the steady phase
    dt: float
    seconds: float


def spin_run(dt_multiple: float, rho_inf: float, *, drive: str = "free", shape: str = "annulus",
             omega: float = 20.0, t_end: float = 0.5, ramp: float = 0.2, tilt: float | None = None,
             max_cutbacks: int = 0, n_circ: int = 16, start: str = "stretched") -> SpinRun:
    """The thin membrane at dt = dt_multiple x the membrane's explicit limit, generalized-alpha at rho_inf.

    drive = "free": released with the rigid spin field omega about z plus an out-of-plane
    velocity tilt * omega * r cos(2 theta) (so that the nearly bendless membrane must keep its plane by its
    centrifugal tension alone; a perfectly flat start would never leave it). Energy and angular momentum are
    conserved by the exact solution. ``start = "stretched"`` (annulus): the nodes start at the steady
    stretch of the plane-stress rotating annulus (free edges), a nearly steady spin, so that a large step
    meets the long-term spin; ``start = "unstressed"``: released from the reference geometry, the start-up
    transient (the membrane must stretch within a fraction of a breathing period, ~3 ms) inside the
    first step. drive = "hub": the inner edge (annulus) or the central ring (hexagon)
    clamped and spun up from rest to omega in ``ramp``; the same out-of-plane velocity field, 10x smaller,
    is given to the free nodes at rest (tilt default 1e-3 free, 1e-4 hub: the membrane at rest has no
    tension to hold it, and a larger wobble would foreshorten the measured stretch). Checked in the steady phase: the co-rotating outer-edge stretch against the rotating
    annulus on a rigid hub (annulus only) and the energy spread.
    """
    from flexbody.dynamics import DynamicModel, PrescribedMotion
    from flexbody.energy import integrate_motion
    from integrators.generalized_alpha import AlphaSettings
    threads = _one_thread()
    try:
        t0 = time.perf_counter()
        dt = dt_multiple * membrane_dt_crit(shape)["membrane"]
        obj, mesh, hub = thin_membrane(shape, drive, n_circ=n_circ)
        if drive == "free":
            dyn = obj
        else:
            dyn = DynamicModel(obj, prescribed=[PrescribedMotion(hub, spin_up_motion(omega, ramp))])
        s = dyn.model.initial_state()
        if drive == "free" and shape == "annulus" and start == "stretched":
            R0 = np.linalg.norm(s.x[:, :2], axis=1)
            u = rotating_annulus_displacement(R0, omega, "free")
            s = s.copy()
            s.x[:, :2] *= (1.0 + u / R0)[:, None]
        elif start != "unstressed" and not (drive == "hub" and start == "stretched"):
            raise ValueError(f"start must be 'stretched' (free annulus only) or 'unstressed', got {start!r}")
        if tilt is None:
            tilt = 1e-3 if drive == "free" else 1e-4
        r = np.linalg.norm(s.x[:, :2], axis=1)
        theta = np.arctan2(s.x[:, 1], s.x[:, 0])
        spin = np.array([0.0, 0.0, omega]) if drive == "free" else np.zeros(3)
        xdot = np.cross(spin, s.x)
        xdot[:, 2] += tilt * omega * r * np.cos(2 * theta)
        v = dyn.velocity_from_nodal(s, xdot, np.tile(spin, (len(s.x), 1)))
        hist = []

        def on_step(rec, q, vel):
            hist.append((rec.time, rec.total_energy, float(np.abs(q.x[:, 2]).max())))

        run = integrate_motion(dyn, t_end, dt, state=s, velocity=v, on_step=on_step,
                               settings=AlphaSettings(rho_inf=rho_inf, max_cutbacks=max_cutbacks))
        out = run.result
        recs = [run.initial] + run.records
        E = np.array([rec.total_energy for rec in recs])
        L = np.array([rec.angular_momentum for rec in recs])
        E0 = E[0]
        z_max = max([abs(s.x[:, 2]).max()] + [z for _, _, z in hist])
        nan = float("nan")
        stretch_error = spread = nan
        spin_ratio = nan
        if drive == "free":
            growth, change = (E.max() - E0) / E0, (E[-1] - E0) / E0
            drift = float(np.abs(L - L[0]).max() / np.linalg.norm(L[0]))
            if run.records:
                spin_ratio = float(dyn.rigid_angular_velocity(out.state, out.velocity)[2] / omega)
        else:
            growth = change = drift = nan
            steady = np.array([e for t, e, _ in hist if t >= ramp + 0.5 * (t_end - ramp)])
            if out.converged and steady.size:
                spread = float(np.ptp(steady) / steady.mean())
            if out.converged and shape == "annulus":
                Q, _ = spin_up_motion(omega, ramp)(out.time)
                outer = mesh.node_set("outer")
                X = mesh.nodes[outer]
                u = np.linalg.norm((out.state.x[outer] @ Q)[:, :2], axis=1) - np.linalg.norm(X[:, :2], axis=1)
                exact = float(rotating_annulus_displacement(THIN["outer"], omega, "hub"))
                stretch_error = float(u.mean() / exact - 1.0)
        return SpinRun(out.converged, out.message, len(run.records), out.stats.iterations,
                       out.stats.factorizations, sum(rec.substeps for rec in run.records), float(growth),
                       float(change), float(drift), spin_ratio, float(z_max), stretch_error, spread, dt,
                       time.perf_counter() - t0)
    finally:
        import numba
        numba.set_num_threads(threads)


# pass criteria of the dynamic rows
ENERGY_GROWTH_MAX = 1e-3     # free spin: E(t) <= (1 + 1e-3) E0 at every step (no blow-up, no spurious energy)
ENERGY_LOSS_MAX = 5e-2       # free spin: E_end >= 0.95 E0 (numerical dissipation of the spin itself)
MOMENTUM_DRIFT_MAX = 5e-2    # free spin: |L - L0| <= 5 % |L0|
Z_MAX = 1e-2                 # out-of-plane motion stays below 1 % of the radius (it starts at ~6e-4)
STRETCH_MAX = 0.05           # hub: co-rotating outer-edge stretch within 5 % of the rotating-annulus value
SPREAD_MAX = 1e-2            # hub: energy spread in the second half of the steady spin


def spin_passed(run: SpinRun, drive: str) -> bool:
    if not run.converged or not np.isfinite(run.z_max) or run.z_max > Z_MAX:
        return False
    if drive == "free":
        return (run.energy_growth <= ENERGY_GROWTH_MAX and run.energy_change >= -ENERGY_LOSS_MAX
                and run.momentum_drift <= MOMENTUM_DRIFT_MAX)
    ok = not (run.energy_spread > SPREAD_MAX)
    return ok and not (abs(run.stretch_error) > STRETCH_MAX)


def case_spin(dt_multiple: float, rho_inf: float, drive: str = "free", shape: str = "annulus",
              omega: float = 20.0, **kw) -> Row:
    """One row: :func:`spin_run` and its pass criteria (module constants above)."""
    run = spin_run(dt_multiple, rho_inf, drive=drive, shape=shape, omega=omega, **kw)
    h_omega = run.dt * omega
    if drive == "free":
        how = "free spin, " + ("steady stretch" if kw.get("start", "stretched") == "stretched" else "released unstressed")
    else:
        how = "hub spin-up"
    cut = f", max_cutbacks = {kw['max_cutbacks']}" if kw.get("max_cutbacks") else ""
    label = (f"thin {shape} h/L = 1e-4, {how}, {omega:g} rad/s, dt = {dt_multiple:g} dt_crit ({run.dt:.2e} s, "
             f"h omega = {h_omega:.2g}), rho_inf = {rho_inf:g}{cut}")
    if drive == "free":
        checked = (f"converges; E <= (1 + {ENERGY_GROWTH_MAX:g}) E0, E_end >= {1 - ENERGY_LOSS_MAX:g} E0; "
                   f"dL/L0 <= {MOMENTUM_DRIFT_MAX:g}; z_max <= {Z_MAX:g} m")
        acc = (f"energy growth {run.energy_growth:.1e}, change {run.energy_change:+.2e}; dL/L0 "
               f"{run.momentum_drift:.2e}; spin {run.spin_ratio:.4f} omega")
    else:
        checked = (f"converges; steady-phase energy spread <= {SPREAD_MAX:g}; outer stretch vs rotating annulus "
                   f"on a hub within {100 * STRETCH_MAX:g} %; z_max <= {Z_MAX:g} m")
        acc = (f"energy spread {run.energy_spread:.1e}; stretch error {100 * run.stretch_error:+.2f} %"
               if shape == "annulus" else f"energy spread {run.energy_spread:.1e}")
    per = run.iterations / max(run.substeps, 1)
    figure = (f"{acc}; z_max {run.z_max:.1e} m; {run.steps} steps, {per:.1f} it/step, "
              f"{run.factorizations} factorizations" + (f", {run.substeps} sub-steps" if run.substeps > run.steps else ""))
    if not run.converged:
        figure = f"stopped after {run.steps} steps: {run.message[:160]}; {figure}"
    ok = spin_passed(run, drive)
    return Row(label, checked, figure, ok, run.seconds, "" if run.converged else run.message[:300])


U = dict(start="unstressed")
DYNAMIC_CASES = {
    # the sweep: released unstressed (the membrane must stretch within the first step), 0.5 s = 1.6 turns
    "spin_free": (lambda: [case_spin(m, rho, **U) for m in (10, 100) for rho in (0.0, 0.5, 0.8, 1.0)], False),
    # where the fixed step stops converging, and what cut-backs (max_cutbacks = 4) make of it
    "spin_free_limits": (lambda: [case_spin(20, 1.0, **U), case_spin(50, 1.0, **U), case_spin(300, 0.8, **U),
                                  case_spin(1000, 0.8, **U), case_spin(300, 0.0, max_cutbacks=4, **U),
                                  case_spin(300, 0.8, max_cutbacks=4, **U), case_spin(1000, 0.8, max_cutbacks=4, **U)],
                         True),
    # started in the steady stretch of the rotating annulus (no breathing)
    "spin_free_stretched": (lambda: [case_spin(10, 0.8), case_spin(100, 0.8), case_spin(100, 0.8, max_cutbacks=4)],
                            True),
    # five times faster (strain ~4e-3): 0.2 s = 3.2 turns
    "spin_fast": (lambda: [case_spin(m, rho, omega=100.0, t_end=0.2, **U) for m, rho in ((10, 0.0), (10, 0.8), (10, 1.0),
                                                                                         (100, 0.8))]
                  + [case_spin(10, 0.8, omega=100.0, t_end=0.2)], True),
    # spun up by a hub from rest in 0.2 s, held to 0.5 s
    "spin_hub": (lambda: [case_spin(m, rho, "hub") for m, rho in ((10, 0.8), (100, 0.0), (100, 0.8), (100, 1.0),
                                                                   (1000, 0.8))], False),
    # the hexagonal sail (54 elements, 6 sectors x 3^2; its dt_crit is 1.09e-4 s)
    "spin_hexagon": (lambda: [case_spin(10, 0.8, "free", "hexagon", **U), case_spin(50, 0.8, "free", "hexagon", **U),
                              case_spin(100, 0.8, "free", "hexagon", **U), case_spin(10, 0.8, "hub", "hexagon"),
                              case_spin(50, 0.8, "hub", "hexagon"), case_spin(100, 0.8, "hub", "hexagon")], True),
}


CASES = {
    "thickness": (lambda: [case_thickness(h) for h in (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)], True),
    "hemisphere_thickness": (lambda: case_hemisphere_thickness(), True),
    "rotation_4pi": (lambda: [case_rotation_4pi()], True),
    "exp_log": (lambda: [case_exp_log()], False),
    "aspect": (lambda: [case_aspect("long"), case_aspect("wide")], False),
    "skewed": (lambda: [case_skewed(0.05), case_skewed(0.2), case_skewed(0.2, 32), case_skewed(0.2, 64)], False),
    "coarse": (lambda: [case_coarse()], False),
    "one_step": (lambda: [case_one_step_shear(1e-2), case_one_step_shear(1e-4), case_one_step_moment()], True),
    "incompressible": (lambda: [case_incompressible()], False),
    "snap_back": (lambda: [case_snap_back()], True),
}


def table(rows: list[Row]) -> str:
    out = ["| case | what was checked | measured | result | time (s) |", "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r.case} | {r.checked} | {r.figure} | {'pass' if r.passed else 'FAIL'} | {r.seconds:.1f} |")
    notes = [f"- {r.case}: {r.note}" for r in rows if r.note]
    return "\n".join(out + ([""] + notes if notes else []))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help=f"cases to run (default all static ones): {', '.join(CASES)}; "
                    f"dynamic: {', '.join(DYNAMIC_CASES)}")
    ap.add_argument("--quick", action="store_true", help="skip the slow cases")
    ap.add_argument("--dynamic", action="store_true", help="run the dynamic cases (thin spinning membrane, "
                    "large time steps) instead of the static ones")
    ap.add_argument("--out", help="also write the table to this Markdown file")
    a = ap.parse_args(argv)
    every = {**CASES, **DYNAMIC_CASES}
    unknown = [c for c in a.cases if c not in every]
    if unknown:
        ap.error(f"unknown case(s) {unknown}; choose from {', '.join(every)}")
    rows = []
    if a.dynamic and not a.cases:
        lim = membrane_dt_crit("annulus")
        print(f"thin annulus (2x2x16, h = 1e-4): explicit limit dt_crit = 2 / omega_max = {lim['membrane']:.3e} s "
              f"(translations; l_min / c = {lim['estimate']:.3e} s); with the director DoFs {lim['full']:.3e} s",
              flush=True)
    for name in a.cases or (DYNAMIC_CASES if a.dynamic else CASES):
        run, slow = every[name]
        if a.quick and slow and not a.cases:
            continue
        for row in run():
            rows.append(row)
            print(f"{'pass' if row.passed else 'FAIL'}  {row.case}: {row.figure} ({row.seconds:.1f} s)", flush=True)
    text = table(rows)
    print()
    print(text)
    if a.out:
        with open(a.out, "w") as fh:
            fh.write(f"Stress cases (python benchmarks/stress.py), {platform.python_version()}, "
                     f"{platform.machine()}\n\n{text}\n")
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
