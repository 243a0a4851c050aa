"""Modal analysis: natural frequencies and mode shapes about an equilibrium, at rest or in steady spin.

The small motions q(t) about an equilibrium q0 of :class:`flexbody.dynamics.DynamicModel` obey the
linearised equations on the free DoFs (the dynamic model's layout: translations in fixed directions,
rotations about the nodal axes t1, t2)::

    M qddot + G qdot + K q = 0

* At rest (an unloaded state, or a static equilibrium at a load factor): K = K_t, the tangent of
  f_int - lambda f_ext (material and geometric, i.e. pre-stress, parts; follower loads add their load
  stiffness), and G = 0. With q = phi e^{i omega t}: the generalized eigenproblem K phi = omega^2 M phi,
  solved by shift-invert Lanczos (:func:`scipy.sparse.linalg.eigsh`).
* In steady spin (:func:`flexbody.spinning.steady_spin`, a relative equilibrium at angular velocity
  Omega), in the co-rotating frame: K = K_t - K_c, the tangent of the :class:`flexbody.spinning.SpinningModel`
  (material, geometric and centrifugal parts), and the Coriolis (gyroscopic) matrix G, skew. With
  q = phi e^{i omega t} the quadratic eigenproblem (-omega^2 M + i omega G + K) phi = 0, solved on its
  first-order form by shift-invert Arnoldi (:func:`scipy.sparse.linalg.eigs`, :func:`quadratic_modes`).

The gyroscopic matrix (:func:`gyroscopic_matrix`). A node of mass m at x = Q(t) (X + u) (Q the spin) has the
inertial acceleration Q (uddot + 2 Omega x udot + Omega x (Omega x (X + u))): the Coriolis force
2 m Omega x udot, G_tt = 2 m hat(Omega) (E^T 2 m hat(Omega) E on a node with a fixed translation basis E).
The director inertia J = j diag(1, 1, 0) has the kinetic energy T = j/2 |tdot|^2 of the director t, and in
the turning frame tdot = Q (Omega x t' + t'dot). The term j t'dot . (Omega x t') of T is linear in the
relative rate; its Lagrange equations give the force 2 j Omega x t'dot on the director (the same form as on
the translations, m -> j), the quadratic term j/2 |Omega x t'|^2 is the centrifugal director moment of
``SpinningModel``. The director moves with the rotations theta_1, theta_2 about t1, t2:
dt = theta_1 t1 x t + theta_2 t2 x t = -theta_1 t2 + theta_2 t1, so the generalized forces on theta_k are
(d t / d theta_k) . 2 j Omega x (d t / d theta_l) theta_l dot::

    G_rr = 2 j (Omega . t) [[0, -1], [1, 0]]

(tests/test_modal.py checks both blocks against central finite differences of the kinetic energy on the
group). Both blocks are skew: the gyroscopic forces do no work, and the eigenvalues i omega of a stable
spin are imaginary.

The frequencies in the co-rotating frame of an axisymmetric body (:func:`axisymmetry`) with n nodal
diameters are seen from the inertial frame as the waves omega + n |Omega| (forward) and omega - n |Omega|
(backward; negative: it travels forward in the inertial frame at |omega - n Omega|).

The mass is the dynamic model's (:func:`mass_matrix`, the one place it is taken from).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexbody.body import ShellState
from flexbody.dynamics import DynamicModel
from flexbody.lie.so3 import hat


# --------------------------------------------------------------------------------------------------------
# The matrices
# --------------------------------------------------------------------------------------------------------
def mass_matrix(dynamic: DynamicModel) -> sp.csc_matrix:
    """M on the free DoFs of ``dynamic`` (its layout): the dynamic model's mass matrix, or its lumped diagonal."""
    getter = getattr(dynamic, "mass_matrix", None)
    if callable(getter):
        return sp.csc_matrix(getter())
    return sp.diags(np.asarray(dynamic.mass, dtype=float)).tocsc()


def gyroscopic_matrix(dynamic: DynamicModel, state: ShellState, omega) -> sp.csc_matrix:
    """G (skew, free x free) of the dynamic model's mass in the frame turning at ``omega`` (module docstring).

    Translations: T^T (S x 2 hat(Omega)) T with S the scalar mass matrix (lumped: diag(m_I); consistent:
    int rho h N_I N_J dA) and T the translation directions of the free DoFs (on a node with a fixed
    translation basis E_I: 2 m_I E_I^T hat(Omega) E_I when lumped); director rotations (their inertia is lumped
    in both): 2 j_I (Omega . t_I) [[0, -1], [1, 0]]."""
    omega = np.asarray(omega, dtype=float)
    m = dynamic.model
    n = m.body.n_nodes
    index = -np.ones(6 * n, dtype=np.int64)
    index[m.free] = np.arange(m.n_dof)
    index = index.reshape(n, 6)
    T = dynamic.translation_directions()
    trans = T.T @ sp.kron(dynamic.body_mass.scalar, 2.0 * hat(omega)) @ T
    spin = state.directors @ omega
    rot = 2.0 * (dynamic.body_mass.rotary * spin)[:, None, None] * np.array([[0.0, -1.0], [1.0, 0.0]])[None]
    idx = index[:, 3:5]
    r = np.repeat(idx[:, :, None], 2, axis=2)
    c = np.repeat(idx[:, None, :], 2, axis=1)
    keep = (r >= 0) & (c >= 0) & (rot != 0.0)
    G = sp.csc_matrix((rot[keep], (r[keep], c[keep])), shape=(m.n_dof, m.n_dof)) + trans
    return sp.csc_matrix(0.5 * (G - G.T))           # skew to the last bit


def tangent_at_rest(dynamic: DynamicModel, state: ShellState, load_factor=0.0) -> sp.csc_matrix:
    """K_t of f_int - lambda f_ext at ``state`` in the dynamic model's layout (columns: global translations)."""
    plain = state.copy()
    plain.stress = None
    K = dynamic.model.residual_and_tangent(plain, load_factor)[1]
    return (K @ dynamic.column_map(plain)).tocsc()


def tangent_in_spin(dynamic: DynamicModel, state: ShellState, omega, center, time: float = 0.0) -> sp.csc_matrix:
    """K_t - K_c of the steady spin (:class:`flexbody.spinning.SpinningModel` at lam = 1) in the dynamic layout."""
    from flexbody.spinning import SpinningModel
    plain = state.copy()
    plain.stress = None
    K = SpinningModel(dynamic, omega, center, time).residual_and_tangent(plain, 1.0)[1]
    return (K @ dynamic.column_map(plain)).tocsc()


# --------------------------------------------------------------------------------------------------------
# The eigen-solutions
# --------------------------------------------------------------------------------------------------------
@dataclass
class ModalProblem:
    """The linearised equations M qddot + G qdot + K q = 0 about ``state`` (G None: at rest).

    ``omega`` (3,) and ``center``: the spin (zero at rest); ``frame``: "inertial" or "co-rotating";
    ``asymmetry``: |K - K^T|_max / |K|_max before K is symmetrised (follower loads, and the drilling moments
    that the 5-DoF rotations leave in the rotation block, make K_t slightly non-symmetric)."""

    dynamic: DynamicModel
    state: ShellState
    K: sp.csc_matrix
    M: sp.csc_matrix
    G: sp.csc_matrix | None = None
    omega: np.ndarray = field(default_factory=lambda: np.zeros(3))
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    frame: str = "inertial"
    asymmetry: float = 0.0

    @property
    def spin_rate(self) -> float:
        return float(np.linalg.norm(self.omega))


def modal_problem_at_rest(dynamic: DynamicModel, state: ShellState | None = None,
                          load_factor=0.0) -> ModalProblem:
    """The problem about ``state`` (default: the reference state) of the model at ``load_factor``."""
    state = dynamic.model.initial_state() if state is None else state
    K = tangent_at_rest(dynamic, state, load_factor)
    K, asym = _symmetric_part(K)
    return ModalProblem(dynamic, state, K, mass_matrix(dynamic), asymmetry=asym)


def modal_problem_in_spin(dynamic: DynamicModel, omega, center=None, *, time: float = 0.0, n_steps: int = 4,
                          settings=None) -> ModalProblem:
    """The problem about the steady spin of ``dynamic`` at ``omega`` (:func:`flexbody.spinning.steady_spin`),
    in the co-rotating frame; omega = 0 gives the problem at rest about the reference state."""
    from flexbody.spinning import steady_spin
    omega = np.asarray(omega, dtype=float)
    if omega.shape != (3,) or not np.all(np.isfinite(omega)):
        raise ValueError(f"the spin angular velocity must be a finite 3-vector, got {omega!r}")
    if not np.any(omega):
        return modal_problem_at_rest(dynamic)
    spin = steady_spin(dynamic, omega, center, time=time, n_steps=n_steps, settings=settings)
    K = tangent_in_spin(dynamic, spin.state, spin.omega, spin.center, time)
    K, asym = _symmetric_part(K)
    return ModalProblem(dynamic, spin.state, K, mass_matrix(dynamic), gyroscopic_matrix(dynamic, spin.state, omega),
                        spin.omega, spin.center, "co-rotating", asym)


def _symmetric_part(K: sp.csc_matrix) -> tuple[sp.csc_matrix, float]:
    scale = float(abs(K).max()) or 1.0
    D = K - K.T
    asym = float(abs(D).max()) / scale if D.nnz else 0.0
    return ((K + K.T) * 0.5).tocsc(), asym


def default_shift(problem: ModalProblem) -> float:
    """The shift s > 0 of the eigen-solvers: they factorize K + s M (at rest) or K + sqrt(s) G + s M (in spin).

    At rest s = 1e-12 max_i(K_ii / M_ii): far below the lowest elastic eigenvalues omega^2 of a shell (the
    largest diagonal ratio belongs to the stiff rotations of the smallest element), so that shift-invert about
    -s converges on them as about 0 (measured: 64 solves for the first 20 modes of a 3e4-DoF plate, 220 with a
    shift above omega_20^2), while K + s M stays regular for a free body (rigid modes omega ~ 0). In spin
    s = Omega^2: the gyroscopic and centrifugal terms set the scale of the lowest modes, and the pencil is
    regular at the real shift also for a free spinning body (its rigid roots lie at 0 and +-i Omega). The
    rest floor is not applied in spin: it grows as 1/thickness^2 (the directors' rotary inertia), and at
    h/R = 1e-6 it put the shift of a 20 rad/s annulus at 2800 rad/s, where the solver did not converge."""
    if problem.spin_rate > 0.0:
        return problem.spin_rate ** 2
    K, M = problem.K, problem.M
    dm = M.diagonal()
    ratio = np.abs(K.diagonal()) / np.where(dm > 0, dm, np.inf)
    return 1e-12 * float(ratio.max() or 1.0)


@dataclass
class Modes:
    """Natural frequencies (rad/s, ascending) and mode shapes on the free DoFs (columns, complex in spin).

    A negative frequency is an unstable state: -sqrt(|omega^2|) of a negative eigenvalue (divergence).
    ``problem`` is the :class:`ModalProblem` solved."""

    frequencies: np.ndarray
    vectors: np.ndarray
    problem: ModalProblem

    def nodal_displacements(self, k: int, phase: float = 0.0) -> np.ndarray:
        """The nodal translations (n, 3) of mode k at phase ``phase`` (Re(phi e^{i phase})), max norm 1."""
        dyn = self.problem.dynamic
        v = np.real(self.vectors[:, k] * np.exp(1j * phase))
        xdot, _ = dyn.nodal_velocities(self.problem.state, v)
        scale = np.abs(self.vectors[:, k][dyn.is_translation]).max() or 1.0
        return xdot / scale


def solve_modes(problem: ModalProblem, count: int = 10, shift: float | None = None) -> Modes:
    """The ``count`` lowest natural frequencies (by |omega|) of ``problem``.

    At rest: eigsh in shift-invert mode about -s (:func:`default_shift`). In spin: :func:`quadratic_modes`.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"the number of modes must be an integer >= 1, got {count!r}")
    n = problem.K.shape[0]
    if count > n - 2 and problem.G is None or 2 * count > 2 * n - 2:
        raise ValueError(f"asked for {count} modes of a model with {n} free DoFs (at most {n - 2})")
    s = default_shift(problem) if shift is None else float(shift)
    if not np.isfinite(s) or s <= 0:
        raise ValueError(f"the shift must be a finite number > 0, got {shift!r}")
    if problem.G is None or problem.G.nnz == 0:
        lam, vec = _symmetric_modes(problem.K, problem.M, count, s)
        freq = np.sign(lam) * np.sqrt(np.abs(lam))
        order = np.argsort(np.abs(freq))
        return Modes(freq[order], vec[:, order], problem)
    freq, vec = quadratic_modes(problem.K, problem.G, problem.M, count, s)
    return Modes(freq, vec, problem)


def _symmetric_modes(K, M, count: int, s: float):
    """eigsh shift-invert about -s: the eigenvalues of K phi = lambda M phi nearest -s."""
    lu = spla.splu((K + s * M).tocsc())
    OPinv = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    lam, vec = spla.eigsh(K, k=count, M=M, sigma=-s, which="LM", OPinv=OPinv)
    return lam, vec


def quadratic_modes(K, G, M, count: int, s: float):
    """The ``count`` frequencies omega >= 0 of (-omega^2 M + i omega G + K) phi = 0 nearest 0, and phi.

    With lambda = i omega and z = (phi, lambda phi) the first-order form A z = lambda B z,
    A = [[0, 1], [-K, -G]], B = [[1, 0], [0, M]]. Shift-invert about the real shift sigma = sqrt(s):
    (A - sigma B)^{-1} B z = nu z, nu = 1 / (lambda - sigma); its largest |nu| are the lambda nearest sigma,
    i.e. the smallest |omega| for lambda on the imaginary axis. One solve with A - sigma B needs only the
    n x n factorization of S = K + sigma G + sigma^2 M:
    z2 = b1 + sigma z1, S z1 = -(b2 + (G + sigma M) b1), for B b = (b1, M b2') applied first.
    The eigenvalues come in pairs lambda, conj(lambda) (real matrices): each mode once, with omega =
    Im(lambda) >= 0 (a real part of lambda is reported through the sign convention of :class:`Modes`:
    a root with |Re lambda| > |Im lambda| is a divergence, -|lambda|).
    """
    n = K.shape[0]
    sigma = float(np.sqrt(s))
    S = (K + sigma * G + sigma * sigma * M).tocsc()
    lu = spla.splu(S)
    GsM = (G + sigma * M).tocsr()
    Mr = M.tocsr()

    def op(z):
        z = np.asarray(z).ravel()
        b1, b2 = z[:n], Mr @ z[n:]
        z1 = -lu.solve(np.asarray(b2 + GsM @ b1))
        return np.concatenate([z1, b1 + sigma * z1])

    dtype = float
    A = spla.LinearOperator((2 * n, 2 * n), matvec=op, dtype=dtype)
    k = min(2 * count + 2, 2 * n - 2)
    nu, Z = spla.eigs(A, k=k, which="LM", ncv=min(2 * n - 1, max(2 * k + 1, 20)))
    lam = sigma + 1.0 / nu
    tol = 1e-8 * float(np.abs(lam).max())
    oscillating = np.abs(lam.imag) >= np.abs(lam.real)
    rigid = np.flatnonzero(np.abs(lam) <= tol)
    # one root of each conjugate pair lambda, conj(lambda): omega = Im(lambda) > 0; the double roots 0 of a
    # rigid motion: one of each two; a real pair +-mu (divergence): the growing root, reported as -mu
    keep = np.flatnonzero(oscillating & (lam.imag > tol))
    keep = np.concatenate([keep, rigid[: (rigid.size + 1) // 2],
                           np.flatnonzero(~oscillating & (lam.real > tol))])
    freq = np.where(oscillating, lam.imag, -np.abs(lam))[keep]
    freq[np.abs(lam[keep]) <= tol] = 0.0
    vec = Z[:n][:, keep]
    order = np.argsort(np.abs(freq))[:count]
    vec = vec[:, order]
    vec = vec / np.abs(vec).max(axis=0)
    return freq[order], vec


# --------------------------------------------------------------------------------------------------------
# Axisymmetric bodies: nodal diameters and circles
# --------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Axisymmetry:
    """An axisymmetric mesh: rings of nodes at equal radius and height about ``axis`` through ``center``.

    ``rings``: the node indices of each ring, sorted by angle, rings by (radius, height); ``radius``,
    ``height``: per ring."""

    axis: np.ndarray
    center: np.ndarray
    rings: tuple
    radius: np.ndarray
    height: np.ndarray


def axisymmetry(x: np.ndarray, axis, center, min_ring: int = 8, rtol: float = 1e-6) -> Axisymmetry | None:
    """The rings of an axisymmetric node set ``x`` (n, 3), or None if it is not one.

    Every node off the axis must lie on a ring of >= ``min_ring`` nodes at equal radius and height whose
    angles are equally spaced (a mesh turned about the axis by one angular step maps onto itself). Nodes on
    the axis form their own one-node ring (radius 0)."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    center = np.asarray(center, dtype=float)
    r = x - center
    h = r @ axis
    radial = r - np.outer(h, axis)
    rad = np.linalg.norm(radial, axis=1)
    size = float(max(rad.max(), np.abs(h).max(), 1e-300))
    tol = rtol * size * 1e3
    e1 = np.cross(axis, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 0.5:
        e1 = np.cross(axis, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    theta = np.arctan2(radial @ e2, radial @ e1)
    key = np.round(np.column_stack([rad, h]) / tol).astype(np.int64)
    _, label = np.unique(key, axis=0, return_inverse=True)
    label = label.ravel()
    rings, radii, heights = [], [], []
    for k in range(label.max() + 1):
        nodes = np.flatnonzero(label == k)
        if rad[nodes].mean() <= tol:
            rings.append(nodes), radii.append(0.0), heights.append(float(h[nodes].mean()))
            continue
        if nodes.size < min_ring:
            return None
        nodes = nodes[np.argsort(theta[nodes])]
        steps = np.diff(np.concatenate([theta[nodes], [theta[nodes[0]] + 2 * np.pi]]))
        if np.abs(steps - 2 * np.pi / nodes.size).max() > 1e-6 * 2 * np.pi:
            return None
        rings.append(nodes), radii.append(float(rad[nodes].mean())), heights.append(float(h[nodes].mean()))
    order = np.lexsort((heights, radii))
    return Axisymmetry(axis, center, tuple(rings[i] for i in order), np.array(radii)[order],
                       np.array(heights)[order])


def nodal_counts(sym: Axisymmetry, x: np.ndarray, u: np.ndarray) -> tuple[int, int]:
    """(nodal diameters n, nodal circles) of the complex nodal displacement field u (n_nodes, 3).

    The component with the most energy among axial, radial and circumferential is expanded on each ring in
    Fourier harmonics e^{i k theta}; n is the |k| with the largest sum of squared coefficients over the
    rings. The nodal circles are the sign changes along the rings (ascending radius) of that harmonic's
    coefficient, after its phase is taken out, ignoring coefficients below 5 % of the largest."""
    axis = sym.axis
    r = x - sym.center
    radial = r - np.outer(r @ axis, axis)
    rad = np.linalg.norm(radial, axis=1)
    er = np.where(rad[:, None] > 0, radial / np.maximum(rad, 1e-300)[:, None], 0.0)
    et = np.cross(axis, er)
    fields = [u @ axis, np.einsum("ni,ni->n", u, er), np.einsum("ni,ni->n", u, et)]
    energies = [float(np.sum(np.abs(f) ** 2)) for f in fields]
    f = fields[int(np.argmax(energies))]
    nmax = min(len(ring) for ring in sym.rings if len(ring) > 1) // 2 if any(len(g) > 1 for g in sym.rings) else 0
    power = np.zeros(nmax + 1)
    coeff = []
    for ring in sym.rings:
        if len(ring) == 1:
            c = np.zeros(nmax + 1, dtype=complex)
            c[0] = f[ring[0]]
            p = np.abs(c) ** 2
        else:
            F = np.fft.fft(f[ring]) / len(ring)
            p = np.array([abs(F[0]) ** 2] + [abs(F[k]) ** 2 + abs(F[-k]) ** 2 for k in range(1, nmax + 1)])
            # the amplitude of each harmonic on this ring: of e^{ik theta} or of the conjugate wave, the larger
            c = np.array([F[0]] + [F[k] if abs(F[k]) >= abs(F[-k]) else np.conj(F[-k]) for k in range(1, nmax + 1)])
        coeff.append(c)
        power += p
    n = int(np.argmax(power))
    a = np.array([c[n] for c in coeff])
    big = a[np.argmax(np.abs(a))]
    if abs(big) == 0:
        return n, 0
    a = np.real(a * np.conj(big) / abs(big))
    a = a[np.abs(a) > 0.05 * np.abs(a).max()]
    circles = int(np.sum(np.sign(a[1:]) != np.sign(a[:-1])))
    return n, circles


def spin_axis_of(problem: ModalProblem, default_axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The spin axis, or at rest ``default_axis``."""
    if problem.spin_rate > 0:
        return problem.omega / problem.spin_rate
    return np.asarray(default_axis, dtype=float)


@dataclass
class ModeReport:
    """One mode as the command reports it."""

    frequency_rad_s: float
    nodal_diameters: int | None = None
    nodal_circles: int | None = None
    forward_rad_s: float | None = None
    backward_rad_s: float | None = None

    def as_dict(self) -> dict:
        out = {"frequency_rad_s": self.frequency_rad_s, "frequency_hz": self.frequency_rad_s / (2 * np.pi),
               "nodal_diameters": self.nodal_diameters, "nodal_circles": self.nodal_circles}
        if self.forward_rad_s is not None:
            out["inertial_forward_rad_s"] = self.forward_rad_s
            out["inertial_backward_rad_s"] = self.backward_rad_s
        return out


def describe_modes(modes: Modes, axis=None, center=None) -> list[ModeReport]:
    """A :class:`ModeReport` per mode: nodal counts where the body (its reference mesh) is axisymmetric about
    the spin axis (at rest: ``axis`` through ``center``, default the z-axis through the mass centre), and in
    spin the inertial-frame waves omega +- n |Omega|."""
    p = modes.problem
    x0 = p.dynamic.model.body.mesh.nodes
    if center is None:
        center = p.center if p.spin_rate > 0 else p.dynamic.rigid_inertia_tensor(p.dynamic.model.initial_state())[0]
    ax = spin_axis_of(p) if axis is None else np.asarray(axis, dtype=float)
    sym = axisymmetry(x0, ax, center)
    reports = []
    for k, w in enumerate(modes.frequencies):
        rep = ModeReport(float(w))
        if sym is not None:
            u = modes.nodal_displacements(k) + 1j * modes.nodal_displacements(k, -np.pi / 2)
            rep.nodal_diameters, rep.nodal_circles = nodal_counts(sym, x0, u)
            if p.spin_rate > 0:
                rep.forward_rad_s = float(w + rep.nodal_diameters * p.spin_rate)
                rep.backward_rad_s = float(w - rep.nodal_diameters * p.spin_rate)
        reports.append(rep)
    return reports
