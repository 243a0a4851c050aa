"""The rotation of each node's patch between two configurations (flexbody.frames.patch_rotations): the body's
rotation under rigid motion, also far from the origin; the turn of the surface under bending."""

import numpy as np
import pytest

from flexbody.frames import node_patches, patch_covariances, patch_rotations
from flexbody.lie import so3
from flexbody.mesh import generators


def test_patches_are_the_nodes_sharing_an_element():
    mesh = generators.strip(1.0, 0.5, 2, 1)
    patches = node_patches(mesh.elements, mesh.n_nodes)
    D, gather = patches.edges.toarray(), patches.gather.toarray()
    assert np.array_equal(D.sum(axis=1), np.zeros(len(D))) and np.all(np.sort(D, axis=1)[:, [0, -1]] == [-1, 1])
    node, neighbour = np.argmin(D, axis=1), np.argmax(D, axis=1)          # x_neighbour - x_node per edge
    assert np.array_equal(gather, (node[None, :] == np.arange(mesh.n_nodes)[:, None]).astype(float))
    for i in range(mesh.n_nodes):
        around = np.unique(mesh.elements[np.any(mesh.elements == i, axis=1)])
        assert sorted(neighbour[node == i]) == sorted(set(around) - {i})
        assert patches.neighbours[patches.start[i]:patches.start[i + 1]].tolist() == sorted(set(around) - {i})
    assert patches.start[0] == 0 and patches.start[-1] == len(D)


def test_the_compiled_patch_rotations_are_the_numpy_reference():
    """The kernel (H_I summed node by node, then Horn's quaternion) against the sparse edge sums and the SVD
    (flexbody.lie.so3.nearest_rotations) at random large deformations of a curved shell."""
    rng = np.random.default_rng(4)
    mesh = generators.cylinder(2.0, 1.5, 3, 4, angle=np.pi / 2)
    patches = node_patches(mesh.elements, mesh.n_nodes)
    x_ref = mesh.nodes + 0.05 * rng.normal(size=mesh.nodes.shape)
    for scale in (1e-6, 0.05, 0.3):
        x = (x_ref + scale * rng.normal(size=x_ref.shape)) @ so3.exp(rng.normal(size=3)).T
        G = patch_rotations(patches, x_ref, x)
        assert np.abs(G - so3.nearest_rotations(patch_covariances(patches, x_ref, x))).max() < 1e-12


@pytest.mark.parametrize("offset", [0.0, 1e6])
def test_rigid_motion_gives_the_body_rotation_at_every_node(offset):
    """x -> Q x + c on a curved shell, also a million model sizes from the origin (the edges are differences
    of nearby positions, not of products of large coordinates): every G_I is Q."""
    mesh = generators.cylinder(2.0, 1.5, 2, 3, angle=np.pi / 2)
    x_ref = mesh.nodes + offset
    patches = node_patches(mesh.elements, mesh.n_nodes)
    for phi in ([0.4, -0.3, 0.8], [0.0, 0.0, np.pi - 1e-9], [1e-9, 0.0, 0.0]):
        Q = so3.exp(np.array(phi))
        G = patch_rotations(patches, x_ref, x_ref @ Q.T + np.array([0.5, -2.0, 3.0]))
        assert np.abs(G - Q).max() < 1e-12 * max(1.0, offset / 10), np.abs(G - Q).max()


def test_bending_turns_each_patch_by_the_slope_of_the_surface():
    """A flat strip bent to w = c x^2: the patch of a node at x turns about y by -atan(2 c x). Where the patch
    surrounds the node the slope is met to 1e-5; the patches at the strip's ends are one-sided (their slope is
    that of half a patch away), and the uneven stretch of patches that are not symmetric adds a small turn about
    x and z: both fall with the element size (measured 2.3e-2 -> 5.9e-3 and 1.9e-2 -> 8.7e-3 from 8 to 32
    cells)."""
    errors = []
    for n in (8, 32):
        mesh = generators.strip(1.0, 0.5, n, 2)
        x_ref = mesh.nodes.copy()
        x = x_ref.copy()
        x[:, 2] = 0.2 * x_ref[:, 0] ** 2
        phi = so3.log_many(patch_rotations(node_patches(mesh.elements, mesh.n_nodes), x_ref, x))
        inside = (x_ref[:, 0] > 1e-9) & (x_ref[:, 0] < 1.0 - 1e-9) & (x_ref[:, 1] > 1e-9) & (x_ref[:, 1] < 0.5 - 1e-9)
        slope = np.abs(phi[:, 1] + np.arctan(0.4 * x_ref[:, 0]))
        assert slope[inside].max() < 2e-5, slope[inside].max()          # measured 1.1e-5, 2.4e-6
        assert np.abs(phi[:, 1]).max() > 0.3
        errors.append((slope.max(), np.abs(phi[:, [0, 2]]).max()))
    (ends8, turn8), (ends32, turn32) = errors
    assert ends32 < 0.35 * ends8 and turn32 < 0.6 * turn8, errors
