"""Independent references for the modal analysis of spinning membranes (tests/test_modal.py, benchmarks/modal.py).

* :func:`lamb_southwell`: the closed form of Lamb & Southwell (1921) for the transverse vibration of a spinning
  membrane disk with a free rim (derivation in docs/modal.md).
* :func:`radial_membrane_frequencies`: the transverse frequencies of a spinning annular (or full) membrane by a
  1-D radial finite-element eigenproblem with the plane-stress rotating-disk pre-stress (Timoshenko & Goodier,
  Theory of Elasticity, 3rd ed., section 32), solved with scipy; no code of flexbody is used.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def lamb_southwell(n: int, s: int, nu: float) -> float:
    """omega / Omega of the membrane disk mode with n nodal diameters and s nodal circles (co-rotating frame):
    omega^2 / Omega^2 = ((3 + nu) m (m + 2) - (1 + 3 nu) n^2) / 8, m = n + 2 s."""
    m = n + 2 * s
    return float(np.sqrt(((3 + nu) * m * (m + 2) - (1 + 3 * nu) * n * n) / 8.0))


def rotating_disk_stress(r, omega, a, b, E, nu, rho, inner: str):
    """Plane-stress radial and hoop stresses (sigma_r, sigma_theta) of a disk a <= r <= b spinning at omega.

    u = C1 r + C2 / r - k r^3, k = (1 - nu^2) rho omega^2 / (8 E); ``inner`` "hub": u(a) = 0, "free":
    sigma_r(a) = 0, "disk" (a = 0): C2 = 0; sigma_r(b) = 0 in all cases."""
    k = (1 - nu * nu) * rho * omega * omega / (8 * E)
    c = E / (1 - nu * nu)

    def sig(r, C1, C2):
        er = C1 - C2 / r ** 2 - 3 * k * r ** 2
        et = C1 + C2 / r ** 2 - k * r ** 2
        return c * (er + nu * et), c * (et + nu * er)

    # sigma_r = c ((1 + nu) C1 - (1 - nu) C2 / r^2 - (3 + nu) k r^2)
    rows = [[(1 + nu), -(1 - nu) / b ** 2]]
    rhs = [(3 + nu) * k * b ** 2]
    if inner == "hub":
        rows.append([a, 1 / a]), rhs.append(k * a ** 3)
    elif inner == "free":
        rows.append([(1 + nu), -(1 - nu) / a ** 2]), rhs.append((3 + nu) * k * a ** 2)
    elif inner == "disk":
        rows.append([0.0, 1.0]), rhs.append(0.0)
    else:
        raise ValueError(inner)
    C1, C2 = np.linalg.solve(np.array(rows), np.array(rhs))
    return sig(np.asarray(r, dtype=float), C1, C2)


def radial_membrane_frequencies(n: int, count: int, omega, a, b, E, nu, rho, inner: str,
                                elements: int = 2000) -> np.ndarray:
    """The ``count`` lowest transverse frequencies (rad/s, co-rotating frame) with n nodal diameters.

    Weak form of rho h w_tt = (1/r)(r N_r w_r)_r - n^2 N_theta w / r^2 (h cancels: N = h sigma):
    K = int (sigma_r w_i' w_j' + n^2 sigma_theta w_i w_j / r^2) r dr, M = int rho w_i w_j r dr, on
    ``elements`` quadratic elements graded towards the inner edge; w(a) = 0 on a hub (and w(0) = 0 for n > 0
    on a full disk), the rim free."""
    a0 = 0.0 if inner == "disk" else a
    t = np.linspace(0.0, 1.0, elements + 1)
    nodes = a0 + (b - a0) * t ** 1.5 if inner != "free" else a0 + (b - a0) * t
    g, wg = np.polynomial.legendre.leggauss(4)
    size = 2 * elements + 1
    rows, cols, kv, mv = [], [], [], []
    for e in range(elements):
        r0, r1 = nodes[e], nodes[e + 1]
        L = r1 - r0
        xi = 0.5 * (g + 1)
        r = r0 + L * xi
        N = np.stack([2 * (xi - 0.5) * (xi - 1), -4 * xi * (xi - 1), 2 * xi * (xi - 0.5)])
        dN = np.stack([4 * xi - 3, -8 * xi + 4, 4 * xi - 1]) / L
        sr, st = rotating_disk_stress(r, omega, a, b, E, nu, rho, inner)
        w = 0.5 * wg * L * r
        Ke = np.einsum("q,iq,jq->ij", w * sr, dN, dN) + n * n * np.einsum("q,iq,jq->ij", w * st / r ** 2, N, N)
        Me = np.einsum("q,iq,jq->ij", w * rho, N, N)
        idx = np.array([2 * e, 2 * e + 1, 2 * e + 2])
        rows.append(np.repeat(idx, 3)), cols.append(np.tile(idx, 3)), kv.append(Ke.ravel()), mv.append(Me.ravel())
    K = sp.csc_matrix((np.concatenate(kv), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))
    M = sp.csc_matrix((np.concatenate(mv), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))
    keep = np.ones(size, dtype=bool)
    if inner == "hub" or (inner == "disk" and n > 0):
        keep[0] = False
    K, M = K[keep][:, keep], M[keep][:, keep]
    lam = spla.eigsh(K, k=count, M=M, sigma=-1e-3 * omega ** 2, which="LM")[0]
    return np.sqrt(np.abs(np.sort(lam)))
