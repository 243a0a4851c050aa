"""Linear buckling: the critical load factors and modes of a model's load pattern.

About the unloaded reference state q0 the reference load f (the model's loads at load factor 1) gives the
linear pre-buckling displacements u0 = K_0^-1 f and their Gauss-point stress resultants
sigma_0 = C B(q0) u0. Along the linear pre-buckling path q(lam) ~ q0 + lam u0 the tangent is
K_0 + lam K_G with K_G = K_G(sigma_0) the geometric stiffness of these stresses (with the load stiffness of
follower loads); the buckling loads are the eigenvalues of

    (K_0 + lam K_G) phi = 0,

lam_1 <= lam_2 <= ... > 0 the load factors at which the linearized path loses stability (Bathe, Finite Element
Procedures, 6.8.2; Cook et al., Concepts and Applications of FEA, 18.2).

K_G is evaluated with the element's own geometric terms: the mixed Newton iteration's element matrix
(:meth:`flexbody.body.ShellBody.mixed_element_forces`) at q0 with the stresses sigma_0 is
K_M(q0) + K_G(sigma_0), linear in the stresses, so K_G = K(q0, sigma_0) - K(q0, 0) exactly (the material
parts are the same matrix). Its definition is checked in the tests against central finite differences of
the forces of fixed stresses B(q)^T sigma_0 under group perturbations q0 o exp(eps e_i).

Both matrices are taken in the virtual-work coordinates of the stability count
(:func:`integrators.static.stability_matrix`): A = sym(T^T K). The problem is solved for mu = 1 / lam as
(-K_G) phi = mu K_0 phi with ARPACK (``scipy.sparse.linalg.eigsh``) on the factorized K_0 -- the shift-invert
transformation of the pencil at lam = 0 -- for the largest mu: the smallest positive load factors. The
constrained DoFs are not unknowns (the free DoFs of the model, as in the static solver).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexbody.assembly import Model
from integrators.linear import LinearSolver, SingularMatrixError
from integrators.static import stability_matrix


@dataclass
class BucklingResult:
    """The critical load factors (ascending, > 0) and the buckling modes of a load pattern.

    ``modes`` (k, n_free): the modes on the model's free DoFs (the model's increment coordinates, as
    :meth:`flexbody.assembly.Model.update` takes them), each scaled to a largest translation of 1 (in
    units of length). ``prebuckling``: the linear pre-buckling displacements u0 under the reference load.
    """

    load_factors: np.ndarray
    modes: np.ndarray
    prebuckling: np.ndarray
    dofs: int
    wall_time_s: float = 0.0

    def as_dict(self, scene: str | None = None) -> dict:
        """A JSON-able summary: the critical load factors, ascending, and one entry per mode."""
        return {"scene": scene, "analysis": "linear buckling", "dofs": self.dofs,
                "load_factors": [float(v) for v in self.load_factors],
                "modes": [{"mode": i + 1, "load_factor": float(v)} for i, v in enumerate(self.load_factors)],
                "wall_time_s": self.wall_time_s}


def _translation_rows(model: Model) -> np.ndarray:
    """The free DoFs that are translations."""
    return (model.free % 6) < 3


def nodal_translations(model: Model, state, dq: np.ndarray) -> np.ndarray:
    """The global translations (n, 3) of an increment dq on the free DoFs (zero on constrained nodes)."""
    n = model.body.n_nodes
    d6 = np.zeros(6 * n)
    d6[model.free] = model.conjugate(state, dq)        # global on nodes without a basis
    d6 = d6.reshape(n, 6)
    out = d6[:, :3].copy()
    idx = np.flatnonzero(model.has_basis)
    out[idx] = np.einsum("nij,nj->ni", model.basis[idx], d6[idx, :3])
    return out


def geometric_stiffness(model: Model, state, stress: np.ndarray, lam: float = 1.0) -> sp.csc_matrix:
    """K_G (free x free): the change of the tangent at ``state`` when the Gauss-point stresses ``stress``
    (m, 7, 8) act in the element's geometric terms and the loads at factor ``lam`` (their load stiffness),
    K(q, sigma, lam) - K(q, 0, 0) in the model's rows and columns. MITC6 bodies."""
    if getattr(model.body.material, "wrinkling", False):
        raise ValueError("linear buckling needs a linear membrane law: the tension-field (wrinkling) material "
                         "has no geometric stiffness of given stresses (material wrinkling = true)")
    if not model.body.supports_mixed_iteration:
        raise ValueError("linear buckling needs an MITC6 element (the geometric stiffness of given stresses); "
                         f"{model.body.element_name} (tying = {model.body.element.key!r}) does not provide it")
    with_stress = state.copy()
    with_stress.stress = np.asarray(stress, dtype=float)
    without = state.copy()
    without.stress = np.zeros_like(with_stress.stress)
    return (model.residual_and_tangent(with_stress, lam)[1] - model.residual_and_tangent(without, 0.0)[1]).tocsc()


def linear_buckling(model: Model, count: int = 6) -> BucklingResult:
    """The ``count`` lowest positive critical load factors of the model's loads and their modes.

    Raises ValueError for a bad count, a model without load, or a body whose supports leave a rigid motion
    free; fewer than ``count`` factors are returned if the load pattern has fewer positive ones (a tension
    field, for instance, has none: the result is then empty).
    """
    import time
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"buckling count must be an integer >= 1, got {count!r}")
    t0 = time.perf_counter()
    model.check_static_support()
    state = model.initial_state()
    A0, g = stability_matrix(model, state, 0.0)
    if not np.any(g):
        raise ValueError("linear buckling needs a load: the scene's external force vector is zero")
    # the linear pre-buckling state, with the model's own (unsymmetric-looking) rows and columns
    _, K0 = model.residual_and_tangent(state, 0.0)
    solver = LinearSolver()
    try:
        solver.factorize(K0)
    except SingularMatrixError as exc:
        raise ValueError(f"linear buckling: {exc}") from None
    u0 = solver.solve(model.external_force(state))
    sigma0 = model.body.stresses(state, model.element_motions(state, u0))
    T = model.conjugate_matrix(state)
    KG = T.T @ geometric_stiffness(model, state, sigma0, 1.0)
    KG = (0.5 * (KG + KG.T)).tocsc()
    n = A0.shape[0]
    k = int(min(count, n - 1))
    lu = spla.splu(A0, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    Minv = spla.LinearOperator((n, n), matvec=lu.solve, dtype=float)
    if n <= 400:   # small: dense, exact
        import scipy.linalg
        mu, phi = scipy.linalg.eigh(-KG.toarray(), A0.toarray())
    else:
        ncv = min(n - 1, max(2 * k + 1, k + 20))
        mu, phi = spla.eigsh(-KG, k=k, M=A0, Minv=Minv, which="LA", ncv=ncv, tol=1e-10)
    keep = mu > 1e-12 * max(np.abs(mu).max(), 1e-300)
    lam, phi = 1.0 / mu[keep], phi[:, keep]
    order = np.argsort(lam)[:k]
    lam, phi = lam[order], phi[:, order]
    modes = np.zeros((len(lam), n))
    for j in range(len(lam)):
        t = nodal_translations(model, state, phi[:, j])
        size = np.abs(t).max()
        i = np.unravel_index(np.argmax(np.abs(t)), t.shape)
        modes[j] = phi[:, j] / (size * np.sign(t[i]) if size > 0 else 1.0)
    return BucklingResult(lam, modes, u0, n, time.perf_counter() - t0)
