"""Sparse linear solves behind one small interface: factorize once, solve many times."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


class SingularMatrixError(RuntimeError):
    """The iteration matrix is singular: typically a free rigid-body mode (missing constraints)."""


@dataclass
class LinearSolver:
    """Sparse LU (SuperLU) with a deliberate column ordering.

    The shell tangents are structurally symmetric and (near equilibrium) nearly symmetric, so the default
    is SuperLU's symmetric mode: MMD ordering of A^T + A and diagonal pivots. Measured on the slit annular
    plate (6300 DoF): 0.031 s, against 4.6 s with the default partial pivoting, whose row exchanges
    destroy the fill-reducing ordering (24e6 instead of 1.2e6 nonzeros in L+U). If the diagonal pivots
    fail, the factorization is retried with threshold pivoting. ``factorizations`` and ``solves`` count
    the work done.
    """

    ordering: str = "MMD_AT_PLUS_A"
    factorizations: int = 0
    solves: int = 0
    _lu: object = field(default=None, repr=False)

    def factorize(self, K: sp.spmatrix) -> None:
        K = sp.csc_matrix(K)
        try:
            self._lu = spla.splu(K, permc_spec=self.ordering, diag_pivot_thresh=0.0,
                                 options=dict(SymmetricMode=True))
        except RuntimeError:
            self._lu = None
        if self._lu is not None and not np.all(np.isfinite(self._lu.U.diagonal())):
            self._lu = None
        try:
            if self._lu is None:
                self._lu = spla.splu(K, permc_spec=self.ordering, diag_pivot_thresh=0.1)
        except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
            self._lu = None
            raise SingularMatrixError(
                f"the tangent matrix is singular ({exc}); is the body free to move rigidly "
                "(missing constraints) or buckled exactly at a bifurcation?") from exc
        self.factorizations += 1

    @property
    def ready(self) -> bool:
        return self._lu is not None

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self._lu is None:
            raise RuntimeError("solve() before factorize()")
        self.solves += 1
        x = self._lu.solve(b)
        if not np.all(np.isfinite(x)):
            raise SingularMatrixError("the linear solve produced non-finite values (singular tangent)")
        return x
