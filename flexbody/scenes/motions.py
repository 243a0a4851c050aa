"""Initial velocity fields and prescribed motions for dynamic scenes: the rigid field of a spin, modal kicks in
polar coordinates, a hub's smooth spin-up, and the nodal velocity fields of a free-DoF velocity.

Building helpers: used by the built-in scenes, the TOML reader and a user's Python scene file (add a field to
the ``initial_velocity`` of a :class:`flexbody.scenes.analysis.DynamicAnalysis`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np


def rigid_field(positions: np.ndarray, angular_velocity, center=None,
                velocity=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Nodal velocities (n, 3) and angular velocities (n, 3) of the rigid motion v0 + omega x (x - c).

    Parameters
    ----------
    positions : nodal positions x (n, 3)
    angular_velocity : omega (3,), global components
    center : c (3,), default the origin
    velocity : v0 (3,), the velocity of the point c
    """
    x = np.asarray(positions, dtype=float)
    w = np.asarray(angular_velocity, dtype=float)
    c = np.zeros(3) if center is None else np.asarray(center, dtype=float)
    xdot = np.asarray(velocity, dtype=float) + np.cross(w, x - c)
    return xdot, np.tile(w, (len(x), 1))


RADIAL_SHAPES = ("uniform", "linear", "quadratic")


def _shown(value) -> str:
    """A value for an error message (arrays as lists)."""
    return repr(value.tolist() if isinstance(value, np.ndarray) else value)


def polar_coordinates(positions: np.ndarray, center=(0.0, 0.0, 0.0),
                      axis=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Distance r from the axis through ``center`` and angle theta about it, of points (n, 3).

    theta is measured from the projection of global x on the plane normal to the axis (of global y when the
    axis is along x), positive about the axis: for the axis z, the usual polar angle.
    """
    n = np.asarray(axis, dtype=float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.abs(n).max() > 0:
        raise ValueError(f"axis must be a finite nonzero 3-vector, got {_shown(axis)}")
    n = n / np.abs(n).max()
    n = n / np.linalg.norm(n)
    ref = np.eye(3)[0] if abs(n[0]) < 0.9 else np.eye(3)[1]
    e1 = ref - (ref @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    rel = np.asarray(positions, dtype=float) - np.asarray(center, dtype=float)
    a, b = rel @ e1, rel @ e2
    return np.hypot(a, b), np.arctan2(b, a)


def radial_shape(r: np.ndarray, shape, inner: float, outer: float) -> np.ndarray:
    """f(r) of a velocity field: with s = (r - a) / (b - a) held in [0, 1], "uniform" 1, "linear" s,
    "quadratic" s^2, or a table (r_k, f_k) interpolated linearly in r and held at its ends."""
    if isinstance(shape, str):
        if shape not in RADIAL_SHAPES:
            raise ValueError(f"radial must be one of {', '.join(map(repr, RADIAL_SHAPES))} or a table "
                             f"[[r...], [f...]], got {shape!r}")
        if not (np.isfinite(inner) and np.isfinite(outer) and outer > inner):
            raise ValueError(f"outer_radius must exceed inner_radius, got {inner!r} and {outer!r}")
        s = np.clip((r - inner) / (outer - inner), 0.0, 1.0)
        return np.ones_like(r) if shape == "uniform" else s if shape == "linear" else s * s
    try:
        rk, fk = (np.asarray(v, dtype=float) for v in shape)
    except (TypeError, ValueError):
        raise ValueError(f"radial table must be two lists [r...], [f...], got {shape!r}") from None
    if rk.ndim != 1 or rk.size < 1 or rk.shape != fk.shape or not np.all(np.isfinite(rk)) \
            or not np.all(np.isfinite(fk)) or np.any(np.diff(rk) <= 0):
        raise ValueError(f"radial table must be two lists of equal length, finite, the radii increasing, "
                         f"got {shape!r}")
    return np.interp(r, rk, fk)


def modal_velocity_field(positions: np.ndarray, direction, amplitude: float, radial="linear",
                         modes=(0,), phase: float = 0.0, inner_radius: float | None = None,
                         outer_radius: float | None = None, center=(0.0, 0.0, 0.0),
                         axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Nodal velocities (n, 3) v_I = amplitude f(r_I) sum_n cos(n (theta_I - phase)) d along ``direction`` d.

    A kick out of plane (d the axis) or in any direction, with circumferential modes n (cos n theta,
    n = 0 the axisymmetric one) and a radial shape f (:func:`radial_shape`) between ``inner_radius`` a and
    ``outer_radius`` b (default: the smallest and largest distance of the nodes from the axis). For the kick
    v_z = 0.05 (r - a)/(b - a) sum_{n=0..3} cos n theta of an annulus:
    ``modal_velocity_field(x, [0, 0, 1], 0.05, "linear", modes=[0, 1, 2, 3])``. Add it to the
    ``initial_velocity`` of a :class:`flexbody.scenes.scene.DynamicAnalysis` (for a steady-spin start it is
    the kick on top of the spin). r and theta are those of :func:`polar_coordinates`; ``direction`` is
    normalised; ``phase`` is in radians.
    """
    x = np.asarray(positions, dtype=float)
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.abs(d).max() > 0:
        raise ValueError(f"direction must be a finite nonzero 3-vector, got {_shown(direction)}")
    d = d / np.abs(d).max()
    d = d / np.linalg.norm(d)
    if isinstance(amplitude, bool) or not np.isfinite(amplitude):
        raise ValueError(f"amplitude must be a finite number, got {amplitude!r}")
    if isinstance(phase, bool) or not np.isfinite(phase):
        raise ValueError(f"phase must be a finite number, got {phase!r}")
    modes = list(modes)
    if not modes or not all(isinstance(m, (int, np.integer)) and not isinstance(m, bool) and m >= 0 for m in modes):
        raise ValueError(f"modes must be a non-empty list of integers >= 0, got {modes!r}")
    r, theta = polar_coordinates(x, center, axis)
    a = float(r.min()) if inner_radius is None else float(inner_radius)
    b = float(r.max()) if outer_radius is None else float(outer_radius)
    pattern = sum(np.cos(m * (theta - phase)) for m in modes)
    return (amplitude * radial_shape(r, radial, a, b) * pattern)[:, None] * d


def spin_up_angle(rate: float, ramp: float) -> Callable[[float], float]:
    """The angle of a smooth spin-up: omega(t) = rate (1 - cos(pi t / ramp)) / 2 for t < ramp, then rate.

    The angular acceleration is continuous and vanishes at both ends of the ramp (ramp = 0: rate from t = 0).
    """
    def angle(t: float) -> float:
        if 0 < ramp and t < ramp:
            return rate * (t / 2 - ramp / (2 * np.pi) * np.sin(np.pi * t / ramp))
        return rate * (ramp / 2 + t - ramp)
    return angle


def hub_spin_up(angular_velocity, ramp: float, center=(0.0, 0.0, 0.0)) -> Callable:
    """t -> (Q(t), d(t)) of a hub spun up about the axis through ``center`` to ``angular_velocity`` in ``ramp``.

    Q(t) = exp(angle(t) n) with n the axis of ``angular_velocity`` and angle from :func:`spin_up_angle`;
    d(t) = c - Q(t) c, so that the points of the axis stay put. For
    :class:`flexbody.dynamics.PrescribedMotion`.
    """
    from flexbody.lie import so3
    w = np.asarray(angular_velocity, dtype=float)
    c = np.asarray(center, dtype=float)
    rate = float(np.linalg.norm(w))
    axis = w / rate if rate > 0 else np.array([0.0, 0.0, 1.0])
    angle = spin_up_angle(rate, ramp)

    def motion(t: float):
        Q = so3.exp(angle(t) * axis)
        return Q, c - Q @ c
    return motion


def nodal_fields(dyn, state, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodal velocities (n, 3) and global angular velocities (n, 3) of a free-DoF velocity.

    The inverse of :meth:`flexbody.dynamics.DynamicModel.velocity_from_nodal` (drilling components are zero).
    """
    xdot, w_local = dyn.nodal_velocities(state, velocity)
    return xdot, np.einsum("nij,nj->ni", state.frames, w_local)
