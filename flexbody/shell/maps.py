"""The assumed-strain maps and the section stiffness in the form the six-node shell kernels take them
(:mod:`flexbody.shell.kernels`), prepared once in numpy by their owners.

The assumed-strain map A (7, 8, 17, 8) is compressed (:class:`CompressedMaps`, built once per element variant:
``ElementVariant.compressed_maps`` of :mod:`flexbody.shell.variants`): rows of a Gauss point that only use that
Gauss point ("local": bending; all rows with tying off) enter the point's 18 x 18 slot matrix; the other rows
("nonlocal": membrane and shear with tying on) are factored exactly, A_nl = M E, through a minimal set of
parameters E: the independent sampled combinations at each point (e_rr, e_ss, e_rs at a membrane tying point,
e_qt on the hypotenuse, ...), then reduced to a basis of what the rows use (the element means of the "mean"
membrane tying combine samples of seven points: 9 membrane and 8 shear parameters for MITC6 with either
scheme). Their material stiffness is one symmetric rank-17 update S^T (sum_g M_g^T C_g M_g) S per element; the
rows S_k of the membrane parameters (rotation-free) are W_k x, constant 6 x 6 matrices W_k of the shape
functions times the nodal positions. Evaluation points that no row uses are skipped.

The section stiffness is checked once (:func:`checked_section`: shape, symmetry, the coupling of its strain
blocks), by the body that owns it (:class:`flexbody.body.ShellBody`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flexbody.shell.geometry import EVAL_DN, GAUSS_OFFSET, N_GAUSS
from flexbody.shell.kernels.layout import N_EVAL


def _row_basis(M: np.ndarray, tol: float) -> np.ndarray:
    """Reduced row-echelon basis of the row space of M (sparse rows with unit pivots)."""
    M = M.copy()
    rows, cols = M.shape
    basis, r = [], 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(M[r:, c])))
        if abs(M[piv, c]) <= tol:
            continue
        M[[r, piv]] = M[[piv, r]]
        M[r] /= M[r, c]
        for k in range(rows):
            if k != r:
                M[k] -= M[k, c] * M[r]
        r += 1
    basis = M[:r]
    basis[np.abs(basis) <= tol] = 0.0
    return basis


class CompressedMaps:
    """Sparse form of an assumed-strain map A (7, 8, 17, 8) for the kernels (see the module docstring).

    * all nonzeros (g, i, p, j, v), by rows (g, i) and by columns (p, j): strains and the pull-back of the
      stress resultants;
    * local rows of each Gauss point (entries referring only to the point itself): in the point's slots;
    * nonlocal rows: A_nl = M E with parameters E = L E1: E1 the row-echelon bases of the sampled components
      used at each point (e.g. e_qq = (e_rr + e_ss)/2 - e_rs at a hypotenuse tying point), L the row-echelon
      basis of the combinations of them that the rows use (fewer when rows share combinations of several
      points, as the element means of the "mean" tying do; L = I otherwise), M the sparse combination per
      Gauss point row. Rotation-free parameters (membrane only) come first and get their rows as W_k x.
      The factorizations are verified to round-off.
    """

    def __init__(self, A: np.ndarray) -> None:
        A = np.asarray(A, dtype=np.float64)
        if A.shape != (N_GAUSS, 8, N_EVAL, 8):
            raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
        if not np.all(np.isfinite(A)):
            raise ValueError("A must be finite")
        g, i, p, j = np.nonzero(A)
        v = A[g, i, p, j]
        # A by rows (g, i) and by columns (p, j), each in the order of the other index (sums as in the reference)
        self.a_ptr = np.searchsorted(8 * g + i, np.arange(8 * N_GAUSS + 1)).astype(np.int64)
        self.a_p, self.a_j, self.a_v = p.astype(np.int64), j.astype(np.int64), v.astype(np.float64)
        by_col = np.argsort(8 * p + j, kind="stable")
        self.at_ptr = np.searchsorted((8 * p + j)[by_col], np.arange(8 * N_EVAL + 1)).astype(np.int64)
        self.at_g, self.at_i = g[by_col].astype(np.int64), i[by_col].astype(np.int64)
        self.at_v = v[by_col].astype(np.float64)
        self.used = np.unique(p).astype(np.int64)
        own = GAUSS_OFFSET + np.arange(N_GAUSS)
        # a row of Gauss point g is local when all its entries refer to g's own evaluation point
        has = np.zeros((N_GAUSS, 8), bool)
        other = np.zeros((N_GAUSS, 8), bool)
        has[g, i] = True
        far = p != own[g]
        other[g[far], i[far]] = True
        local = has & ~other
        nonlocal_ = has & other
        self.loc_rows = np.zeros((N_GAUSS, 8), np.int64)
        self.nl_rows = np.zeros((N_GAUSS, 8), np.int64)
        self.n_loc = local.sum(axis=1).astype(np.int64)
        self.n_nl = nonlocal_.sum(axis=1).astype(np.int64)
        loc_index = -np.ones((N_GAUSS, 8), np.int64)
        nl_index = -np.ones((N_GAUSS, 8), np.int64)
        for gg in range(N_GAUSS):
            rows = np.flatnonzero(local[gg])
            self.loc_rows[gg, :len(rows)] = rows
            loc_index[gg, rows] = np.arange(len(rows))
            rows = np.flatnonzero(nonlocal_[gg])
            self.nl_rows[gg, :len(rows)] = rows
            nl_index[gg, rows] = np.arange(len(rows))
        is_loc = local[g, i]
        order = np.argsort(g[is_loc], kind="stable")
        self.loc_i = loc_index[g, i][is_loc][order]
        self.loc_j = j[is_loc][order].astype(np.int64)
        self.loc_v = v[is_loc][order]
        self.loc_ptr = np.searchsorted(g[is_loc][order], np.arange(N_GAUSS + 1)).astype(np.int64)
        self.pt_gauss = -np.ones(N_EVAL, np.int64)
        for gg in range(N_GAUSS):
            if self.n_loc[gg] > 0:
                self.pt_gauss[own[gg]] = gg
        self._factor_nonlocal(A, nonlocal_, nl_index)

    def _factor_nonlocal(self, A, nonlocal_, nl_index) -> None:
        # dense A_nl: rows (g, nonlocal row), columns (point, component)
        row_of = [(gg, int(r)) for gg in range(N_GAUSS) for r in np.flatnonzero(nonlocal_[gg])]
        A_nl = np.array([A[gg, r].ravel() for gg, r in row_of]).reshape(len(row_of), N_EVAL * 8)
        scale = np.abs(A_nl).max() if A_nl.size else 1.0
        tol = 1e-12 * scale
        # point parameters E1: row-echelon bases of the sampled components used at each point
        E_rows, pt_of = [], []
        for pp in range(N_EVAL):
            sub = A_nl[:, 8 * pp:8 * pp + 8] if A_nl.size else np.zeros((0, 8))
            if not np.any(np.abs(sub) > tol):
                continue
            for row in _row_basis(sub, tol):
                full = np.zeros(N_EVAL * 8)
                full[8 * pp:8 * pp + 8] = row
                E_rows.append(full)
                pt_of.append(pp)
        E1 = np.array(E_rows).reshape(len(E_rows), N_EVAL * 8)
        pt_of = np.array(pt_of, np.int64)
        # rotation-free (membrane) point parameters first
        rf1 = np.array([bool(np.all(np.flatnonzero(row) % 8 < 3)) for row in E1], bool)
        order = np.argsort(~rf1, kind="stable")
        E1, rf1, pt_of = E1[order], rf1[order], pt_of[order]
        if len(E1):
            M1 = np.linalg.lstsq(E1.T, A_nl.T, rcond=None)[0].T      # A_nl = M1 E1
            M1[np.abs(M1) <= 1e-14 * np.abs(M1).max()] = 0.0
            if np.abs(M1 @ E1 - A_nl).max() > 1e-13 * scale:
                raise ValueError("could not factor the nonlocal assumed-strain rows")
            # parameters E = L E1 of minimal number: L the row-echelon basis of the row space of M1
            # (e.g. the element means of the "mean" membrane tying combine sampled strains of several points)
            L = _row_basis(M1, 1e-12 * max(np.abs(M1).max(), 1.0))
            rf = ~np.any(L[:, ~rf1] != 0.0, axis=1)                  # parameters of rotation-free rows only
            order = np.argsort(~rf, kind="stable")
            L, rf = L[order], rf[order]
            E = L @ E1
            M = np.linalg.lstsq(E.T, A_nl.T, rcond=None)[0].T        # A_nl = M E
            M[np.abs(M) <= 1e-14 * np.abs(M).max()] = 0.0
            if len(L) == len(E1) or np.abs(M @ E - A_nl).max() > 1e-13 * scale:
                L, rf, M = np.eye(len(E1)), rf1.copy(), M1           # no reduction (or an ill-conditioned one)
        else:
            L = np.zeros((0, 0))
            rf = np.zeros(0, bool)
            M = np.zeros((len(row_of), 0))
        npar = len(L)
        self.n_rf = int(rf.sum())
        # rotation-free parts: S_k[x_I] = sum_J W_k[I, J] x_J, from the membrane gradients at the points
        # (delta e_rr = x_,r . delta x_,r, delta e_ss = x_,s . delta x_,s,
        #  2 delta e_rs = x_,r . delta x_,s + x_,s . delta x_,r)
        self.w2 = np.zeros((max(npar, 1), 6, 6))
        for k in range(npar):
            for kp in np.flatnonzero(rf1):
                lv = L[k, kp]
                if lv == 0.0:
                    continue
                pp = pt_of[kp]
                dr, ds = EVAL_DN[pp]
                row = E1[kp, 8 * pp:8 * pp + 3]
                self.w2[k] += lv * (row[0] * np.outer(dr, dr) + row[1] * np.outer(ds, ds)
                                    + 0.5 * row[2] * (np.outer(dr, ds) + np.outer(ds, dr)))
        self.has_w = np.any(self.w2[:npar] != 0.0, axis=(1, 2)).astype(np.int64)
        # point parameters with rotations: their sampled components and weights in the parameters
        nr1 = np.flatnonzero(~rf1)
        self.par_p = pt_of[nr1].astype(np.int64)
        ptr, pj, pv = [0], [], []
        lptr, lk, lv = [0], [], []
        for kp in nr1:
            (nzc,) = np.nonzero(E1[kp])
            pj.extend(int(c) % 8 for c in nzc)
            pv.extend(E1[kp, nzc])
            ptr.append(len(pj))
            for k in np.flatnonzero(L[:, kp]):
                lk.append(int(k))
                lv.append(L[k, kp])
            lptr.append(len(lk))
        self.par_ptr = np.array(ptr, np.int64)
        self.par_j = np.array(pj, np.int64)
        self.par_v = np.array(pv, np.float64)
        self.pl_ptr = np.array(lptr, np.int64)
        self.pl_k = np.array(lk, np.int64)
        self.pl_v = np.array(lv, np.float64)
        self.npar = npar
        mg, mi, mk, mv = [], [], [], []
        for r, (gg, row) in enumerate(row_of):
            for k in np.flatnonzero(M[r]):
                mg.append(gg)
                mi.append(nl_index[gg, row])
                mk.append(int(k))
                mv.append(M[r, k])
        mg = np.array(mg, np.int64)
        self.m_ptr = np.searchsorted(mg, np.arange(N_GAUSS + 1)).astype(np.int64)
        self.m_i = np.array(mi, np.int64)
        self.m_k = np.array(mk, np.int64)
        self.m_v = np.array(mv, np.float64)
        self.m_dense = np.zeros((N_GAUSS, 8, max(npar, 1)))        # M_g by nonlocal row, dense in the parameters
        self.m_dense[mg, self.m_i, self.m_k] = self.m_v

    @property
    def n_parameters(self) -> int:
        return self.npar

    def nonzeros(self):
        return self.used, self.a_ptr, self.a_p, self.a_j, self.a_v, self.at_ptr, self.at_g, self.at_i, self.at_v

    def kernel_args(self):
        return (self.used, self.a_ptr, self.a_p, self.a_j, self.a_v, self.at_ptr, self.at_g, self.at_i, self.at_v,
                self.pt_gauss, self.loc_rows, self.n_loc, self.loc_ptr, self.loc_i, self.loc_j, self.loc_v,
                self.par_p, self.par_ptr, self.par_j, self.par_v, self.pl_ptr, self.pl_k, self.pl_v,
                self.w2, self.has_w, self.n_rf, self.nl_rows, self.n_nl, self.m_ptr, self.m_i, self.m_k, self.m_v,
                self.m_dense)


def compress_maps(A: np.ndarray | CompressedMaps) -> CompressedMaps:
    """The compressed form of an assumed-strain map A (7, 8, 17, 8), built anew (an element variant builds
    its own once, ``ElementVariant.compressed_maps``); a compressed map is returned as it is."""
    if isinstance(A, CompressedMaps):
        return A
    return CompressedMaps(A)


_BLOCK0 = np.array([0, 3, 6, 8], np.int64)   # strain blocks: membrane, bending, shear


def _section_blocks(C: np.ndarray) -> np.ndarray:
    """(3, 3) flags: does the section couple strain blocks a and b (membrane, bending, shear)?"""
    return np.array([[np.any(C[_BLOCK0[a]:_BLOCK0[a + 1], _BLOCK0[b]:_BLOCK0[b + 1]] != 0.0) for b in range(3)]
                     for a in range(3)], np.int64)


class SectionStiffness(NamedTuple):
    """A checked section stiffness (:func:`checked_section`), as the kernels take it."""

    matrix: np.ndarray    # (8, 8) symmetric, contiguous float64 (a copy: a caller's edits do not reach it)
    blocks: np.ndarray    # (3, 3) int64 coupling flags of the strain blocks (membrane, bending, shear)


def checked_section(section: np.ndarray | SectionStiffness) -> SectionStiffness:
    """The section stiffness (8, 8) checked (shape, symmetry) as a contiguous float64 copy, with its
    block coupling flags. A :class:`SectionStiffness` is returned as it is: its owner checks it once."""
    if isinstance(section, SectionStiffness):
        return section
    C = np.array(section, dtype=np.float64, order="C")
    if C.shape != (8, 8):
        raise ValueError(f"section must be (8, 8), got {C.shape}")
    if not np.allclose(C, C.T, rtol=0.0, atol=1e-13 * np.abs(C).max()):
        raise ValueError("section stiffness must be symmetric")
    return SectionStiffness(C, _section_blocks(C))
