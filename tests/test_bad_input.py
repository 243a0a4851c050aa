"""Bad input at the user-facing entry points: each fails at once with a message that names the bad value."""

import numpy as np
import pytest

from flexbody.assembly import Model, ModelError
from flexbody.body import ShellBody, ShellState
from flexbody.constraints import Fix, Symmetry
from flexbody.loads import FollowerPressure, NodalLoad
from flexbody.mesh import MeshError, generators
from flexbody.shell.material import ShellMaterial
from integrators.linear import LinearSolver, SingularMatrixError
from integrators.static import arc_length, load_control

MESH = generators.strip(10.0, 1.0, 4, 1)
MAT = ShellMaterial(1.2e6, 0.0, 0.1)


def body():
    return ShellBody(MESH, MAT)


def clamped(loads=(), more=()):
    return Model(body(), [Fix(MESH.node_set("clamped"), "all"), *more], list(loads))


def tip_force(f=(0, 0, 1.0)):
    return NodalLoad(MESH.node_set("tip"), force=f)


# -- material ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, match", [
    (dict(thickness=0.0), r"material thickness must be > 0, got 0\.0"),
    (dict(thickness=-0.1), r"material thickness must be > 0, got -0\.1"),
    (dict(young=0.0), r"material young \(E\) must be > 0, got 0\.0"),
    (dict(young=-1e6), r"material young \(E\) must be > 0"),
    (dict(poisson=0.5), r"material poisson \(nu\) must lie in \(-1, 0\.5\), got 0\.5"),
    (dict(poisson=-1.0), r"material poisson \(nu\) must lie in \(-1, 0\.5\), got -1\.0"),
    (dict(poisson=0.7), r"poisson \(nu\) must lie in \(-1, 0\.5\), got 0\.7"),
    (dict(young=float("nan")), "material young must be a finite number, got nan"),
    (dict(thickness=float("inf")), "material thickness must be a finite number, got inf"),
    (dict(poisson=float("nan")), "material poisson must be a finite number, got nan"),
    (dict(density=-1.0), "material density must be >= 0"),
    (dict(young="210e9"), "material young must be a finite number, got '210e9'"),
    (dict(thickness=True), "material thickness must be a finite number, got True"),
])
def test_bad_material_is_named(kwargs, match):
    args = dict(young=1.2e6, poisson=0.3, thickness=0.1) | kwargs
    with pytest.raises(ValueError, match=match):
        ShellMaterial(**args)


def test_poisson_just_inside_the_range_is_accepted():
    ShellMaterial(1.0, 0.4999, 0.1)
    ShellMaterial(1.0, -0.9999, 0.1)


# -- loads ----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, match", [
    (dict(force=(np.nan, 0, 0)), r"force must be finite, got \(nan, 0, 0\)"),
    (dict(force=(0, np.inf, 0)), "force must be finite"),
    (dict(moment=(0, 0, -np.inf)), "moment must be finite"),
    (dict(force=(1.0, 2.0)), "force must be a 3-vector"),
    (dict(force="up"), "force must be a 3-vector of numbers, got 'up'"),
])
def test_bad_nodal_load_is_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        NodalLoad([1], **kwargs)


@pytest.mark.parametrize("load, match", [
    (FollowerPressure(float("nan")), "pressure must be finite, got nan"),
    (FollowerPressure("high"), "pressure must be a number, got 'high'"),
    (FollowerPressure(1.0, elements=[0, 99]), r"pressure elements must be indices in 0\.\.7, got \[0, 99\]"),
    (NodalLoad([99], force=(0, 0, 1.0)), r"load names node 99, but the mesh has nodes 0\.\.26"),
])
def test_bad_loads_in_a_model_are_named(load, match):
    with pytest.raises(ModelError, match=match):
        clamped([load])


@pytest.mark.parametrize("nodes", [[1.5], ["a"], [np.nan], [True]])
def test_node_indices_must_be_integers_not_truncated(nodes):
    with pytest.raises(ValueError, match="nodes must be integer node indices"):
        Fix(nodes)
    with pytest.raises(ValueError, match="nodes must be integer node indices"):
        NodalLoad(nodes, force=(0, 0, 1.0))


# -- coordinates ----------------------------------------------------------------------------------------------
def test_nan_coordinates_are_named_at_the_mesh():
    nodes = MESH.nodes.copy()
    nodes[7, 2] = np.nan
    with pytest.raises(MeshError, match="node 7 has non-finite coordinates"):
        type(MESH)(nodes, MESH.elements, MESH.directors)


def test_nan_state_is_named_by_the_model():
    model = clamped([tip_force()])
    s = model.initial_state()
    x = s.x.copy()
    x[5, 0] = np.nan
    with pytest.raises(FloatingPointError, match=r"non-finite nodal positions or frames in the state \(node 5"):
        model.residual(ShellState(x, s.frames), 1.0)


# -- sets -----------------------------------------------------------------------------------------------------
def test_unknown_node_and_edge_sets_list_the_known_ones():
    with pytest.raises(MeshError, match="unknown node set 'clampd'; this mesh has node sets: bottom, clamped, tip, top"):
        MESH.node_set("clampd")
    with pytest.raises(MeshError, match="unknown edge set 'edge'; this mesh has edge sets: bottom, clamped, tip, top"):
        MESH.edge_set("edge")


# -- constraints ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cons, match", [
    (Fix([999]), r"fixed condition names node 999, but the mesh has nodes 0\.\.26"),
    (Fix([-1]), "fixed condition names node -1"),
    (Fix([]), "fixed condition acts on no nodes"),
    (Symmetry([1000], (0, 1.0, 0)), "symmetry condition names node 1000"),
])
def test_constraints_on_missing_nodes_are_named(cons, match):
    with pytest.raises(ModelError, match=match):
        Model(body(), [cons])


def test_unknown_constraint_component_is_named():
    with pytest.raises(ValueError, match=r"unknown constraint component\(s\) \['w'\]"):
        Fix([0], ("w",))


def test_load_on_constrained_translations_only_is_refused():
    # a load partly on constrained DoFs is fine (the support carries that part: tests/test_hostile_inputs.py)
    with pytest.raises(ModelError, match=r"every load acts on constrained DoFs only \(nodes 24, 25, 26\): the "
                                         "supports carry all of it and nothing moves"):
        Model(body(), [Fix(MESH.node_set("clamped")), Fix(MESH.node_set("tip"), ("z",))], [tip_force()])


def test_moment_on_constrained_rotations_only_is_refused():
    with pytest.raises(ModelError, match="every load acts on constrained DoFs only"):
        Model(body(), [Fix(MESH.node_set("clamped")), Fix(MESH.node_set("tip"), ("r1", "r2"))],
              [NodalLoad(MESH.node_set("tip"), moment=(0, 1.0, 0))])


def test_load_orthogonal_to_the_constrained_direction_is_fine():
    Model(body(), [Fix(MESH.node_set("clamped")), Fix(MESH.node_set("tip"), ("x",))], [tip_force()])


def test_contradictory_constraint_directions_are_named():
    with pytest.raises(ModelError, match=r"node 13: constraint direction \[0\.707.*0\.707.*\] contradicts an "
                                         "earlier constraint direction"):
        clamped(more=[Fix([13], ("x",)), Symmetry([13], (1.0, 1.0, 0))])


def test_symmetry_plane_not_through_the_surface_is_named():
    with pytest.raises(ValueError, match=r"symmetry plane normal \[0\.0, 0\.0, 1\.0\] is not tangent to the "
                                         "shell at node 13"):
        clamped(more=[Symmetry([13], (0, 0, 1.0))])


# -- singular static problems -----------------------------------------------------------------------------------
def test_static_run_without_constraints_says_singular_stiffness():
    model = Model(body(), [], [tip_force()])
    with pytest.raises(ModelError, match=r"the body has no constraints: rigid-body motions are not restrained "
                                         r"\(translation along x; translation along y; translation along z; "
                                         r"3 rotation\(s\).*static stiffness is singular"):
        load_control(model, n_steps=2)
    with pytest.raises(ModelError, match="static stiffness is singular"):
        arc_length(model)


def test_partial_supports_name_the_free_motions():
    # only the clamped edge's translations: the strip can still turn about that edge (the y axis)
    model = Model(body(), [Fix(MESH.node_set("clamped"), "translations")], [tip_force()])
    with pytest.raises(ModelError, match=r"constraints that leave it free to move: .*1 rotation\(s\) \(axes along "
                                         r"\[\[0\.0, 1\.0, 0\.0\]\]\)"):
        load_control(model, n_steps=1)
    # fixing z at the tip as well restrains it: the run proceeds
    model = Model(body(), [Fix(MESH.node_set("clamped"), "translations"), Fix(MESH.node_set("tip"), ("z",))],
                  [NodalLoad(MESH.node_set("tip"), force=(1.0, 0, 0))])
    assert model.unrestrained_rigid_modes() == []


def test_singular_matrix_is_reported_by_the_linear_solver():
    import scipy.sparse as sp
    with pytest.raises(SingularMatrixError, match="singular.*missing constraints"):
        LinearSolver().factorize(sp.csc_matrix(np.array([[1.0, 1.0], [1.0, 1.0]])))


def test_arc_length_without_load_is_refused():
    with pytest.raises(ValueError, match="arc-length needs a nonzero external load"):
        arc_length(clamped())


@pytest.mark.parametrize("factors", [[0.5, 0.2], [np.nan], [], [0.5, 0.5], [-1.0, 1.0]])
def test_bad_load_factors_are_refused(factors):
    with pytest.raises(ValueError, match="load factors must be finite, non-negative and increasing"):
        load_control(clamped([tip_force()]), factors)


# -- non-finite values during a run ------------------------------------------------------------------------------
def test_non_finite_load_stops_the_run_at_once():
    model = clamped([tip_force((0, 0, 10.0))])
    model.dead[25, 2] = np.nan        # corrupted after the checks (as a bug elsewhere would)
    result = load_control(model, n_steps=4)
    assert not result.converged and result.records == []
    assert result.failure.attempts == 1 and result.cutbacks == 1      # no cut-back cascade
    assert result.failure.non_finite
    assert "non-finite external load at node 25" in result.message
    assert "stopped at once" in result.message
    np.testing.assert_array_equal(result.state.x, MESH.nodes)         # the last converged state: the start


def test_non_finite_values_mid_run_stop_at_once_and_keep_the_steps_done():
    model = clamped([tip_force((0, 0, 0.3))])

    def corrupt(rec, state):
        if rec.step == 2:
            model.dead[25, 2] = np.inf

    result = load_control(model, n_steps=4, adaptive=False, on_step=corrupt)
    assert not result.converged
    assert [r.step for r in result.records] == [1, 2]
    assert result.failure.step == 3 and result.failure.attempts == 1
    assert result.load_factor == pytest.approx(0.5)
    assert "step 3 to load factor 0.75 failed (non-finite external load at node 25" in result.message
    assert np.all(np.isfinite(result.state.x))


def test_non_finite_element_forces_name_the_element(monkeypatch):
    model = clamped([tip_force()])
    f, K = model.body.element_forces(model.initial_state())
    f[3, 7] = np.nan
    monkeypatch.setattr(model.body, "element_forces", lambda state, want=True: (f, K))
    with pytest.raises(FloatingPointError, match=r"element 3 gives non-finite internal forces or tangent"):
        model.residual_and_tangent(model.initial_state(), 1.0)
    result = load_control(model, n_steps=2)
    assert not result.converged and "element 3 gives non-finite" in result.message and "at once" in result.message
