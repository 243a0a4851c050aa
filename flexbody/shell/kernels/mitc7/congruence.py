"""The congruence stage of the MITC7 element: the tangent in relative coordinates z to the nodal motions h,
K_h = P^T K_z P (paper Eq. 31: dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0; the bubble
amplitudes are not mapped)."""

from __future__ import annotations

from flexbody import _numba
from flexbody.shell.kernels.mitc7.points import NAUG, NDOF

fast = _numba.fast


@fast
def congruence(Kz, KP, fr, Ti, Tm, Ka):
    """Ka = P^T Kz P: dx_I = R_I du_I, dd_I = T^-1(d_I) dtheta_I - T^-1(-d_I) dtheta_0."""
    for r in range(NAUG):                            # KP = K_z P (rows z, cols h)
        for i in range(6):
            for l in range(3):
                KP[r, 6 * i + l] = (Kz[r, 3 * i] * fr[i, 0, l] + Kz[r, 3 * i + 1] * fr[i, 1, l]
                                    + Kz[r, 3 * i + 2] * fr[i, 2, l])
        for l in range(3):
            acc = Kz[r, 18 + l]
            for i in range(1, 6):
                z0 = 18 + 3 * i
                acc -= Kz[r, z0] * Tm[i, 0, l] + Kz[r, z0 + 1] * Tm[i, 1, l] + Kz[r, z0 + 2] * Tm[i, 2, l]
            KP[r, 3 + l] = acc
        for i in range(1, 6):
            z0 = 18 + 3 * i
            for l in range(3):
                KP[r, 6 * i + 3 + l] = (Kz[r, z0] * Ti[i, 0, l] + Kz[r, z0 + 1] * Ti[i, 1, l]
                                        + Kz[r, z0 + 2] * Ti[i, 2, l])
        KP[r, NDOF] = Kz[r, NDOF]
        KP[r, NDOF + 1] = Kz[r, NDOF + 1]
    for i in range(6):                               # Ka = P^T KP
        for l in range(3):
            for c in range(NAUG):
                Ka[6 * i + l, c] = (fr[i, 0, l] * KP[3 * i, c] + fr[i, 1, l] * KP[3 * i + 1, c]
                                    + fr[i, 2, l] * KP[3 * i + 2, c])
    for l in range(3):
        for c in range(NAUG):
            Ka[3 + l, c] = KP[18 + l, c]
    for i in range(1, 6):
        z0 = 18 + 3 * i
        for l in range(3):
            tm0, tm1, tm2 = Tm[i, 0, l], Tm[i, 1, l], Tm[i, 2, l]
            ti0, ti1, ti2 = Ti[i, 0, l], Ti[i, 1, l], Ti[i, 2, l]
            for c in range(NAUG):
                k0, k1, k2 = KP[z0, c], KP[z0 + 1, c], KP[z0 + 2, c]
                Ka[3 + l, c] -= tm0 * k0 + tm1 * k1 + tm2 * k2
                Ka[6 * i + 3 + l, c] = ti0 * k0 + ti1 * k1 + ti2 * k2
    for c in range(NAUG):
        Ka[NDOF, c] = KP[NDOF, c]
        Ka[NDOF + 1, c] = KP[NDOF + 1, c]
