"""TOML scene files: they build the model they describe, --set overrides, and every mistake is one line
naming the key and the value."""

from pathlib import Path

import numpy as np
import pytest

from flexbody.constraints import Fix, Symmetry
from flexbody.loads import FollowerPressure, NodalLoad
from flexbody.scenes.builtin import cantilever_end_shear
from flexbody.scenes.scene import run_scene
from flexbody.scenes.sources import open_scene
from flexbody.scenes.toml_scene import SceneError, apply_overrides, flatten, load_toml_scene, resolve_key
from flexbody.shell.variants import MITC6, MITC7, NoTying

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"

PLATE = """
name = "plate"
[mesh]
generator = "strip"
length = 2.0
width = 1.0
nx = 2
ny = 2
[material]
young = 1.0e6
poisson = 0.3
thickness = 0.02
[[bc]]
type = "fix"
set = "clamped"
[[bc]]
type = "symmetry"
plane = { point = [0.0, 0.5, 0.0], normal = [0.0, 1.0, 0.0] }
[[load]]
type = "nodal"
near = [2.0, 0.5, 0.0]
force = [0.0, 0.0, 1.0]
[[load]]
type = "pressure"
value = 2.0
[analysis]
steps = 2
[[output]]
name = "w_tip"
near = [2.0, 0.5, 0.0]
component = "z"
"""


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_the_example_reproduces_the_builtin_scene():
    toml = load_toml_scene(EXAMPLES / "cantilever_end_shear.toml", {"nx": 2, "steps": 3})
    builtin = cantilever_end_shear(nx=2, steps=3)
    assert toml.model.n_dof == builtin.model.n_dof
    np.testing.assert_array_equal(toml.model.body.mesh.nodes, builtin.model.body.mesh.nodes)
    np.testing.assert_allclose(toml.model.dead, builtin.model.dead, atol=1e-15)
    assert [o.node for o in toml.outputs] == [o.node for o in builtin.outputs]
    np.testing.assert_allclose(toml.reference.values["W_tip"], builtin.reference.values["W_tip"])
    a, b = run_scene(toml), run_scene(builtin)
    for name in ("minus_U_tip", "W_tip"):
        np.testing.assert_allclose(a.history[name], b.history[name], rtol=1e-12)
    assert a.max_rel_error == pytest.approx(b.max_rel_error, rel=1e-12) and a.max_rel_error < 0.2


def test_every_example_scene_file_builds():
    for path in sorted(EXAMPLES.glob("*.toml")):
        scene = open_scene(str(path)).build({})
        assert scene.model.n_dof > 0 and scene.outputs, path


def test_sections_become_the_model(tmp_path):
    scene = load_toml_scene(write(tmp_path, PLATE))
    model, mesh = scene.model, scene.model.body.mesh
    fix, sym = model.constraints
    assert isinstance(fix, Fix) and set(fix.nodes) == set(mesh.node_set("clamped"))
    assert isinstance(sym, Symmetry) and np.allclose(mesh.nodes[sym.nodes, 1], 0.5) and len(sym.nodes) == 5
    nodal, pressure = model.loads
    assert isinstance(nodal, NodalLoad) and nodal.nodes.tolist() == [mesh.nearest_node([2.0, 0.5, 0.0])]
    assert isinstance(pressure, FollowerPressure) and pressure.pressure == 2.0
    assert scene.analysis.load_factors == pytest.approx((0.5, 1.0))
    assert scene.outputs[0].direction == (0.0, 0.0, 1.0) and scene.name == "plate"
    assert scene.parameters["mesh.nx"] == 2 and scene.reference is None


def test_overrides_by_dotted_or_unambiguous_key(tmp_path):
    path = write(tmp_path, PLATE)
    scene = load_toml_scene(path, {"nx": 3, "material.thickness": 0.01, "load.1.value": 5.0,
                                   "analysis.newton.max_iterations": 7, "density": 1.0,
                                   "analysis.newton.mixed": False})
    assert scene.analysis.newton.mixed is False and load_toml_scene(path).analysis.newton.mixed is True
    assert scene.model.body.mesh.n_elements == 2 * 3 * 2
    assert scene.model.body.material.thickness == 0.01 and scene.model.body.material.density == 1.0
    assert scene.model.loads[1].pressure == 5.0 and scene.analysis.newton.max_iterations == 7
    doc = {"load": [{"value": 1.0}, {"value": 2.0}], "mesh": {"nx": 1}}
    assert resolve_key(doc, "nx", "f") == "mesh.nx"
    assert flatten(apply_overrides(doc, {"load.0.value": 3.0}, "f"))["load.0.value"] == 3.0
    with pytest.raises(SceneError, match="ambiguous; use one of load.0.value, load.1.value"):
        resolve_key(doc, "value", "f")


def test_mesh_from_a_file(tmp_path):
    pytest.importorskip("meshio")
    from flexbody.mesh import generators
    from flexbody.mesh.io import write_mesh
    write_mesh(generators.strip(2.0, 1.0, 2, 1), tmp_path / "strip.vtu")
    text = PLATE.replace('generator = "strip"\nlength = 2.0\nwidth = 1.0\nnx = 2\nny = 2',
                         'file = "strip.vtu"').replace('set = "clamped"',
                                                      'plane = { point = [0, 0, 0], normal = [1, 0, 0] }')
    scene = load_toml_scene(write(tmp_path, text))
    assert scene.model.body.mesh.n_elements == 4 and len(scene.model.constraints[0].nodes) == 3


def test_reference_csv_is_read_relative_to_the_scene_file(tmp_path):
    (tmp_path / "ref.csv").write_text("# my FE code\nlf,w\n0.5,0.1\n1.0,0.3\n")
    scene = load_toml_scene(write(tmp_path, PLATE + '[reference]\nfile = "ref.csv"\ncolumns = { w_tip = "w" }\n'))
    assert scene.reference.load_factors.tolist() == [0.5, 1.0] and scene.reference.source == "my FE code"
    assert scene.reference.values["w_tip"].tolist() == [0.1, 0.3]


@pytest.mark.parametrize("edit, message", [
    (("[material]", "[material]\ncolour = 1"), "unknown key 'material.colour'; keys allowed in [material]: young"),
    (("name = \"plate\"", "name = \"plate\"\n[solver]\nx = 1"), "unknown key 'solver'; keys allowed in the top level"),
    (("set = \"clamped\"", "set = \"left\""), "bc.0.set: unknown node set 'left'; this mesh has node sets"),
    (("nx = 2", "nx = 0"), "mesh (generator 'strip'): nx must be an integer >= 1, got 0"),
    (("nx = 2", "nx = 2\nangle = 1"), "unknown key 'mesh.angle'; keys allowed in [mesh]"),
    (("thickness = 0.02", "thickness = -1"), "material thickness must be > 0, got -1"),
    (("thickness = 0.02", "thickness = \"thin\""), "material.thickness must be a finite number, got 'thin'"),
    (("generator = \"strip\"", "generator = \"disk\""), "mesh.generator must be one of 'strip'"),
    (("type = \"fix\"", "type = \"glue\""), "bc.0.type must be one of 'fix', 'symmetry', got 'glue'"),
    (("type = \"fix\"\nset = \"clamped\"", "type = \"fix\"\nset = \"clamped\"\ncomponents = [\"q\"]"),
     "bc.0.components: unknown constraint component(s) ['q']"),
    (("force = [0.0, 0.0, 1.0]", "force = [0.0, 1.0]"), "load.0.force must be a list of three finite numbers"),
    (("value = 2.0", "value = 2.0\nside = 1"), "unknown key 'load.1.side'"),
    (("steps = 2", "steps = 2\nload_factors = [0.5, 1.0]"), "give analysis.steps or analysis.load_factors"),
    (("steps = 2", "method = \"newmark\""), "analysis.method must be one of 'load_control', 'arc_length'"),
    (("component = \"z\"", "component = \"w\""), "output.0.component must be one of 'x', 'y', 'z', got 'w'"),
    (("near = [2.0, 0.5, 0.0]\ncomponent", "set = \"tip\"\ncomponent"), "output.0.set must select one node, it selects 5"),
    (("[[output]]", "[[output]]\nnodes = [1]"), "[output.0] needs exactly one node selection of set, nodes, near, plane"),
    (("normal = [0.0, 1.0, 0.0] }", "normal = [0.0, 1.0, 0.0] }\n[analysis.newton]\npolicy = \"lazy\""),
     "Newton policy must be 'full' or 'modified', got 'lazy'"),
    (("normal = [0.0, 1.0, 0.0] }", "normal = [0.0, 1.0, 0.0] }\n[analysis.newton]\nmixed = 1"),
     "analysis.newton.mixed"),
    (("point = [0.0, 0.5, 0.0]", "point = [0.0, 0.7, 0.0]"), "bc.1.plane selects no nodes"),
    (("steps = 2", "steps = 2\n[reference]\nfile = \"missing.csv\""), "reference.file: reference CSV"),
    (("[[bc]]", "[element]\ntying = \"mitc9\"\n[[bc]]"),
     "element.tying must be one of 'mean', 'point', 'mitc7', got 'mitc9'"),
])
def test_mistakes_are_one_line_naming_the_key(tmp_path, edit, message):
    old, new = edit
    assert old in PLATE
    path = write(tmp_path, PLATE.replace(old, new, 1))
    with pytest.raises(SceneError) as exc:
        load_toml_scene(path)
    text = str(exc.value)
    assert message in text and "\n" not in text and text.startswith(f"scene file {str(path)!r}: ")


def test_bad_set_overrides(tmp_path):
    path = write(tmp_path, PLATE)
    with pytest.raises(SceneError, match="unknown parameter 'colour'; documented keys: "):
        load_toml_scene(path, {"colour": "red"})
    with pytest.raises(SceneError, match=r"load has no entry '5' \(2 entries"):
        load_toml_scene(path, {"load.5.value": 1.0})
    with pytest.raises(SceneError, match="mesh.nx must be an integer|nx must be an integer >= 1, got 'many'"):
        load_toml_scene(path, {"nx": "many"})


def test_invalid_toml_names_the_line(tmp_path):
    with pytest.raises(SceneError, match=r"is not valid TOML: .*line 2"):
        load_toml_scene(write(tmp_path, "[mesh]\ngenerator = \n"))


def test_arc_length_example_matches_the_builtin_model():
    from flexbody.scenes.builtin import pullout_cylinder
    toml = load_toml_scene(EXAMPLES / "pullout_cylinder.toml", {"n_circ": 3, "n_axial": 2})
    builtin = pullout_cylinder(n_circ=3, n_axial=2)
    a, b = toml.analysis, builtin.analysis
    assert (a.method, a.load_factors, a.arc_increment, a.max_load_increment, a.newton.rtol) == \
           (b.method, b.load_factors, b.arc_increment, b.max_load_increment, b.newton.rtol)
    assert toml.model.n_dof == builtin.model.n_dof
    np.testing.assert_array_equal(toml.model.fixed, builtin.model.fixed)  # the three symmetry planes
    np.testing.assert_allclose(toml.model.dead, builtin.model.dead)
    assert [o.node for o in toml.outputs] == [o.node for o in builtin.outputs]
    assert set(toml.reference.values) == {"W_A", "minus_U_B", "minus_U_C"}  # columns named like the outputs


@pytest.mark.parametrize("value, variant", [('"mitc7"', MITC7()), ('"point"', MITC6(membrane="point")),
                                            ('"mean"', MITC6()), ("true", MITC6()), ("false", NoTying())])
def test_element_variant_by_name(tmp_path, value, variant):
    scene = load_toml_scene(write(tmp_path, PLATE.replace("[[bc]]", f"[element]\ntying = {value}\n[[bc]]", 1)))
    assert scene.model.body.element == variant
