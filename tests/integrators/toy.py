"""Small analytic models with the interface the static integrators use."""

import numpy as np
import scipy.sparse as sp


class CubicSpring:
    """One DoF, f_int(w) = k (w - 1.5 w^2 + 0.5 w^3): limit points at w = 1 -+ 1/sqrt 3 (snap-through)."""

    def __init__(self, load=0.3, k=1.0, fail_above=None):
        self.load, self.k, self.fail_above = load, k, fail_above
        self.dof_scale = 1.0

    def f_int(self, w):
        return self.k * (w - 1.5 * w**2 + 0.5 * w**3)

    def initial_state(self):
        return np.zeros(1)

    def residual(self, q, lam):
        if self.fail_above is not None and q[0] > self.fail_above:
            raise FloatingPointError("non-finite state (forced by the test model)")
        return np.array([self.f_int(q[0]) - lam * self.load])

    def residual_and_tangent(self, q, lam):
        w = q[0]
        return self.residual(q, lam), sp.csc_matrix([[self.k * (1 - 3 * w + 1.5 * w * w)]])

    def external_force(self, q):
        return np.array([self.load])

    def update(self, q, dq):
        return q + dq

    def conjugate(self, q, dq):
        return dq
