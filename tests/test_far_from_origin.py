"""A model far from the coordinate origin gives the answer of the same model at the origin (issue 14).

Before, the end-moment strip offset by 1e5 (L = 12) stopped at load factor 7e-4 with "no convergence": the
positions x ~ 1e5 carry a rounding of 1e-11, membrane-strain noise whose forces (residual floor 3e-6) lie far
above the strip's bending load. The body now computes with positions relative to a model origin
(:func:`flexbody.body.model_origin`), which the state carries at full precision; ``state.x`` stays in the
user's coordinates.
"""

import dataclasses

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody, model_origin
from flexbody.mesh.tri6 import Tri6Mesh
from flexbody.scenes.builtin import cantilever_end_moment
from flexbody.scenes.scene import run_scene


def shifted(scene, offset):
    """The scene with its mesh (and so its model) moved by ``offset``; constraints and loads unchanged."""
    m = scene.model
    mesh = m.body.mesh
    moved = Tri6Mesh(mesh.nodes + np.asarray(offset, float), mesh.elements, mesh.directors, mesh.node_sets,
                     mesh.edge_sets)
    body = ShellBody(moved, m.body.material, element=m.body.element)
    return dataclasses.replace(scene, model=Model(body, m.constraints, m.loads))


@pytest.fixture(scope="module")
def at_origin():
    return run_scene(cantilever_end_moment(nx=8, steps=10))


@pytest.mark.parametrize("offset, rel", [((1e5, 0.0, 0.0), 1e-8), ((1e5 + 0.3, -3e4 + 0.1, 7e4), 5e-8)])
def test_the_end_moment_strip_far_from_the_origin_rolls_up_as_at_the_origin(at_origin, offset, rel):
    scene = shifted(cantilever_end_moment(nx=8, steps=10), offset)
    far = run_scene(scene)
    assert far.result.converged, far.result.message
    assert far.history["load_factor"] == at_origin.history["load_factor"]
    size = 12.0
    for name in ("minus_U_tip", "W_tip"):
        np.testing.assert_allclose(far.history[name], at_origin.history[name], rtol=0, atol=rel * size)
    # the state is in the user's coordinates: the positions at the origin, moved by the offset
    np.testing.assert_allclose(far.result.state.x - np.asarray(offset), at_origin.result.state.x, rtol=0,
                               atol=rel * size)


def test_model_origin_is_a_rounded_centre_and_zero_near_the_origin():
    strip = np.array([[0.0, 0.0, 0.0], [12.0, 1.0, 0.0]])
    assert np.array_equal(model_origin(strip), np.zeros(3))
    far = model_origin(strip + [1e5, 0.0, 0.0])
    assert np.array_equal(far, [1e5, 0.0, 0.0])                       # a multiple of 16 >= the size
    assert np.abs((strip + [1e5 + 0.3, 0, 0]) - model_origin(strip + [1e5 + 0.3, 0, 0])).max() <= 1.5 * 16


def test_writing_positions_directly_still_counts():
    """Code that writes state.x (prescribed motions, tests) is honoured: the elements see the new position."""
    scene = shifted(cantilever_end_moment(nx=4, steps=1), (1e5, 0.0, 0.0))
    model = scene.model
    state = model.initial_state()
    r0 = model.residual(state, 0.0)
    state.x[5, 0] += 1e-3
    assert np.abs(model.residual(state, 0.0) - r0).max() > 0
    np.testing.assert_allclose(model.body.relative_positions(state)[5],
                               model.body.mesh.nodes[5] - model.body.origin + [1e-3, 0, 0], atol=1e-10)
