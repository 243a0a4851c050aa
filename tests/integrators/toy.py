"""Small analytic models with the interfaces the integrators use (integrators.protocols), and an observer
that keeps the output steps of a dynamic run."""

import numpy as np
import scipy.sparse as sp


class _OneDof:
    """What the one-DoF models share: a dead load, additive update, the increment as its own conjugate."""

    dof_scale = 1.0

    def initial_state(self):
        return np.zeros(1)

    def external_force(self, q):
        return np.array([self.load])

    def update(self, q, dq):
        return q + dq

    def conjugate(self, q, dq):
        return dq


class CubicSpring(_OneDof):
    """One DoF, f_int(w) = k (w - 1.5 w^2 + 0.5 w^3): limit points at w = 1 -+ 1/sqrt 3 (snap-through)."""

    def __init__(self, load=0.3, k=1.0, fail_above=None):
        self.load, self.k, self.fail_above = load, k, fail_above

    def f_int(self, w):
        return self.k * (w - 1.5 * w**2 + 0.5 * w**3)

    def residual(self, q, lam):
        if self.fail_above is not None and q[0] > self.fail_above:
            raise FloatingPointError("non-finite state (forced by the test model)")
        return np.array([self.f_int(q[0]) - lam * self.load])

    def residual_and_tangent(self, q, lam):
        w = q[0]
        return self.residual(q, lam), sp.csc_matrix([[self.k * (1 - 3 * w + 1.5 * w * w)]])


class HardeningSpring(_OneDof):
    """One DoF, f_int(w) = w + w^3 (stiffening: a secant extrapolation overshoots). Any evaluation above
    ``fail_above`` raises as a non-finite element would; ``failures`` counts them."""

    def __init__(self, load=1.0, fail_above=None):
        self.load, self.fail_above, self.failures = load, fail_above, 0

    def f_int(self, w):
        return w + w**3

    def residual(self, q, lam):
        if self.fail_above is not None and q[0] > self.fail_above:
            self.failures += 1
            raise FloatingPointError("non-finite state (forced by the test model)")
        return np.array([self.f_int(q[0]) - lam * self.load])

    def residual_and_tangent(self, q, lam):
        return self.residual(q, lam), sp.csc_matrix([[1.0 + 3.0 * q[0] ** 2]])


class Oscillator:
    """M x'' + K x = 0 on R^n, M = I, K = diag(omega^2): exactly the members of
    integrators.protocols.DynamicProblem with a diagonal mass (the group is R^n: q o exp(d) = q + d)."""

    def __init__(self, omegas):
        self.omegas = np.asarray(omegas, float)
        self.mass = np.ones(len(self.omegas))
        self.dof_scale = 1.0
        self.n_dof = len(self.omegas)

    def residual(self, q, v, vdot, t):
        return self.mass * vdot + self.omegas**2 * q

    def residual_and_tangent(self, q, v, vdot, t):
        return self.residual(q, v, vdot, t), sp.diags(self.omegas**2).tocsc()

    def update(self, q, dq):
        return q + dq

    def initial_acceleration(self, q, t=0.0, v=None):
        return -self.omegas**2 * q / self.mass


class OutputSteps:
    """A step observer keeping the output steps (integrators.protocols.AcceptedStep) of a run, and calling
    ``then(step)`` with each if given."""

    def __init__(self, then=None):
        self.steps, self.then = [], then

    def __call__(self, step):
        if step.output:
            self.steps.append(step)
            if self.then is not None:
                self.then(step)


class LaggingIterationMatrix(Oscillator):
    """The oscillator M x'' + K x = 0 whose ``residual_and_tangent`` returns, instead of K, a tangent whose
    iteration matrix S_B = M beta' + K_B is off by a cross-coupling of its two DoFs: the modified-Newton error
    map e -> (I - S_B^-1 S) e is G = [[0, a], [b, 0]] (S = M beta' + K the exact one, for the step h and rho_inf).

    With a >> b the corrections alternate between contracting by about b and by about a: a single ratio of two
    corrections exceeds a refresh ratio below a while the iteration converges at sqrt(a b) per iteration, as the
    kept iteration matrix of a thin shell does (translation errors that the directors follow one iteration later;
    integrators/generalized_alpha.py, "Transient ratios of a kept matrix"). The residual is exact: the fixed point
    is the oscillator's. A fresh matrix is no better than a kept one: the coupling is in every tangent.
    """

    def __init__(self, omegas, h, rho_inf, a, b):
        from integrators.generalized_alpha import AlphaParameters
        super().__init__(omegas)
        self.beta_prime = AlphaParameters.from_rho_inf(rho_inf).beta_prime(h)
        S = np.diag(self.mass * self.beta_prime + self.omegas**2)
        G = np.array([[0.0, a], [b, 0.0]])
        self.tangent = S @ np.linalg.inv(np.eye(2) - G) - np.diag(self.mass * self.beta_prime)

    def residual_and_tangent(self, q, v, vdot, t):
        return self.residual(q, v, vdot, t), sp.csc_matrix(self.tangent)
