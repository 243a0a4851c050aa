"""Lumped (HRZ) against consistent mass: vibration frequencies under mesh refinement (docs/dynamics.md, "Inertia").

    python benchmarks/consistent_mass.py [radial] [spin] [rotary] [bending] [--cells 4,8,16]

* ``radial``: the in-plane breathing modes of the annulus held at a hub (a = 0.2, b = 1, E = 1e9, nu = 0.3,
  rho = 1000, h = 1e-3, not spinning), n_radial x 8 n_radial cells, against the plane-stress Bessel solution
  u = C1 J1(kr) + C2 Y1(kr), u(a) = 0, u'(b) + nu u(b)/b = 0, omega = k sqrt(E / (rho (1 - nu^2))) (roots checked
  by integrating the ODE, tests/shell/test_consistent_mass.py). The axisymmetric modes come from K and M reduced
  to the fields invariant under the mesh's cyclic symmetry.
* ``spin``: the transverse modes of the same annulus in its steady spin at 20 rad/s (the issue's meshes), from the
  tangent of the relative equilibrium (centrifugal softening included; Coriolis couples them to the in-plane
  modes only, which are two orders of magnitude higher), omega / Omega with the circumferential wave number n of
  the rim motion. No closed form (bending boundary layer at the hub): the finest mesh is the reference.
* ``rotary``: the bending modes of a simply supported square plate (a = 1, 8 x 8 cells, h/a = 0.01 and 0.1)
  against Kirchhoff's omega_mn = pi^2 (m^2 + n^2) / a^2 sqrt(D / (rho h)) (Leissa, Vibration of Plates, NASA
  SP-160, 1969, 4.2), with consistent translations and the director inertia lumped (the model), consistent
  (rho h^3/12 int N_I N_J on w_1, w_2, constant on a flat plate because all frames are equal there) or
  absent (the rotations condensed out): the effect of the choice for the rotary part. The supports are "hard"
  (w = 0 and no twist along the edges: no boundary layer).

* ``bending``: the same plate (h/a = 0.01) on 4 x 4, 8 x 8 and 16 x 16 cells, lumped against consistent.

Each table prints relative errors in percent. Not run by the tests.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
import time

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spl

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from flexbody.assembly import Model  # noqa: E402
from flexbody.body import ShellBody  # noqa: E402
from flexbody.constraints import Fix  # noqa: E402
from flexbody.dynamics import DynamicModel  # noqa: E402
from flexbody.mesh import generators  # noqa: E402
from flexbody.shell.inertia import consistent_scalar_mass  # noqa: E402
from flexbody.shell.material import ShellMaterial  # noqa: E402
from flexbody.spinning import SpinningModel, steady_spin  # noqa: E402
from tests.shell.test_consistent_mass import (A_IN, B_OUT, E, NU, RHO, axisymmetric_frequencies,  # noqa: E402
                                              in_plane_annulus, radial_wavenumbers)

KINDS = ("lumped", "consistent")


def radial(cells: list[int], modes: int = 5) -> None:
    exact = radial_wavenumbers(modes) * np.sqrt(E / (RHO * (1 - NU**2)))
    print(f"\nradial (breathing) modes of the hub annulus, error in % against Bessel; exact omega [rad/s]: "
          f"{np.round(exact, 1).tolist()}")
    print("| cells | mass | " + " | ".join(f"mode {k + 1}" for k in range(modes)) + " |")
    print("|---|---|" + "---|" * modes)
    for n in cells:
        model = in_plane_annulus(n)
        for kind in KINDS:
            w, frac = axisymmetric_frequencies(DynamicModel(model, mass=kind))
            w = w[frac > 0.9][:modes]
            err = [f"{100 * (a / b - 1):+.3f}" for a, b in zip(w, exact)]
            print(f"| {n} x {8 * n} | {kind} | " + " | ".join(err + ["-"] * (modes - len(err))) + " |")


def spin_modes(n_radial: int, kind: str, count: int = 24, omega: float = 20.0):
    mesh = generators.annulus(A_IN, B_OUT, n_radial, 8 * n_radial)
    body = ShellBody(mesh, ShellMaterial(E, NU, 1e-3, density=RHO))
    dyn = DynamicModel(Model(body, [Fix(mesh.node_set("inner"), "all")]), mass=kind)
    s = steady_spin(dyn, [0.0, 0.0, omega], center=[0.0, 0.0, 0.0])
    spin = SpinningModel(dyn, [0.0, 0.0, omega], [0.0, 0.0, 0.0])
    K = (spin.residual_and_tangent(s.state, 1.0)[1] @ dyn.column_map(s.state)).tocsc()
    w2, phi = spl.eigsh(0.5 * (K + K.T), k=count, M=dyn.mass_matrix(), sigma=-1.0, which="LM")
    order = np.argsort(w2)
    w, phi = np.sqrt(np.abs(w2[order])) / omega, phi[:, order]
    rim = mesh.node_set("outer")
    theta = np.arctan2(mesh.nodes[rim, 1], mesh.nodes[rim, 0])
    index = -np.ones((mesh.n_nodes, 6), dtype=int)
    index.ravel()[dyn.model.free] = np.arange(dyn.n_dof)
    wave = [int(np.argmax([abs(np.sum(phi[index[rim, 2], j] * np.exp(-1j * k * theta))) for k in range(9)]))
            for j in range(len(w))]
    return w, wave


def spin(cells: list[int]) -> None:
    results = {}
    for n in cells:
        for kind in KINDS:
            t0 = time.perf_counter()
            results[n, kind] = spin_modes(n, kind)
            print(f"  ({n} x {8 * n}, {kind}: {time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    # one entry per (n, s): the s-th distinct frequency with wave number n
    def table(w, wave):
        out = {}
        for value, k in zip(w, wave):
            found = [key for key in out if key[0] == k]
            if not found or abs(out[max(found)] - value) > 1e-6 * value:
                out[(k, len(found))] = value
        return out
    ref_cells = max(cells)
    ref = {key: 0.5 * (table(*results[ref_cells, "lumped"])[key] + table(*results[ref_cells, "consistent"])[key])
           for key in table(*results[ref_cells, "lumped"])}
    keys = sorted(ref, key=ref.get)[:14]
    print(f"\ntransverse modes of the spinning hub annulus, omega/Omega in the turning frame; reference: the mean of "
          f"both masses on {ref_cells} x {8 * ref_cells}; (n, s) = (wave number, radial order)")
    print("| cells | mass | " + " | ".join(f"({k}, {s})" for k, s in keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    print("| reference | | " + " | ".join(f"{ref[k]:.3f}" for k in keys) + " |")
    for n in cells:
        for kind in KINDS:
            t = table(*results[n, kind])
            print(f"| {n} x {8 * n} | {kind} | " + " | ".join(f"{100 * (t[k] / ref[k] - 1):+.2f}" if k in t else "-"
                                                          for k in keys) + " |")


def plate_frequencies(thickness: float, rotary: str, cells: int = 8, count: int = 6, mass: str = "consistent"):
    """Bending frequencies of the simply supported square plate and Kirchhoff's; ``rotary`` "lumped" (the
    model's director inertia), "consistent" or "none"; ``mass`` the model's translational mass."""
    mesh = generators.strip(1.0, 1.0, cells, cells)
    body = ShellBody(mesh, ShellMaterial(E, NU, thickness, density=RHO))
    x, y = mesh.nodes[:, 0], mesh.nodes[:, 1]
    # "hard" simple support: w = 0 and no rotation about the edge's normal (r1 about t1 = e_x, r2 about e_y)
    across_x = np.flatnonzero(np.isclose(x, 0) | np.isclose(x, 1))
    across_y = np.flatnonzero(np.isclose(y, 0) | np.isclose(y, 1))
    cons = [Fix(across_x, ("z", "r1")), Fix(across_y, ("z", "r2")), Fix(np.arange(mesh.n_nodes), ("x", "y"))]
    dyn = DynamicModel(Model(body, cons), mass=mass)
    M = dyn.mass_matrix().tolil()
    rot = np.flatnonzero(~dyn.is_translation)
    if rotary == "consistent":       # rho h^3/12 int N_I N_J on each in-plane rotation (all frames equal here)
        Sr = consistent_scalar_mass(body.reference.weights, mesh.elements, mesh.n_nodes, RHO * thickness**3 / 12)
        block = Sr.toarray()[np.ix_(dyn.node[rot], dyn.node[rot])] * (dyn.comp[rot][:, None] == dyn.comp[rot][None, :])
        M = M.toarray()
        M[np.ix_(rot, rot)] = block
    else:
        M = M.toarray()
    s = dyn.model.initial_state()
    z = np.zeros(dyn.n_dof)
    K = dyn.residual_and_tangent(s, z, z, 0.0)[1].toarray()
    if rotary == "none":             # no director inertia: the rotations condensed out exactly
        tr = np.flatnonzero(dyn.is_translation)
        K = K[np.ix_(tr, tr)] - K[np.ix_(tr, rot)] @ np.linalg.solve(K[np.ix_(rot, rot)], K[np.ix_(rot, tr)])
        M = M[np.ix_(tr, tr)]
    w = np.sqrt(np.abs(scipy.linalg.eigh(0.5 * (K + K.T), M, eigvals_only=True, subset_by_index=[0, 14])))
    D = E * thickness**3 / (12 * (1 - NU**2))
    # (m, n) and (n, m) have the same frequency: the sorted list with multiplicities
    exact = np.sort([np.pi**2 * (m * m + n * n) * np.sqrt(D / (RHO * thickness)) for m in range(1, 6)
                     for n in range(1, 6)])[:len(w)]
    return w[:count], exact[:count]


def rotary(thicknesses=(0.01, 0.1)) -> None:
    print("\nbending modes of the simply supported square plate (8 x 8 cells, consistent translations): error in % "
          "against Kirchhoff (Leissa 1969), by the director inertia")
    print("| h/a | director inertia | " + " | ".join(f"mode {k + 1}" for k in range(6)) + " |")
    print("|---|---|" + "---|" * 6)
    for h in thicknesses:
        for kind in ("lumped", "consistent", "none"):
            w, exact = plate_frequencies(h, kind)
            print(f"| {h:g} | {kind} | " + " | ".join(f"{100 * (a / b - 1):+.3f}" for a, b in zip(w, exact)) + " |")


def bending(cells=(4, 8, 16), thickness: float = 0.01) -> None:
    print(f"\nbending modes of the simply supported square plate, h/a = {thickness:g}: error in % against Kirchhoff "
          "(Leissa 1969), by mesh and mass")
    print("| cells | mass | " + " | ".join(f"mode {k + 1}" for k in range(6)) + " |")
    print("|---|---|" + "---|" * 6)
    for n in cells:
        for kind in KINDS:
            w, exact = plate_frequencies(thickness, "lumped", cells=n, mass=kind)
            print(f"| {n} x {n} | {kind} | " + " | ".join(f"{100 * (a / b - 1):+.3f}" for a, b in zip(w, exact)) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("studies", nargs="*", default=["radial", "spin", "rotary", "bending"])
    parser.add_argument("--cells", default="4,8,16", help="radial cells of the annulus meshes")
    args = parser.parse_args()
    cells = [int(c) for c in args.cells.split(",")]
    for study in args.studies:
        {"radial": lambda: radial(cells), "spin": lambda: spin(cells), "rotary": rotary, "bending": bending}[study]()


if __name__ == "__main__":
    main()
