"""The expansion stage of the MITC7 element: a point's operators in the 18 slots
xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] = Pi_p z expanded into the 38 relative coordinates z (Pi_p
holds only the scalars N_I, dN_I and, for the bubble amplitudes, N_b, dN_b)."""

from __future__ import annotations

from flexbody import _numba
from flexbody.shell.kernels.mitc7.points import NAUG, NDOF

fast = _numba.fast


@fast
def expand_cols(Kx, nrow, p, EN, EDN, ENB, EDNB, Y):
    """Y[:nrow] (nrow, 38) = Kx[:nrow] (nrow, 18) Pi_p."""
    nb, nbr, nbs = ENB[p], EDNB[p, 0], EDNB[p, 1]
    for r in range(nrow):
        for i in range(6):
            wr = EDN[p, 0, i]
            ws = EDN[p, 1, i]
            for k in range(3):
                Y[r, 3 * i + k] = wr * Kx[r, k] + ws * Kx[r, 3 + k]
        for k in range(3):
            Y[r, 18 + k] = Kx[r, 6 + k]
        for i in range(1, 6):
            wn = EN[p, i]
            wr = EDN[p, 0, i]
            ws = EDN[p, 1, i]
            for k in range(3):
                Y[r, 18 + 3 * i + k] = wn * Kx[r, 9 + k] + wr * Kx[r, 12 + k] + ws * Kx[r, 15 + k]
        for q in range(2):
            Y[r, NDOF + q] = nb * Kx[r, 9 + q] + nbr * Kx[r, 12 + q] + nbs * Kx[r, 15 + q]


@fast
def expand_rows_add(Y, p, EN, EDN, ENB, EDNB, Kz):
    """Kz (38, 38) += Pi_p^T Y (Y: 18 x 38)."""
    nb, nbr, nbs = ENB[p], EDNB[p, 0], EDNB[p, 1]
    for i in range(6):
        wr = EDN[p, 0, i]
        ws = EDN[p, 1, i]
        for k in range(3):
            for c in range(NAUG):
                Kz[3 * i + k, c] += wr * Y[k, c] + ws * Y[3 + k, c]
    for k in range(3):
        for c in range(NAUG):
            Kz[18 + k, c] += Y[6 + k, c]
    for i in range(1, 6):
        wn = EN[p, i]
        wr = EDN[p, 0, i]
        ws = EDN[p, 1, i]
        for k in range(3):
            for c in range(NAUG):
                Kz[18 + 3 * i + k, c] += wn * Y[9 + k, c] + wr * Y[12 + k, c] + ws * Y[15 + k, c]
    for q in range(2):
        for c in range(NAUG):
            Kz[NDOF + q, c] += nb * Y[9 + q, c] + nbr * Y[12 + q, c] + nbs * Y[15 + q, c]
