"""Hostile inputs that used to give a wrong answer with exit code 0, or a traceback (issue #14).

Grouped by family: disconnected pieces, overflowing vectors, keys that do nothing or count twice, loads on
supported nodes, tracebacks. The command-line cases run ``flexbody run`` on a scene written to tmp_path and
check for a non-zero exit, one stderr line naming the value and no traceback.
"""

import os
from pathlib import Path
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from flexbody.assembly import Model, ModelError
from flexbody.body import ShellBody
from flexbody.constraints import Fix, Symmetry
from flexbody.frames import unit_vector
from flexbody.loads import NodalLoad, nodal_vectors_from_edges
from flexbody.mesh import generators
from flexbody.mesh.tri6 import Tri6Mesh
from flexbody.scenes.reference import parse_csv
from flexbody.scenes.toml_scene import SceneError, load_toml_scene
from flexbody.shell.material import ShellMaterial
from integrators.static import load_control

REPO = Path(__file__).resolve().parents[1]
MESH = generators.strip(10.0, 1.0, 4, 1)
MAT = ShellMaterial(1.2e6, 0.0, 0.1)


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``flexbody`` in a fresh interpreter (imports flexbody from this checkout)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "flexbody.cli", *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd, env=env)


def refused(out: subprocess.CompletedProcess, *fragments: str) -> str:
    """The one stderr line of a refused run, checked to name every fragment."""
    assert out.returncode != 0 and "Traceback" not in out.stderr, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


STRIP_TOML = """
[mesh]
generator = "strip"
length = 10.0
width = 1.0
nx = 2
ny = 1

[material]
young = 1.2e6
poisson = 0.0
thickness = 0.1

[[bc]]
type = "fix"
set = "clamped"

[[load]]
type = "edge_force"
set = "tip"
density = [0.0, 0.0, 1.0]

[analysis]
steps = 2

[[output]]
name = "W_tip"
near = [10.0, 0.5, 0.0]
component = "z"
"""


def strip_scene(tmp_path, text: str = STRIP_TOML, name: str = "strip.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ----------------------------------------------------------------------------------------------------------
# Disconnected pieces
# ----------------------------------------------------------------------------------------------------------

def two_strips(gap: float = 5.0) -> Tri6Mesh:
    """Two copies of the 4 x 1 strip side by side (not touching); only the first one's 'clamped' set."""
    n = MESH.n_nodes
    return Tri6Mesh(np.vstack([MESH.nodes, MESH.nodes + [0.0, gap, 0.0]]),
                    np.vstack([MESH.elements, MESH.elements + n]), np.vstack([MESH.directors] * 2),
                    {"clamped": MESH.node_set("clamped"), "clamped_2": MESH.node_set("clamped") + n,
                     "tips": np.concatenate([MESH.node_set("tip"), MESH.node_set("tip") + n])})


def test_connected_components_label_the_pieces():
    assert MESH.connected_components()[0] == 1
    count, labels = two_strips().connected_components()
    assert count == 2
    np.testing.assert_array_equal(labels, np.repeat([0, 1], MESH.n_nodes))


def test_a_slit_mesh_is_one_piece():
    # coincident but distinct nodes on the two lips of the slit: still one piece (joined around the annulus)
    assert generators.slit_annulus(6.0, 10.0, 2, 8).connected_components()[0] == 1


def test_an_unsupported_piece_is_named_before_the_first_step():
    mesh = two_strips()
    model = Model(ShellBody(mesh, MAT), [Fix(mesh.node_set("clamped"))],
                  [NodalLoad(mesh.node_set("tips"), force=(0, 0, 1.0))])
    with pytest.raises(ModelError, match=r"the mesh has 2 separate pieces, and piece 2 \(27 nodes, e\.g\. node 27\) "
                                         r"has no supports: rigid-body motions are not restrained \(translation "
                                         r"along x.*static stiffness is singular"):
        model.check_static_support()
    supported = Model(ShellBody(mesh, MAT), [Fix(mesh.node_set("clamped")), Fix(mesh.node_set("clamped_2"))],
                      [NodalLoad(mesh.node_set("tips"), force=(0, 0, 1.0))])
    supported.check_static_support()


TWO_PIECES_PY = """
import numpy as np
from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.constraints import Fix
from flexbody.loads import NodalLoad
from flexbody.mesh import generators
from flexbody.mesh.tri6 import Tri6Mesh
from flexbody.scenes import Output, Scene, StaticAnalysis
from flexbody.shell.material import ShellMaterial


def build(steps: int = 2):
    m = generators.strip(10.0, 1.0, 2, 1)
    n = m.n_nodes
    mesh = Tri6Mesh(np.vstack([m.nodes, m.nodes + [0.0, 5.0, 0.0]]), np.vstack([m.elements, m.elements + n]),
                    np.vstack([m.directors] * 2))
    tips = np.concatenate([m.node_set("tip"), m.node_set("tip") + n])
    model = Model(ShellBody(mesh, ShellMaterial(1.2e6, 0.0, 0.1)), [Fix(m.node_set("clamped"))],
                  [NodalLoad(tips, force=(0.0, 0.0, 0.1))])
    return Scene("two_strips", "two strips, one clamped", model,
                 StaticAnalysis("load_control", tuple(np.linspace(0, 1, steps + 1)[1:])),
                 [Output("w", int(tips[0]), (0.0, 0.0, 1.0))])
"""


def test_cli_two_pieces_one_supported_is_refused_before_the_run(tmp_path):
    (tmp_path / "two.py").write_text(TWO_PIECES_PY)
    line = refused(run_cli(["run", "two.py"], tmp_path))
    assert line.startswith("flexbody: the mesh has 2 separate pieces, and piece 2 (15 nodes, e.g. node 15) has no "
                           "supports: rigid-body motions are not restrained (translation along x")


def test_cli_notes_a_mesh_of_several_pieces(tmp_path):
    both = '[Fix(m.node_set("clamped")), Fix(m.node_set("clamped") + n)]'
    (tmp_path / "two.py").write_text(TWO_PIECES_PY.replace('[Fix(m.node_set("clamped"))]', both))
    out = run_cli(["run", "two.py", "--quiet"], tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stderr == "note: the mesh of two_strips has 2 separate pieces (nodes per piece: 15, 15)\n"


# ----------------------------------------------------------------------------------------------------------
# Overflowing vectors
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("vector, unit", [
    ([1e300, 0, 0], [1, 0, 0]), ([0, -1e308, 1e308], [0, -2**-0.5, 2**-0.5]), ([1e-320, 0, 0], [1, 0, 0]),
    ([3.0, 4.0, 0], [0.6, 0.8, 0]),
])
def test_unit_vector_neither_overflows_nor_underflows(vector, unit):
    np.testing.assert_allclose(unit_vector(vector, "normal"), unit, rtol=1e-15, atol=1e-16)


@pytest.mark.parametrize("vector", [[0, 0, 0], [np.nan, 0, 1], [np.inf, 0, 0], [1, 0], "up", None])
def test_unit_vector_refuses_zero_and_non_finite_vectors(vector):
    with pytest.raises(ValueError, match=r"plane normal must be a finite nonzero 3-vector, got "):
        unit_vector(vector, "plane normal")


def test_huge_plane_normal_selects_the_plane(tmp_path):
    small = load_toml_scene(strip_scene(tmp_path, STRIP_TOML.replace(
        'set = "clamped"', 'plane = { point = [0, 0, 0], normal = [1.0, 0, 0] }')))
    huge = load_toml_scene(strip_scene(tmp_path, STRIP_TOML.replace(
        'set = "clamped"', 'plane = { point = [0, 0, 0], normal = [1e300, 0, 0] }')))
    assert huge.model.n_dof == small.model.n_dof == 5 * (15 - 3)
    np.testing.assert_array_equal(huge.model.fixed, small.model.fixed)


def test_huge_symmetry_normal_and_output_direction_are_normalised():
    huge = Model(ShellBody(MESH, MAT), [Fix(MESH.node_set("clamped")), Symmetry(MESH.node_set("bottom"),
                                                                                 (0, 1e300, 0))])
    unit = Model(ShellBody(MESH, MAT), [Fix(MESH.node_set("clamped")), Symmetry(MESH.node_set("bottom"), (0, 1, 0))])
    assert huge.n_dof == unit.n_dof < Model(ShellBody(MESH, MAT), [Fix(MESH.node_set("clamped"))]).n_dof
    np.testing.assert_array_equal(huge.body.frames0, unit.body.frames0)
    from flexbody.scenes import Output
    assert Output("w", 3, (0, 0, 1e300)).direction == (0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"output 'w' direction must be a finite nonzero 3-vector, got \(0, 0, 0\)"):
        Output("w", 3, (0, 0, 0))


def test_huge_output_direction_in_a_toml_scene(tmp_path):
    scene = load_toml_scene(strip_scene(tmp_path, STRIP_TOML.replace('component = "z"', "direction = [0, 0, 1e300]")))
    assert scene.outputs[0].direction == (0.0, 0.0, 1.0)


def test_a_model_with_no_free_dof_is_refused():
    with pytest.raises(ModelError, match=r"the constraints fix every DoF of the body's 27 nodes: nothing is left"):
        Model(ShellBody(MESH, MAT), [Fix(np.arange(MESH.n_nodes))])


def test_cli_plane_selecting_every_node_is_refused(tmp_path):
    scene = strip_scene(tmp_path, STRIP_TOML.replace('set = "clamped"',
                                                     'plane = { point = [0, 0, 0], normal = [0, 0, 1e300] }'))
    refused(run_cli(["run", scene.name], tmp_path), "the constraints fix every DoF of the body's 15 nodes")


# ----------------------------------------------------------------------------------------------------------
# Keys that do nothing or count twice
# ----------------------------------------------------------------------------------------------------------

def test_max_load_factor_with_load_factors_is_refused(tmp_path):
    scene = strip_scene(tmp_path, STRIP_TOML.replace("steps = 2", "load_factors = [0.5, 1.0]\nmax_load_factor = 2.0"))
    with pytest.raises(SceneError, match=r"give analysis.max_load_factor or analysis.load_factors, not both"):
        load_toml_scene(scene)
    refused(run_cli(["run", scene.name], tmp_path), "analysis.max_load_factor or analysis.load_factors, not both")


def test_a_set_listed_twice_in_a_load_is_refused(tmp_path):
    scene = strip_scene(tmp_path, STRIP_TOML.replace('set = "tip"', 'set = ["tip", "tip"]'))
    refused(run_cli(["run", scene.name], tmp_path), "load.0.set lists 'tip' twice")
    scene = strip_scene(tmp_path, STRIP_TOML.replace('set = "clamped"', 'set = ["clamped", "top", "clamped"]'))
    with pytest.raises(SceneError, match=r"bc.0.set lists 'clamped' twice"):
        load_toml_scene(scene)


def test_overlapping_edge_sets_load_each_edge_once(tmp_path):
    from flexbody.loads import edges_of           # what the TOML edge loads use (moved from toml_scene._edges)
    mesh = MESH.with_sets(edge_sets={"tip_reversed": MESH.edge_set("tip")[::-1, ::-1],
                                     "tip_and_top": np.vstack([MESH.edge_set("tip"), MESH.edge_set("top")])})
    edges = edges_of(mesh, ["tip_reversed", "tip_and_top"])
    assert len(edges) == len(MESH.edge_set("tip")) + len(MESH.edge_set("top"))
    density = np.array([0.0, 0.0, 1.0])
    union = nodal_vectors_from_edges(mesh.nodes, edges, density, mesh.n_nodes)
    once = nodal_vectors_from_edges(mesh.nodes, mesh.edge_set("tip_and_top"), density, mesh.n_nodes)
    np.testing.assert_allclose(union, once, rtol=1e-14)
    assert union[:, 2].sum() == pytest.approx(1.0 + 10.0)       # width + length: each edge once


@pytest.mark.parametrize("text, message", [
    ("load_factor,w\n0.5,nan\n1.0,2.0\n", "line 2, column 'w': 'nan' is not a finite number"),
    ("load_factor,w\n0.5,1.0\ninf,2.0\n", "line 3, column 'load_factor': 'inf' is not a finite number"),
    ("load_factor,w,w\n0.5,1.0,1.0\n", "line 1: the header names column 'w' twice"),
    ("load_factor,,w\n0.5,1.0,1.0\n", "line 1: the header has an empty column name"),
])
def test_bad_reference_csv_cells_and_headers_are_refused(text, message):
    with pytest.raises(ValueError, match=f"reference CSV 'ref.csv' {message}"):
        parse_csv(text, "ref.csv")


def test_cli_nan_in_the_reference_csv_is_refused(tmp_path):
    (tmp_path / "ref.csv").write_text("load_factor,W_tip\n0.5,-nan\n1.0,2.0\n")
    scene = strip_scene(tmp_path, STRIP_TOML + '\n[reference]\nfile = "ref.csv"\n')
    refused(run_cli(["run", scene.name], tmp_path), "reference.file", "column 'W_tip': '-nan' is not a finite number")


# ----------------------------------------------------------------------------------------------------------
# Loads on supported nodes: the supports carry their part
# ----------------------------------------------------------------------------------------------------------

def edge_loads(edge_set: str, drop=()) -> list:
    vectors = nodal_vectors_from_edges(MESH.nodes, MESH.edge_set(edge_set), np.array([0.0, 0.3, 0.02]),
                                       MESH.n_nodes)
    vectors[list(drop)] = 0.0
    return [NodalLoad([i], force=vectors[i]) for i in np.flatnonzero(np.any(vectors != 0, axis=1))]


def test_a_distributed_load_over_supported_nodes_goes_partly_to_the_support():
    clamped = MESH.node_set("clamped")
    assert np.intersect1d(np.unique(MESH.edge_set("bottom")), clamped).size == 1   # the edge starts at the support
    supports = [Fix(clamped), Fix(MESH.node_set("tip"), ("y",))]                  # the tip is held in y as well
    full = Model(ShellBody(MESH, MAT), supports, edge_loads("bottom"))
    held = np.concatenate([clamped, MESH.node_set("tip")])
    free_part = Model(ShellBody(MESH, MAT), supports, edge_loads("bottom", drop=clamped))
    state = full.initial_state()
    np.testing.assert_array_equal(full.external_force(state), free_part.external_force(state))
    assert np.any(full.dead[held] != free_part.dead[held])          # the dropped part really was there
    a, b = load_control(full, n_steps=2), load_control(free_part, n_steps=2)
    assert a.converged and b.converged
    np.testing.assert_allclose(a.state.x, b.state.x, rtol=0, atol=1e-12 * 10.0)
    assert np.abs(a.state.x - MESH.nodes).max() > 1e-3             # and the structure did move


def test_cli_edge_load_over_the_support_runs(tmp_path):
    scene = strip_scene(tmp_path, STRIP_TOML.replace('set = "tip"', 'set = ["tip", "bottom"]'))
    out = run_cli(["run", scene.name, "--quiet"], tmp_path)
    assert out.returncode == 0 and out.stderr == "", out.stderr
    assert "output           W_tip = " in out.stdout


# ----------------------------------------------------------------------------------------------------------
# Tracebacks
# ----------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("value, shown", [("10000000000", "10000000000"), ("2.5", "2.5"), ("0", "0")])
def test_cli_absurd_steps_in_a_toml_scene(tmp_path, value, shown):
    scene = strip_scene(tmp_path, STRIP_TOML.replace("steps = 2", f"steps = {value}"))
    refused(run_cli(["run", scene.name], tmp_path), "analysis.steps must be an integer", f"got {shown}")


@pytest.mark.parametrize("value, shown", [("1e10", "10000000000.0"), ("10000000000", "10000000000"),
                                          ("2.5", "2.5"), ("-3", "-3")])
def test_cli_absurd_steps_for_a_builtin_scene(tmp_path, value, shown):
    refused(run_cli(["run", "cantilever_end_shear", "--set", f"steps={value}"], tmp_path),
            "scene 'cantilever_end_shear': steps must be an integer in 1..100000", f"got {shown}")


@pytest.mark.parametrize("body, message", [
    ("return 1 / 0", "cannot build scene 's.py': build() raised ZeroDivisionError: division by zero"),
    ("raise RuntimeError('no licence')", "build() raised RuntimeError: no licence"),
    ("import numpy; return numpy.linalg.inv(numpy.zeros((2, 2)))", "build() raised LinAlgError: Singular matrix"),
    ("return None", "cannot build scene 's.py': build() returned None, expected a Scene"),
    ("return {'name': 'x'}", "build() returned {'name': 'x'}, expected a Scene"),
])
def test_cli_python_build_failures_are_one_line(tmp_path, body, message):
    (tmp_path / "s.py").write_text(f"def build(steps: int = 2):\n    {body}\n")
    refused(run_cli(["run", "s.py"], tmp_path), message)


def test_cli_output_naming_a_missing_node_is_refused_at_build(tmp_path):
    text = TWO_PIECES_PY.replace('Output("w", int(tips[0])', 'Output("w", 999')
    (tmp_path / "s.py").write_text(text)
    out = run_cli(["run", "s.py"], tmp_path)
    refused(out, "build() raised ValueError: output 'w' names node 999, but the mesh has nodes 0..29")


def test_outputs_naming_missing_nodes_fail_when_the_scene_is_made():
    from flexbody.scenes import Output, Scene, StaticAnalysis
    from flexbody.scenes.scene import RadialDisplacement
    model = Model(ShellBody(MESH, MAT), [Fix(MESH.node_set("clamped"))], [NodalLoad([25], force=(0, 0, 1.0))])
    with pytest.raises(ValueError, match=r"output 'r' names node 27, but the mesh has nodes 0\.\.26"):
        Scene("s", "", model, StaticAnalysis(), [Output("w", 25, (0, 0, 1)), RadialDisplacement("r", (3, 27))])
    with pytest.raises(ValueError, match=r"output 'w' node must be a node index, got 2\.5"):
        Output("w", 2.5, (0, 0, 1))


KERNEL_CALLS = {
    "update_frames_into": ("from flexbody.lie.kernels import update_frames_into as f; import numpy as np; "
                           "f(np.tile(np.eye(3), (200000, 1, 1)), np.zeros((1, 2)), np.zeros((1, 3, 3)))",
                           "ValueError: dtheta must have shape (200000, 2), got (1, 2)"),
    "update_frames_into out": ("from flexbody.lie.kernels import update_frames_into as f; import numpy as np; "
                               "f(np.tile(np.eye(3), (200000, 1, 1)), np.zeros((200000, 2)), np.zeros((1, 3, 3)))",
                               "ValueError: out must be a writeable float64 array of shape (200000, 3, 3), got a "
                               "float64 array of shape (1, 3, 3)"),
    "scatter_blocks maps": ("from flexbody.scatter import scatter_blocks as f; import numpy as np; "
                            "f(np.ones((50000, 36, 36)), np.zeros((1, 6, 3, 3)), np.zeros((1, 6, 3, 3)), "
                            "np.zeros((50000, 36, 36), dtype=np.int64), 1.0, np.zeros(1))",
                            "ValueError: S must have shape (50000, 6, 3, 3), got (1, 6, 3, 3)"),
    "scatter_blocks slots": ("from flexbody.scatter import scatter_blocks as f; import numpy as np; "
                             "f(np.ones((1, 36, 36)), np.ones((1, 6, 3, 3)), np.ones((1, 6, 3, 3)), "
                             "np.full((1, 36, 36), 10**9, dtype=np.int64), 1.0, np.zeros(1))",
                             "IndexError: scatter_blocks: a slot lies beyond the output array"),
}


@pytest.mark.parametrize("case", list(KERNEL_CALLS))
def test_numba_entry_points_check_their_arrays(case):
    """Mismatched arrays handed to a public numba entry point: a ValueError, never a crash (a subprocess,
    so that the crash the checks prevent cannot take the test session down)."""
    code, message = KERNEL_CALLS[case]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 1, (out.returncode, out.stderr[-500:])
    assert out.stderr.strip().splitlines()[-1] == message


def test_absurd_time_step_counts_are_refused(tmp_path):
    from flexbody.scenes.scene import DynamicAnalysis
    with pytest.raises(ValueError, match=r"end_time / time_step asks for 1e\+12 time steps, at most 10000000"):
        DynamicAnalysis(1e-12, 1.0)           # used to hang in the list of output times
    DynamicAnalysis(1e-6, 10.0)               # 1e7 steps: allowed
    refused(run_cli(["run", "spinning_plate", "--set", "dt=1e-12"], tmp_path),
            "cannot build scene 'spinning_plate': end_time / time_step asks for")


def test_a_builtin_scene_error_is_not_quoted(tmp_path):
    line = refused(run_cli(["run", "cantilever_end_shear", "--set", "nx=0"], tmp_path))
    assert line == "flexbody: cannot build scene 'cantilever_end_shear': nx must be an integer >= 1, got 0", line


def test_a_near_point_far_from_the_mesh_is_refused(tmp_path):
    # [1e300, 0.5, 0]: every distance overflowed to inf and node 0 (at the clamp) "was nearest"; the tip is
    assert MESH.nearest_node([1e5, 0.5, 0.0]) == MESH.nearest_node([10.0, 0.5, 0.0])
    scene = strip_scene(tmp_path, STRIP_TOML.replace("near = [10.0, 0.5, 0.0]", "near = [1e300, 0.5, 0.0]"))
    refused(run_cli(["run", scene.name], tmp_path), "output.0.near", "point [1e+300, 0.5, 0.0] lies 1e+299 model "
            "sizes away from the mesh (at most 1e+06)")


def test_a_drilling_moment_alone_is_refused():
    # the moment about the director does no work on a 5-DoF node: alone it would move nothing
    with pytest.raises(ModelError, match=r"every load acts on constrained DoFs only \(node 25\).*a moment about a "
                                         "director does no work either"):
        Model(ShellBody(MESH, MAT), [Fix(MESH.node_set("clamped"))], [NodalLoad([25], moment=(0, 0, 1.0))])
