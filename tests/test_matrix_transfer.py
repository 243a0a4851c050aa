"""The map of a kept iteration matrix to the current configuration (flexbody.matrix_transfer): the compiled
drilling drifts and node rotations against their numpy references; a drilling turn is recovered exactly."""

import numpy as np
import pytest

from flexbody.lie import so3
from flexbody.matrix_transfer import (apply_node_rotations, apply_node_rotations_reference, drilling_drifts,
                                      drilling_drifts_reference)


def random_rotations(rng, k, scale=1.0):
    return so3.exp_many(scale * rng.normal(size=(k, 3)))


@pytest.mark.parametrize("scale", [1e-8, 0.1, 1.0])
def test_drilling_drifts_are_the_reference(scale):
    """Frames turned by their patch's rotation G and a further turn of size ``scale`` (tilt and drilling)."""
    rng = np.random.default_rng(5)
    R_ref, G = random_rotations(rng, 40), random_rotations(rng, 40, 3.0)
    R = G @ R_ref @ random_rotations(rng, 40, scale)
    DT = drilling_drifts(R_ref, G, R)
    assert np.abs(DT - drilling_drifts_reference(R_ref, G, R)).max() < 1e-14
    assert np.allclose(DT @ np.swapaxes(DT, 1, 2), np.eye(2), atol=1e-14)      # plane rotations


def test_a_drilling_turn_beyond_the_patch_rotation_is_recovered():
    """R = G R_ref exp(phi e3): D = exp(phi e3), so D^T = [[cos, sin], [-sin, cos]]."""
    rng = np.random.default_rng(6)
    R_ref, G = random_rotations(rng, 10), random_rotations(rng, 10)
    phi = rng.uniform(-3.0, 3.0, 10)
    R = G @ R_ref @ so3.exp_many(phi[:, None] * np.array([0.0, 0.0, 1.0]))
    DT = drilling_drifts(R_ref, G, R)
    c, s = np.cos(phi), np.sin(phi)
    assert np.abs(DT - np.stack([np.stack([c, s], 1), np.stack([-s, c], 1)], 1)).max() < 1e-14


@pytest.mark.parametrize("transpose", [False, True])
def test_node_rotations_are_the_reference(transpose):
    rng = np.random.default_rng(7)
    n = 60
    perm = rng.permutation(n)
    col, rot = perm[:30].reshape(10, 3), perm[30:50].reshape(10, 2)       # 10 entries untouched
    G, DT = random_rotations(rng, 10), random_rotations(rng, 10)[:, :2, :2]
    vec = rng.normal(size=n)
    out = apply_node_rotations(vec, col, G, rot, DT, transpose)
    assert np.abs(out - apply_node_rotations_reference(vec, col, G, rot, DT, transpose)).max() < 1e-15
    back = apply_node_rotations(out, col, G, rot, DT, not transpose)
    assert np.allclose(back[col], vec[col], atol=1e-14) and np.array_equal(back[perm[50:]], vec[perm[50:]])
    with pytest.raises(ValueError, match="vec must be a vector"):
        apply_node_rotations(vec[:, None], col, G, rot, DT)
    with pytest.raises(ValueError, match=r"col_index must hold DoF indices in \[0, 60\), got 0 .. 60"):
        apply_node_rotations(vec, np.where(col == col.max(), 60, col), G, rot, DT)
    with pytest.raises(ValueError, match="rot_index"):
        apply_node_rotations(vec, col, G, rot[:, :1], DT)


def test_a_director_turned_over_against_its_patch_gets_no_drilling_turn():
    """A half turn about an in-plane axis (R = G R_ref exp(pi a), a in the plane) leaves c = s = 0: both paths give
    the identity, not a division by zero (a numba ZeroDivisionError would have ended the run from inside the
    transfer of the iteration matrix)."""
    rng = np.random.default_rng(8)
    R_ref, G = random_rotations(rng, 3), random_rotations(rng, 3)
    a = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, -0.8, 0.0]])
    R = G @ R_ref @ so3.exp_many(np.pi * a)
    for drifts in (drilling_drifts, drilling_drifts_reference):
        assert np.array_equal(drifts(R_ref, G, R), np.tile(np.eye(2), (3, 1, 1)))
