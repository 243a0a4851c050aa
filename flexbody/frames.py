"""Nodal reference frames R_I = [t1, t2, n] of a shell from its directors, and the rotation of each node's
patch between two configurations.

The nodal frames carry no drilling DoF, but their in-plane orientation enters the relative-rotation
interpolation, so the field t1 must be smooth: t1 is a fixed axis projected onto the tangent plane.
The default axis is the global axis least aligned with any director.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from flexbody import _numba
from flexbody.kernel_arrays import kernel_input, kernel_output
from flexbody.lie import kernels


def unit_vector(vector, name: str) -> np.ndarray:
    """``vector / |vector|`` for a user direction (a plane normal, an axis, an output direction).

    The vector is divided by its largest component first, so that huge components (1e300) do not overflow
    the norm into inf (which made the unit vector zero) and tiny ones do not underflow it into zero.

    Raises
    ------
    ValueError
        Naming ``name`` and the value, if it is not a finite nonzero 3-vector.
    """
    try:
        v = np.asarray(vector, dtype=float)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)) or not np.abs(v).max() > 0:
        shown = vector.tolist() if isinstance(vector, np.ndarray) else vector
        raise ValueError(f"{name} must be a finite nonzero 3-vector, got {shown!r}")
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)


def default_frame_axis(directors: np.ndarray) -> np.ndarray:
    """The global axis (x, y or z) whose largest |cos| with the directors is smallest."""
    worst = np.abs(directors).max(axis=0)
    axis = np.zeros(3)
    axis[int(np.argmin(worst))] = 1.0
    return axis


def frames_from_directors(directors: np.ndarray, axis: np.ndarray | None = None) -> np.ndarray:
    """Frames (n, 3, 3) with third column the director and first column the projected ``axis``."""
    directors = np.asarray(directors, dtype=float)
    axis = default_frame_axis(directors) if axis is None else unit_vector(axis, "frame axis")
    t1 = axis - (directors @ axis)[:, None] * directors
    norm = np.linalg.norm(t1, axis=1)
    if np.any(norm < 1e-6):
        bad = int(np.argmin(norm))
        raise ValueError(f"frame axis {axis.tolist()} is parallel to the director of node {bad}; "
                         "choose another frame_axis")
    t1 /= norm[:, None]
    t2 = np.cross(directors, t1)
    return np.stack([t1, t2, directors], axis=2)


def align_frame(frame: np.ndarray, direction: np.ndarray, node: int) -> tuple[np.ndarray, int]:
    """Rotate a frame about its director so that one in-plane axis is +-``direction``.

    Returns the new frame and the index (0 or 1) of the in-plane axis now along ``direction``.
    An axis already within 1e-8 of the direction is kept, so frames stay unchanged where they fit.
    """
    n = frame[:, 2]
    direction = unit_vector(direction, "symmetry plane normal")
    if abs(direction @ n) > 1e-6:
        raise ValueError(f"symmetry plane normal {direction.tolist()} is not tangent to the shell at node "
                         f"{node} (director {n.tolist()}): the node cannot lie on that symmetry plane")
    for k in (0, 1):
        if abs(abs(frame[:, k] @ direction) - 1.0) < 1e-8:
            return frame, k
    t1 = direction
    return np.column_stack([t1, np.cross(n, t1), n]), 0


@dataclass(frozen=True)
class NodePatches:
    """The patch of each node: the nodes it shares an element with.

    ``edges`` (edges, n) is the difference matrix of the directed edges (node, neighbour), x_neighbour - x_node
    per row, and ``gather`` (n, edges) the 0/1 matrix that sums edge values per node (the numpy reference,
    :func:`patch_covariances`); ``start`` (n + 1,) and ``neighbours`` (edges,) list the same edges node by
    node, the neighbours of node I in ``neighbours[start[I]:start[I + 1]]`` (the compiled kernel,
    :func:`patch_rotations`).
    """

    edges: sp.csr_matrix
    gather: sp.csr_matrix
    start: np.ndarray
    neighbours: np.ndarray


def node_patches(elements: np.ndarray, n_nodes: int) -> NodePatches:
    """The :class:`NodePatches` of a mesh with connectivity ``elements`` (m, k)."""
    elements = np.asarray(elements)
    k = elements.shape[1]
    pairs = np.stack([np.repeat(elements, k, axis=1).ravel(), np.tile(elements, (1, k)).ravel()], axis=1)
    pairs = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0)   # each neighbour once, sorted by node
    n_pairs, rows = len(pairs), np.arange(len(pairs))
    edges = sp.csr_matrix((np.r_[-np.ones(n_pairs), np.ones(n_pairs)], (np.r_[rows, rows], pairs.T.ravel())),
                          shape=(n_pairs, n_nodes))
    gather = sp.csr_matrix((np.ones(n_pairs), (pairs[:, 0], rows)), shape=(n_nodes, n_pairs))
    start = np.searchsorted(pairs[:, 0], np.arange(n_nodes + 1)).astype(np.int64)
    return NodePatches(edges, gather, start, np.ascontiguousarray(pairs[:, 1], dtype=np.int64))


def patch_covariances(patches: NodePatches, x_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
    """H_I = sum_J (x_J - x_I)(x_J,ref - x_I,ref)^T over the nodes J of the patch of I, (n, 3, 3): the edges are
    differences of nearby positions, so a body far from the origin loses no digits."""
    e, e_ref = patches.edges @ x, patches.edges @ x_ref
    return (patches.gather @ (e[:, :, None] * e_ref[:, None, :]).reshape(-1, 9)).reshape(-1, 3, 3)


def patch_rotations(patches: NodePatches, x_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The rotations G_I (n, 3, 3) that best map each node's patch from ``x_ref`` onto ``x``.

    G_I minimizes sum_J |G (x_J,ref - x_I,ref) - (x_J - x_I)|^2 over the nodes J of the patch of I: the rotation
    nearest to :func:`patch_covariances` H_I (Kabsch; :func:`flexbody.lie.kernels.nearest_rotation_into`,
    Horn's quaternion, equal to :func:`flexbody.lie.so3.nearest_rotations` to round-off). The edges of a patch
    of a shell span its tangent plane, which fixes the rotation. Under a rigid motion every G_I is the body's
    rotation; under a smooth deformation, the rotation of the surface around the node (its tilt, and its turn
    in its plane). A patch whose edges do not span a plane (none in a mesh of non-degenerate elements) gets
    the identity.

    Compiled, node by node (:func:`_patch_rotations_into`: H_I summed over the node's edges, then its rotation):
    the same H_I as :func:`patch_covariances` but summed in another order, so G_I agrees with the numpy path
    to round-off, not bit for bit.
    """
    n = len(patches.start) - 1
    x_ref, x = kernel_input(x_ref, (3,), "x_ref", rows=n), kernel_input(x, (3,), "x", rows=n)
    G = np.empty((n, 3, 3))
    _patch_rotations_into(patches.start, patches.neighbours, x_ref, x, np.empty((3, 3)), np.empty((4, 4)),
                          kernel_output(G, (n, 3, 3), "out"))
    return G


@_numba.plain
def _patch_rotations_into(start, neighbours, x_ref, x, H, N, out):
    """out[I] = the rotation nearest to H_I = sum_J (x_J - x_I)(x_J,ref - x_I,ref)^T over the neighbours J of I."""
    for i in range(len(start) - 1):
        H[:, :] = 0.0
        for k in range(start[i], start[i + 1]):
            j = neighbours[k]
            for a in range(3):
                e = x[j, a] - x[i, a]
                for b in range(3):
                    H[a, b] += e * (x_ref[j, b] - x_ref[i, b])
        kernels.nearest_rotation_into(H, N, out[i])
