"""Refinement of the kicked spinning annulus: transverse frequencies per nodal diameter, modal and transient.

    python benchmarks/spinning_frequencies.py modal [--cells 4,8,16] [--thickness 1e-3] [--shift 400] [--json F]
    python benchmarks/spinning_frequencies.py run --cells 4 --thickness 1e-3 --revolutions 20 --save FILE.npz
    python benchmarks/spinning_frequencies.py table modal.json modal32.json [--json merged.json]
    python benchmarks/spinning_frequencies.py synthetic
    python benchmarks/spinning_frequencies.py analyse FILE.npz [FILE.npz ...] --reference reference.json

The hub annulus of ``benchmarks/spinning_membranes.py`` (a = 0.2, b = 1, E = 1e9, nu = 0.3, rho = 1000, clamped
to a hub turning at Omega = 20 rad/s, n_radial x 8 n_radial cells), the same scene text.

* ``modal``: the transverse frequencies (n, 0), n = 0..3, and (0, 1) in the turning frame from
  ``flexbody.modal`` about the steady spin of that scene's model (the hub turning: its Coriolis and centrifugal
  terms), per mesh; a Richardson extrapolation of the three finest meshes gives the converged value; the 1-D
  membrane reference (``tests/membrane_reference.py``, hub u(a) = 0) beside it. ``--json`` keeps the table.
  ``--shift 400`` (Omega^2) at h/R 1e-6: the default shift of ``flexbody.modal`` grows like 1/h^2 there.
* ``table``: the tables of several ``modal --json`` files as one, with the extrapolation; ``synthetic``: the
  decomposition and the fit on a synthetic ring of known frequencies.
* ``run``: the kicked scene (v_z = 0.05 (r - a)/(b - a) sum_{n<4} cos n theta) at default settings, 100 steps per
  revolution; every step the transverse displacement w of every rim node (a material node: it turns with the
  membrane, and w is along the spin axis, so its history is the turning frame's) and the CPU time so far, saved
  to ``--save`` (NPZ) every 10 steps, so that a run stopped early keeps what it did.
* ``analyse``: per nodal diameter n the ring's Fourier component w_n(t) = (1/N) sum_rim w cos(n theta) (n = 0..3;
  the kick has cos terms only), then its frequencies by a least-squares fit of a sum of sinusoids started
  on the peaks of its spectrum (:func:`fit_frequencies`); for the first R revolutions of each record (the CPU
  time up to there), the error of the (n, 0) frequency against the modal reference: error against run time.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
from scipy.optimize import least_squares

from spinning_membranes import ANNULUS, HUB, OMEGA, _scene   # this script's folder is first on sys.path

A = 0.2
PERIOD = 2 * math.pi / OMEGA
N_MAX = 4                      # the kick excites n = 0..3
KICK = 0.05                    # the kick of benchmarks/spinning_membranes.py, m/s at the rim
SHORT_PERIODS = 8.0            # a record of fewer periods of the mode: the fit starts on the modal (n, 0), (n, 1)


def scene_text(n_radial: int, h: float, revolutions: float, amplitude: float = KICK) -> str:
    """The hub annulus of ``benchmarks/spinning_membranes.py`` with n_radial x 8 n_radial cells; ``amplitude``:
    the kick's rim velocity (m/s) per harmonic."""
    text = (ANNULUS.format(name="hub", a=A, nr=n_radial, nc=8 * n_radial, h=h, dt=PERIOD / 100,
                           end=revolutions * PERIOD, omega=OMEGA, mass="lumped")
            + HUB.format(a=A, omega=OMEGA)).replace("output_every = 10", "output_every = 1")
    assert f"amplitude = {KICK}" in text
    return text.replace(f"amplitude = {KICK}", f"amplitude = {amplitude!r}")


# ------------------------------------------------------------------------------------------------ the ring
def ring_components(w: np.ndarray, theta: np.ndarray, n_max: int = N_MAX) -> np.ndarray:
    """The Fourier components of a ring's deflection: ``w`` (samples, nodes) at the nodes' angles ``theta``;
    returns (samples, n_max) with column n = (1/N) sum_j w_j cos(n theta_j) (equally spaced nodes: the cos n
    theta pattern of the ring, separated exactly from every other harmonic below N/2)."""
    return np.stack([(w * np.cos(n * theta)[None, :]).mean(axis=1) for n in range(n_max)], axis=1)


def spectrum_peaks(t: np.ndarray, c: np.ndarray, count: int, pad: int = 16) -> list[float]:
    """The ``count`` largest local maxima (rad/s) of the Hann-windowed, zero-padded amplitude spectrum of
    c - mean(c), each refined by a parabola through the log amplitudes of the bin and its neighbours."""
    dt = float(t[1] - t[0])
    n = pad * len(c)
    spec = np.log(np.abs(np.fft.rfft((c - c.mean()) * np.hanning(len(c)), n)) + 1e-300)
    df = 2 * math.pi / (n * dt)
    k = np.flatnonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
    k = k[np.argsort(spec[k])[::-1]][:count]
    peaks = []
    for i in k:
        a, b, cc = spec[i - 1:i + 2]
        peaks.append(df * (i + 0.5 * (a - cc) / (a - 2 * b + cc)))
    return sorted(peaks)


def _basis(t, omegas, decays):
    cols = [np.ones_like(t), t - t.mean()]
    for w, d in zip(omegas, decays):
        e = np.exp(-d * (t - t[0]))
        cols += [e * np.cos(w * t), e * np.sin(w * t)]
    return np.stack(cols, axis=1)


def fit_frequencies(t: np.ndarray, c: np.ndarray, guesses: list[float],
                    damped: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares fit of c(t) = c0 + c1 t + sum_k e^{-d_k t} (a_k cos w_k t + b_k sin w_k t) (variable
    projection: the amplitudes by linear least squares, the w_k and d_k by ``scipy.optimize.least_squares``),
    started on ``guesses`` with d = 0; ``damped`` False holds d = 0 (fewer unknowns: the one-revolution
    records hold about one period of the lowest mode, where a decay and a frequency trade off). Returns the frequencies w_k (sorted), their amplitudes
    sqrt(a_k^2 + b_k^2) at t[0] and the RMS residual relative to the RMS of c - mean(c)."""
    m = len(guesses)
    scale = float(np.std(c)) or 1.0
    c = (c - c.mean()) / scale           # O(1) residuals: the solver's tolerances are absolute in places

    def params(p):
        return p[:m], (p[m:] if damped else np.zeros(m))

    def residual(p):
        B = _basis(t, *params(p))
        coef, *_ = np.linalg.lstsq(B, c, rcond=None)
        return B @ coef - c

    p0 = np.concatenate([guesses, np.zeros(m)]) if damped else np.asarray(guesses, float)
    sol = least_squares(residual, p0, x_scale=np.concatenate([np.full(m, 1.0), np.full(m, 0.1)])[:p0.size])
    w = sol.x[:m]
    B = _basis(t, *params(sol.x))
    coef, *_ = np.linalg.lstsq(B, c, rcond=None)
    amp = scale * np.hypot(coef[2::2], coef[3::2])
    order = np.argsort(w)
    rel = float(np.sqrt(np.mean(sol.fun ** 2)))
    return np.abs(w[order]), amp[order], rel


def mode_frequency(t: np.ndarray, c: np.ndarray, near: float, count: int = 3,
                   seeds: list[float] | None = None) -> tuple[float, float, float]:
    """The frequency of ``c`` nearest to ``near`` (rad/s; the same mesh's modal (n, 0)): the fit of
    :func:`fit_frequencies` started on the ``count`` largest spectral peaks and, where given, on ``seeds`` (a
    record of a few periods, whose spectral peaks merge), the fit with the smaller residual. Returns (fitted, FFT peak nearest to ``near``, fit's relative residual)."""
    peaks = spectrum_peaks(t, c, count)
    fft_peak = min(peaks, key=lambda p: abs(p - near)) if peaks else float("nan")
    fits = [fit_frequencies(t, c, start) for start in ([peaks, list(seeds)] if seeds else [peaks])]
    w, amp, rel = min(fits, key=lambda f: f[2])
    return float(w[np.argmin(np.abs(w - near))]), float(fft_peak), rel


# ------------------------------------------------------------------------------------------------ runs
def run(n_radial: int, h: float, revolutions: float, save: str, amplitude: float = KICK) -> None:
    """The kicked annulus at default settings; the rim ring's w and the CPU time at every step into ``save``."""
    from flexbody.scenes.scene import run_scene
    scene = _scene(scene_text(n_radial, h, revolutions, amplitude))
    mesh = scene.model.body.mesh
    rim = mesh.node_set("outer")
    theta = np.arctan2(mesh.nodes[rim, 1], mesh.nodes[rim, 0])
    times, w, cpu = [], [], []
    t0 = time.process_time()
    meta = dict(n_radial=n_radial, h=h, revolutions=revolutions, amplitude=amplitude, n_dof=scene.model.n_dof, theta=theta)

    def dump(status: str) -> None:
        np.savez(save, time=np.array(times), w=np.array(w), cpu=np.array(cpu), status=status, **meta)

    def on_step(rec, state, history):
        times.append(rec.time)
        w.append(state.x[rim, 2].copy())
        cpu.append(time.process_time() - t0)
        if len(times) % 10 == 0:
            dump("running")

    try:
        summary = run_scene(scene, on_step=on_step)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        dump(f"failed: {exc}")
        raise
    res = summary.result
    steps = max(1, len(times) - 1)
    meta.update(iterations_per_step=res.stats.iterations / steps,
                factorizations_per_step=res.stats.factorizations / steps,
                compile_time_s=float(getattr(summary, "compile_time_s", 0.0)))
    dump("completed" if res.converged else f"stopped: {res.message}")
    print(f"{n_radial}x{8 * n_radial} h/R {h:g}: {'completed' if res.converged else res.message}, {steps} steps, "
          f"{meta['iterations_per_step']:.2f} iterations / {meta['factorizations_per_step']:.3f} factorizations "
          f"per step, {cpu[-1]:.1f} s CPU (compile {meta['compile_time_s']:.1f} s)", flush=True)


# ------------------------------------------------------------------------------------------------ modal
def modal_frequencies(n_radial: int, h: float, shift: float | None = None) -> tuple[dict, int, float, float]:
    """The (n, s) transverse frequencies (rad/s, turning frame) of the hub annulus' scene model about its steady
    spin. Returns ({(n, s): omega}, DoFs, set-up CPU s (steady spin, tangents), eigen-solution CPU s)."""
    from flexbody.dynamics import DynamicModel
    from flexbody.modal import describe_modes, modal_problem_in_spin, solve_modes
    scene = _scene(scene_text(n_radial, h, 1.0))
    dyn = DynamicModel(scene.model)
    t0 = time.process_time()
    problem = modal_problem_in_spin(dyn, [0.0, 0.0, OMEGA], [0.0, 0.0, 0.0])
    t1 = time.process_time()
    from flexbody.modal import default_shift
    print(f"  {n_radial}x{8 * n_radial} h/R {h:g}: default shift {default_shift(problem):.3g} (rad/s)^2, used "
          f"{shift if shift is not None else default_shift(problem):.3g}", flush=True)
    modes = solve_modes(problem, 14, shift=shift)
    t2 = time.process_time()
    found = {}
    for r in describe_modes(modes):
        if r.nodal_diameters is not None:
            found.setdefault((r.nodal_diameters, r.nodal_circles), r.frequency_rad_s)
    return found, dyn.n_dof, t1 - t0, t2 - t1


def richardson(f1: float, f2: float, f3: float) -> tuple[float, float]:
    """The limit and observed order p of f1, f2, f3 on meshes h, h/2, h/4: p = log2((f1 - f2)/(f2 - f3)),
    f = f3 + (f3 - f2)/(2^p - 1). NaN order where the differences do not have one sign."""
    d1, d2 = f1 - f2, f2 - f3
    if d1 * d2 <= 0:
        return float("nan"), float("nan")
    p = math.log2(d1 / d2)
    return f3 - d2 / (2 ** p - 1), p


def modal_study(cells: list[int], thickness: list[float], out: str | None, shift: float | None = None) -> None:
    from tests.membrane_reference import radial_membrane_frequencies
    keys = [(n, 0) for n in range(N_MAX)] + [(0, 1)]
    ref = {n: radial_membrane_frequencies(n, 2, OMEGA, A, 1.0, 1e9, 0.3, 1000.0, "hub", 400) for n in range(N_MAX)}
    membrane = {(n, s): float(ref[n][s]) for n in range(N_MAX) for s in range(2)}
    result = {"membrane": {f"{n},{s}": v for (n, s), v in membrane.items()}, "meshes": {}}
    for h in thickness:
        rows = {}
        for nr in cells:
            found, ndof, setup, eig = modal_frequencies(nr, h, shift)
            rows[nr] = found
            result["meshes"][f"{nr},{h:g}"] = {"dofs": ndof, "setup_cpu_s": setup, "eig_cpu_s": eig,
                                               "freq": {f"{n},{s}": v for (n, s), v in found.items()}}
            print(f"h/R {h:g} {nr}x{8 * nr}: {ndof} DoFs, set-up {setup:.1f} s, eig {eig:.1f} s: "
                  + ", ".join(f"{k}: {found.get(k, float('nan')):.4f}" for k in keys), flush=True)
    extrapolate(result, keys)
    if out:
        with open(out, "w") as f:
            json.dump(result, f, indent=1)
    print_modal_table(result, keys)


def extrapolate(result: dict, keys) -> None:
    """Add to ``result["meshes"]`` the Richardson limit (:func:`richardson`) of the three finest meshes per h."""
    meshes = result["meshes"]
    for label in [k for k in meshes if k.startswith("extrapolated,")]:
        del meshes[label]
    by_h = {}
    for label in meshes:
        nr, h = label.split(",")
        by_h.setdefault(h, []).append(int(nr))
    for h, cells in by_h.items():
        if len(cells) < 3:
            continue
        c1, c2, c3 = sorted(cells)[-3:]
        rows = [meshes[f"{c},{h}"]["freq"] for c in (c1, c2, c3)]
        ext = {f"{n},{s}": richardson(*(r.get(f"{n},{s}", np.nan) for r in rows)) for n, s in keys}
        meshes[f"extrapolated,{h}"] = {"from": [c1, c2, c3], "freq": {k: v[0] for k, v in ext.items()},
                                       "order": {k: v[1] for k, v in ext.items()}}


def merge_tables(files: list[str], out: str | None) -> None:
    """The tables of several ``modal --json`` files as one (e.g. a finer mesh run on its own)."""
    keys = [(n, 0) for n in range(N_MAX)] + [(0, 1)]
    result = {"membrane": {}, "meshes": {}}
    for name in files:
        part = json.load(open(name))
        result["membrane"].update(part["membrane"])
        result["meshes"].update({k: v for k, v in part["meshes"].items() if not k.startswith("extrapolated")})
    order = sorted(result["meshes"], key=lambda k: (-float(k.split(",")[1]), int(k.split(",")[0])))
    result["meshes"] = {k: result["meshes"][k] for k in order}
    extrapolate(result, keys)
    if out:
        with open(out, "w") as f:
            json.dump(result, f, indent=1)
    print_modal_table(result, keys)


def print_modal_table(result: dict, keys) -> None:
    names = " | ".join(f"({n},{s})" for n, s in keys)
    print(f"\n| h/R | mesh | DoFs | {names} | max error vs extrapolated | set-up CPU s | eig CPU s |")
    print("|---|---|---|" + "---|" * len(keys) + "---|---|---|")
    meshes = result["meshes"]
    for label, row in meshes.items():
        what, h = label.split(",")
        ext = meshes.get(f"extrapolated,{h}", {}).get("freq", {})
        vals = [row["freq"].get(f"{n},{s}", float("nan")) for n, s in keys]
        if what == "extrapolated":
            orders = " ".join(f"{row['order'][f'{n},{s}']:.2f}" for n, s in keys)
            src = "/".join(str(c) for c in row["from"])
            print(f"| {h} | Richardson of {src} (orders {orders}) | | " + " | ".join(f"{v:.4f}" for v in vals) + " | | | |")
            continue
        errs = [abs(v / ext[f"{n},{s}"] - 1) for v, (n, s) in zip(vals, keys) if f"{n},{s}" in ext]
        err = f"{max(errs):.2e}" if errs else "-"
        print(f"| {h} | {what}x{8 * int(what)} | {row['dofs']} | " + " | ".join(f"{v:.4f}" for v in vals)
              + f" | {err} | {row['setup_cpu_s']:.1f} | {row['eig_cpu_s']:.1f} |")
    mem = result["membrane"]
    print("| membrane (1-D, 400 elements) | | | " + " | ".join(f"{mem[f'{n},{s}']:.4f}" for n, s in keys)
          + " | | | |")


# ------------------------------------------------------------------------------------------------ analysis
def analyse(files: list[str], reference: str | None, windows: list[float]) -> None:
    modal = json.load(open(reference)) if reference else None
    print("| mesh | h/R | revolutions (steps) | CPU s | status | "
          + " | ".join(f"n = {n}: fit (FFT peak) rad/s" for n in range(N_MAX))
          + " | " + " | ".join(f"error n = {n} (vs same mesh)" for n in range(N_MAX)) + " | fit residual |")
    print("|---|---|---|---|---|" + "---|" * (2 * N_MAX + 1))
    for name in files:
        d = np.load(name, allow_pickle=False)
        t, w, cpu, theta = d["time"], d["w"], d["cpu"], d["theta"]
        nr, h = int(d["n_radial"]), float(d["h"])
        comps = ring_components(w, theta)
        ref = None
        if modal:
            key = f"extrapolated,{h:g}"
            ref = modal["meshes"].get(key, {}).get("freq")
        # the modal (n, 0) of this mesh seeds the choice of the peak; the error is against the converged value
        own = modal["meshes"].get(f"{nr},{h:g}", {}).get("freq") if modal else None
        total = (t[-1] - t[0]) / PERIOD
        for rev in [r for r in windows if r <= total + 1e-9] or [total]:
            k = int(round(rev * 100)) + 1
            tt, cc = t[:k], comps[:k]
            fits, errs, resid = [], [], 0.0
            for n in range(N_MAX):
                near = own[f"{n},0"] if own else 20.0 + 6.5 * n
                short = (tt[-1] - tt[0]) * near / (2 * math.pi) < SHORT_PERIODS
                seeds = [own[f"{n},0"], own[f"{n},1"]] if short and own and f"{n},1" in own else None
                f, peak, rel = mode_frequency(tt, cc[:, n], near, seeds=seeds)
                resid = max(resid, rel)
                fits.append(f"{f:.3f} ({peak:.2f})")
                e_ref = f"{f / ref[f'{n},0'] - 1:+.2e}" if ref else "-"
                e_own = f"{f / own[f'{n},0'] - 1:+.1e}" if own else "-"
                errs.append(f"{e_ref} ({e_own})")
            kick = f", kick {float(d['amplitude']):g}" if "amplitude" in d and float(d["amplitude"]) != KICK else ""
            print(f"| {nr}x{8 * nr}{kick} | {h:g} | {rev:g} ({k - 1}) | {cpu[k - 1]:.1f} | {str(d['status'])[:30]} | "
                  + " | ".join(fits) + " | " + " | ".join(errs) + f" | {resid:.1e} |", flush=True)


def synthetic_check(revolutions=(1, 2, 5, 20)) -> None:
    """The ring decomposition and the fit on a synthetic ring of 64 nodes with known content: per n = 0..3 a
    (n, 0) wave of amplitude 1e-3 and an (n, 1) wave of 3e-4 (frequencies near the 4 x 32 mesh's), plus an n = 5
    wave of 5e-4 at 25 rad/s that the decomposition must reject and white noise of 1e-4 on every node, sampled at 100 per revolution; the fit started
    on the spectral peaks and, for short records, on seeds 2 % off the true (n, 0), (n, 1). Prints the relative
    error of the (n, 0) frequency."""
    theta = np.arange(64) * 2 * np.pi / 64
    f0 = [18.7, 22.46, 30.45, 39.31]
    f1 = [54.1, 60.0, 70.0, 80.0]
    print("| revolutions | " + " | ".join(f"n = {n} error" for n in range(N_MAX)) + " |")
    print("|---|" + "---|" * N_MAX)
    for rev in revolutions:
        t = np.arange(int(rev * 100) + 1) * PERIOD / 100
        w = sum(np.cos(n * theta)[None, :] * (1e-3 * np.sin(f0[n] * t + 0.3 * n)[:, None]
                                              + 3e-4 * np.sin(f1[n] * t + 1)[:, None]) for n in range(N_MAX))
        w = w + 5e-4 * np.cos(5 * theta)[None, :] * np.sin(25.0 * t)[:, None]
        w = w + 1e-4 * np.random.default_rng(1).standard_normal(w.shape)
        comps = ring_components(w, theta)
        errs = []
        for n in range(N_MAX):
            short = (t[-1] - t[0]) * f0[n] / (2 * math.pi) < SHORT_PERIODS
            seeds = [1.02 * f0[n], 0.98 * f1[n]] if short else None
            errs.append(mode_frequency(t, comps[:, n], f0[n], seeds=seeds)[0] / f0[n] - 1)
        print(f"| {rev} | " + " | ".join(f"{e:+.1e}" for e in errs) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    m = sub.add_parser("modal")
    m.add_argument("--cells", default="4,8,16")
    m.add_argument("--thickness", default="1e-3,1e-6")
    m.add_argument("--json", default=None)
    m.add_argument("--shift", type=float, default=None,
                   help="the eigen-solver's shift in (rad/s)^2 (default: flexbody.modal's)")
    r = sub.add_parser("run")
    r.add_argument("--cells", type=int, default=4)
    r.add_argument("--thickness", type=float, default=1e-3)
    r.add_argument("--revolutions", type=float, default=20.0)
    r.add_argument("--save", required=True)
    r.add_argument("--amplitude", type=float, default=KICK, help="the kick, m/s at the rim per harmonic")
    sub.add_parser("synthetic", help="the decomposition and fit on a synthetic ring of known frequencies")
    t = sub.add_parser("table")
    t.add_argument("files", nargs="+", help="JSON files of `modal --json`")
    t.add_argument("--json", default=None, help="the merged table")
    a = sub.add_parser("analyse")
    a.add_argument("files", nargs="+")
    a.add_argument("--reference", required=True, help="the JSON of `modal --json` or `table --json` (the modal "
                   "(n, 0) of each record's mesh picks its mode; the extrapolated value is the converged one)")
    a.add_argument("--windows", default="1,2,5,10,20,40", help="revolutions from the start analysed per record")
    args = parser.parse_args()
    if args.what == "modal":
        modal_study([int(c) for c in args.cells.split(",")], [float(v) for v in args.thickness.split(",")],
                    args.json, args.shift)
    elif args.what == "run":
        if args.cells < 1 or args.revolutions <= 0 or args.thickness <= 0 or args.amplitude <= 0:
            raise SystemExit(f"bad run: cells {args.cells}, revolutions {args.revolutions}, h {args.thickness}, "
                             f"amplitude {args.amplitude}")
        run(args.cells, args.thickness, args.revolutions, args.save, args.amplitude)
    elif args.what == "synthetic":
        synthetic_check()
    elif args.what == "table":
        merge_tables(args.files, args.json)
    else:
        analyse(args.files, args.reference, [float(v) for v in args.windows.split(",")])


if __name__ == "__main__":
    main()
