"""MITC6 assumed covariant strains (Lee & Bathe 2004; paper Sec. 5, Eqs. 27-28).

Every assumed field is linear in the covariant strains sampled at the tying points, so it is stored as a
linear map: ``assumed(r, s) = M(r, s) @ sampled`` with the samples taken at ``TYING_POINTS``.

Covariant components on the reference triangle (r, s); q runs along the hypotenuse, direction (-1, 1)/sqrt 2:
    e_qq = (e_rr - 2 e_rs + e_ss) / 2,    e_rs = (e_rr + e_ss)/2 - e_qq       (paper Eq. 27)
    e_qt = (e_st - e_rt) / sqrt 2
Membrane: each of e_rr, e_ss, e_qq is a linear field tied at the two Gauss stations of its edge plus one
interior condition (see the schemes below).
Transverse shear, MITC6a (8 parameters, a rotated Raviart-Thomas field):
    e_rt = a1 + b1 r + c1 s + s (d r + e s),   e_st = a2 + b2 r + c2 s - r (d r + e s).

Two membrane schemes (``MEMBRANE_SCHEMES``; docs/locking.md has the measurements):

* ``"mean"`` (default): each linear field passes through its two edge stations, and its element mean (its
  value at the centroid) equals the element mean of the displacement-based strain (``MEAN_RULE``, exact for
  the quadratic strains of a curved quadratic element in the linear range). Edge stations plus one interior
  moment instead of an interior point value: the moment form of the tying. It removes most of the
  membrane locking of curved elements (thin hemisphere) and is identical to ``"point"`` on flat elements
  in the linear range (there the strains are linear and both reproduce them exactly).
* ``"point"``: the third value is a point value at the interior tying point (r1, 1/sqrt 3) etc. (the reading
  of Lee & Bathe 2004 in /work/shared/reference/README.md). Locks for thin curved shells.

The membrane maps refer to all evaluation points of the element (tying points, then the Gauss points of
:func:`flexbody.shell.shape.gauss_triangle_7`, the layout of ``flexbody.shell.geometry.EVAL_POINTS``).
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.shape import gauss_triangle_7

R1 = 0.5 - 0.5 / np.sqrt(3.0)  # edge Gauss stations (paper Eq. 28)
R2 = 0.5 + 0.5 / np.sqrt(3.0)
C3 = 1.0 / np.sqrt(3.0)

#: The distinct tying points, (r, s). Indices below refer to rows of this array.
TYING_POINTS = np.array(
    [
        (R1, 0.0), (R2, 0.0), (R1, C3),      # 0-2: e_rr (the interior point: "point" scheme only)
        (0.0, R1), (0.0, R2), (C3, R1),      # 3-5: e_ss
        (R2, R1), (R1, R2), (R1, R1),        # 6-8: e_qq (hypotenuse x2, interior)
        (1.0 / 3.0, 1.0 / 3.0),              # 9: centroid (shear)
    ]
)
N_TYING = len(TYING_POINTS)

_GAUSS_POINTS, _GAUSS_WEIGHTS = gauss_triangle_7()
#: Evaluation points: the tying points, then the Gauss points (their indices are N_TYING + g).
N_EVAL = N_TYING + len(_GAUSS_POINTS)
#: Element mean of a sampled field: 1/12 at each of the six edge stations, 1/2 at the centroid. Exact for
#: quadratics (the membrane strains of a curved quadratic element in the linear range), positive, and it
#: only uses points that the shear tying samples anyway (cheaper in the kernel than the 7 Gauss points,
#: which give the same results to four digits on the benchmarks).
MEAN_RULE = {0: 1 / 12, 1: 1 / 12, 3: 1 / 12, 4: 1 / 12, 6: 1 / 12, 7: 1 / 12, 9: 1 / 2}

#: Membrane tying schemes; the first is the default.
MEMBRANE_SCHEMES = ("mean", "point")
DEFAULT_SCHEME = MEMBRANE_SCHEMES[0]

_RR_POINTS = (0, 1, 2)
_SS_POINTS = (3, 4, 5)
_QQ_POINTS = (6, 7, 8)


def _linear_basis(points: np.ndarray, r: float, s: float) -> np.ndarray:
    """Weights of the linear field through three points, evaluated at (r, s)."""
    vander = np.column_stack([np.ones(3), points[:, 0], points[:, 1]])
    return np.linalg.solve(vander.T, np.array([1.0, r, s]))


def _edge_mean_weights(edge: tuple[int, int], r: float, s: float) -> np.ndarray:
    """Weights [v1, v2, mean] of the linear field with values v1, v2 at two edge stations and mean ``mean``."""
    rows = [[1.0, *TYING_POINTS[k]] for k in edge] + [[1.0, 1.0 / 3.0, 1.0 / 3.0]]  # mean = centroid value
    return np.linalg.solve(np.array(rows).T, np.array([1.0, r, s]))


def membrane_map(r: float, s: float, scheme: str = DEFAULT_SCHEME) -> np.ndarray:
    """Assumed membrane strains [e_rr, e_ss, e_rs] at (r, s) from the samples.

    Returns
    -------
    M : (3, N_EVAL, 3) array with assumed[i] = sum_kj M[i, k, j] sampled[k, j], where
        sampled[k] = [e_rr, e_ss, e_rs] computed at evaluation point k (tying points, then Gauss points).
    """
    if scheme not in MEMBRANE_SCHEMES:
        raise ValueError(f"membrane scheme must be one of {MEMBRANE_SCHEMES}, got {scheme!r}")
    m = np.zeros((3, N_EVAL, 3))
    qq_of_sample = np.array([0.5, 0.5, -1.0])  # e_qq = (e_rr + e_ss)/2 - e_rs
    if scheme == "point":
        w_rr = _linear_basis(TYING_POINTS[list(_RR_POINTS)], r, s)
        w_ss = _linear_basis(TYING_POINTS[list(_SS_POINTS)], r, s)
        w_qq = _linear_basis(TYING_POINTS[list(_QQ_POINTS)], r, s)
        for w, k in zip(w_rr, _RR_POINTS):
            m[0, k, 0] += w
        for w, k in zip(w_ss, _SS_POINTS):
            m[1, k, 1] += w
        qq = np.zeros((N_EVAL, 3))
        for w, k in zip(w_qq, _QQ_POINTS):
            qq[k] += w * qq_of_sample
    else:
        fields = []
        for edge, sample in ((_RR_POINTS[:2], np.eye(3)[0]), (_SS_POINTS[:2], np.eye(3)[1]),
                             (_QQ_POINTS[:2], qq_of_sample)):
            w = _edge_mean_weights(edge, r, s)
            f = np.zeros((N_EVAL, 3))
            f[list(edge)] += w[:2, None] * sample
            for k, wk in MEAN_RULE.items():
                f[k] += w[2] * wk * sample
            fields.append(f)
        m[0], m[1], qq = fields
    # e_rs = (e_rr + e_ss)/2 - e_qq, all three assumed fields evaluated at (r, s)
    m[2] = 0.5 * (m[0] + m[1]) - qq
    return m


def _shear_rows(r: float, s: float) -> np.ndarray:
    """Rows of the MITC6a field: [e_rt; e_st] = rows @ (a1, b1, c1, a2, b2, c2, d, e)."""
    return np.array(
        [
            [1, r, s, 0, 0, 0, s * r, s * s],
            [0, 0, 0, 1, r, s, -r * r, -r * s],
        ],
        dtype=float,
    )


def _shear_tying_system() -> tuple[np.ndarray, np.ndarray]:
    """The 8x8 tying matrix A and the selection S (8 x N_TYING*2) of sampled shear strains."""
    rows, select = [], []
    isq2 = 1.0 / np.sqrt(2.0)

    def pick(k: int, comp: int) -> np.ndarray:
        v = np.zeros((N_TYING, 2))
        v[k, comp] = 1.0
        return v.ravel()

    for k in (0, 1):  # e_rt on the edge s = 0
        rows.append(_shear_rows(*TYING_POINTS[k])[0])
        select.append(pick(k, 0))
    for k in (3, 4):  # e_st on the edge r = 0
        rows.append(_shear_rows(*TYING_POINTS[k])[1])
        select.append(pick(k, 1))
    for k in (6, 7):  # e_qt on the hypotenuse
        f = _shear_rows(*TYING_POINTS[k])
        rows.append(isq2 * (f[1] - f[0]))
        select.append(isq2 * (pick(k, 1) - pick(k, 0)))
    for comp in (0, 1):  # e_rt and e_st at the centroid
        rows.append(_shear_rows(*TYING_POINTS[9])[comp])
        select.append(pick(9, comp))
    return np.array(rows), np.array(select)


_SHEAR_A, _SHEAR_S = _shear_tying_system()


def _shear_tying_system_mitc7() -> tuple[np.ndarray, np.ndarray]:
    """MITC7 (Brezzi, Bathe & Fortin 1989): the six edge conditions of MITC6a, and the element means of
    e_rt and e_st (the 7-point rule, over all N_EVAL points) instead of their centroid values: the canonical
    degrees of freedom of the rotated Raviart-Thomas space. S selects over N_EVAL points."""
    A, S = _shear_tying_system()
    S = np.concatenate([S.reshape(8, N_TYING, 2), np.zeros((8, len(_GAUSS_POINTS), 2))], axis=1)
    S[6:] = 0.0
    w = 2.0 * _GAUSS_WEIGHTS                                   # the mean: weights summing to 1
    for comp in (0, 1):
        A[6 + comp] = sum(wg * _shear_rows(r, s)[comp] for (r, s), wg in zip(_GAUSS_POINTS, w))
        S[6 + comp, N_TYING:, comp] = w
    return A, S.reshape(8, -1)


def shear_map_mitc7(r: float, s: float) -> np.ndarray:
    """MITC7 assumed transverse shear [e_rt, e_st] at (r, s): M (2, N_EVAL, 2), samples at all evaluation
    points (tying points, then Gauss points)."""
    A, S = _shear_tying_system_mitc7()
    return (_shear_rows(r, s) @ np.linalg.solve(A, S)).reshape(2, N_EVAL, 2)


def shear_map(r: float, s: float) -> np.ndarray:
    """Assumed transverse shear strains [e_rt, e_st] at (r, s) from the samples.

    Returns
    -------
    M : (2, N_TYING, 2) array with assumed[i] = sum_kj M[i, k, j] sampled[k, j], where
        sampled[k] = [e_rt, e_st] computed at TYING_POINTS[k].
    """
    coeffs = np.linalg.solve(_SHEAR_A, _SHEAR_S)  # (8, N_TYING*2)
    return (_shear_rows(r, s) @ coeffs).reshape(2, N_TYING, 2)
