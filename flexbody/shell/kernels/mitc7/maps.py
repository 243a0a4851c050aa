"""The MITC7 kernels' form of an assumed-strain map A (7, 8, 17, 8): its nonzeros by Gauss point and the
evaluation points it uses (computed in Python, once per map)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from flexbody.shell.geometry import N_GAUSS
from flexbody.shell.kernels.mitc7.points import N_EVAL


class MapNonzeros(NamedTuple):
    """The nonzeros of an assumed-strain map A (7, 8, 17, 8) by Gauss point, and the evaluation points used."""

    ptr: np.ndarray     # (8,) start of each Gauss point's entries
    i: np.ndarray       # row component
    p: np.ndarray       # evaluation point
    j: np.ndarray       # column component
    value: np.ndarray   # A[g, i, p, j]
    used: np.ndarray    # (17,) bool: the evaluation points the map uses


def map_nonzeros(A: np.ndarray) -> MapNonzeros:
    """The kernel's form of an assumed-strain map A (7, 8, 17, 8) (computed; :func:`as_map_nonzeros` caches)."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    if A.shape != (N_GAUSS, 8, N_EVAL, 8):
        raise ValueError(f"A must have shape {(N_GAUSS, 8, N_EVAL, 8)}, got {A.shape}")
    g, i, p, j = np.nonzero(A)                   # row-major: sorted by g
    ptr = np.searchsorted(g, np.arange(N_GAUSS + 1)).astype(np.int64)
    used = np.zeros(N_EVAL, dtype=np.bool_)
    used[p] = True
    return MapNonzeros(ptr, i.astype(np.int64), p.astype(np.int64), j.astype(np.int64),
                       np.ascontiguousarray(A[g, i, p, j]), used)


_MAP_CACHE: dict[bytes, MapNonzeros] = {}


def as_map_nonzeros(A: np.ndarray | MapNonzeros) -> MapNonzeros:
    """:func:`map_nonzeros`, cached on the contents of A; a MapNonzeros is returned as it is."""
    if isinstance(A, MapNonzeros):
        return A
    A = np.ascontiguousarray(A, dtype=np.float64)
    key = A.tobytes()
    out = _MAP_CACHE.get(key)
    if out is None:
        out = map_nonzeros(A)
        if len(_MAP_CACHE) > 8:
            _MAP_CACHE.clear()
        _MAP_CACHE[key] = out
    return out
