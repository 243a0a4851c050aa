"""The data layout of the six-node shell kernels: evaluation points, the point slots xi and the element
coordinates z.

* evaluation points: the tying points of the assumed strains, then the Gauss points (N_EVAL = 17 for MITC6);
  ``_EN`` (17, 6) and ``_EDN`` (17, 2, 6) the shape functions and their derivatives there;
* slots of the point coordinates xi = [dx_,r, dx_,s, dtheta_0, dd, dd_,r, dd_,s] (3 components each):
  ``_U0, _U1, _V0, _V, _W0, _W1``; ``_PI8`` (17, 6, 8) the map Pi from z to the slots at each point;
* z = [dx_I, dtheta_0, dd_1..dd_5] stored component-major and padded to 8 lanes: dx_I[c] at 8c + I,
  (dtheta_0, dd_I)[c] at ``_ZR`` + 8c + I (NZ = 48 in all);
* the tangent in z is accumulated on a pattern: the translation rows of component c from column 8c (the upper
  block triangle of the symmetric part), the rotation rows in the rotation columns from ``_KR``; the rest is
  overwritten by the mirror in :func:`flexbody.shell.kernels.congruence._finish_tangent`.
"""

from __future__ import annotations

import numpy as np

from flexbody.shell.geometry import EVAL_DN, EVAL_N, N_GAUSS
from flexbody.shell.mitc6 import N_TYING

N_EVAL = N_TYING + N_GAUSS
NDOF = 36

_EN = np.ascontiguousarray(EVAL_N, dtype=np.float64)     # (17, 6)
_EDN = np.ascontiguousarray(EVAL_DN, dtype=np.float64)   # (17, 2, 6)


# slots of the point coordinates xi (3 components each)
_U0, _U1, _V0, _V, _W0, _W1 = 0, 1, 2, 3, 4, 5

# z is stored component-major and padded to 8 lanes: dx_I[c] at 8c + I, (dtheta_0, dd_I)[c] at 24 + 8c + I
NZ = 48
_ZR = 24
# The tangent in z is accumulated on a pattern: the translation rows of component c from column 8c (the upper
# block triangle of the symmetric part), the rotation rows in the rotation columns from _KR; the rest is
# overwritten by the mirror in _finish_tangent.
_KR = 24


def _slot_weights() -> np.ndarray:
    """Pi per point as 8-lane rows: (17, 6 slots, 8); translation slots U0, U1 act on dx, the others on rotations."""
    w = np.zeros((N_EVAL, 6, 8))
    w[:, _U0, :6] = EVAL_DN[:, 0]
    w[:, _U1, :6] = EVAL_DN[:, 1]
    w[:, _V0, 0] = 1.0
    w[:, _V, 1:6] = EVAL_N[:, 1:]
    w[:, _W0, 1:6] = EVAL_DN[:, 0, 1:]
    w[:, _W1, 1:6] = EVAL_DN[:, 1, 1:]
    return w


_PI8 = _slot_weights()
