"""Stiff and extreme cases: very thin shells, rotations past 4 pi, distorted meshes, the whole load in one
step, nearly incompressible material, a sharp snap-back under arc-length.

    python benchmarks/stress.py [--quick] [--out docs/robustness_results.md] [CASE ...]

Prints one row per case: what was checked, the measured figure, pass or fail. ``--quick`` skips the slow
cases (those the test suite does not run). The fast cases also run in tests/test_stress.py, through the
functions of this file. The table and its discussion are in docs/robustness.md.
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
    ap.add_argument("cases", nargs="*", help=f"cases to run (default all): {', '.join(CASES)}")
    ap.add_argument("--quick", action="store_true", help="skip the slow cases")
    ap.add_argument("--out", help="also write the table to this Markdown file")
    a = ap.parse_args(argv)
    unknown = [c for c in a.cases if c not in CASES]
    if unknown:
        ap.error(f"unknown case(s) {unknown}; choose from {', '.join(CASES)}")
    rows = []
    for name in a.cases or CASES:
        run, slow = CASES[name]
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
