"""The public Python API (``import flexbody as fb``): cheap to import, every name resolves and is documented,
the one-line loads build what the TOML reader builds, and the solves give what the scene runner gives."""

import doctest
import inspect
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import flexbody as fb
from flexbody.mesh import MeshError
from flexbody.scenes.toml_scene import scene_from_document

#: modules that ``import flexbody`` must not import: the compiled kernels and the optional, heavy outputs
HEAVY = ("numba", "llvmlite", "scipy", "h5py", "rerun", "dask", "distributed", "meshio", "matplotlib",
         "flexbody.shell.kernels.loops", "flexbody.lie.kernels", "integrators")


def imported_after(code: str) -> set[str]:
    """The modules loaded in a fresh interpreter after running ``code``."""
    script = code + "\nimport sys\nprint('\\n'.join(sorted(sys.modules)))\n"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    return set(out.split())


def heavy(modules: set[str], names=HEAVY) -> list[str]:
    return sorted(m for m in modules if any(m == h or m.startswith(h + ".") for h in names))


def test_import_flexbody_is_cheap():
    modules = imported_after("import flexbody")
    assert heavy(modules) == []
    assert "flexbody" in modules


def test_the_whole_public_api_imports_no_output_or_cluster_module():
    modules = imported_after("import flexbody as fb\nfor name in fb.__all__: getattr(fb, name)")
    assert heavy(modules, ("h5py", "rerun", "dask", "distributed", "matplotlib", "flexbody.outputs",
                           "flexbody.cli", "flexbody.adapters")) == []
    assert "numba" in modules            # the body's kernels are loaded once the body is used


def test_every_public_name_resolves_and_is_documented():
    assert len(fb.__all__) == len(set(fb.__all__)) >= 40
    for name in fb.__all__:
        obj = getattr(fb, name)
        if name == "__version__":
            continue
        assert obj.__name__ == name, name
        doc = obj.__doc__ or ""
        assert len(doc) > 30 and not doc.startswith(name + "("), f"fb.{name} has no docstring of its own"
        if inspect.isclass(obj):                 # and its public methods and properties
            for member, value in vars(obj).items():
                function = value.fget if isinstance(value, property) else value
                if not member.startswith("_") and callable(function):
                    assert (function.__doc__ or "").strip(), f"fb.{name}.{member} has no docstring"
        if inspect.isfunction(obj):
            hints = {k for k in inspect.signature(obj).parameters if k not in ("self", "options", "overrides")}
            missing = [k for k in hints if inspect.signature(obj).parameters[k].annotation is inspect.Parameter.empty]
            assert not missing, f"fb.{name}: parameters without type hints: {missing}"
    assert set(fb.__all__) <= set(dir(fb))
    with pytest.raises(AttributeError, match="module 'flexbody' has no attribute 'no_such_name'"):
        fb.no_such_name


def test_the_examples_in_the_public_docstrings_run():
    finder, runner = doctest.DocTestFinder(recurse=False), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    ran = 0
    for name in fb.__all__[1:]:
        for test in finder.find(getattr(fb, name), name, globs={"fb": fb}):
            ran += len(test.examples)
            runner.run(test)
    assert ran >= 5 and runner.failures == 0, f"{runner.failures} docstring example(s) failed"


# -- loads and supports as one-liners ------------------------------------------------------------------------

PLATE = textwrap.dedent("""
    [mesh]
    generator = "strip"
    length = 2.0
    width = 1.0
    nx = 4
    ny = 2
    [material]
    young = 1.0e6
    poisson = 0.3
    thickness = 0.01
    [[bc]]
    type = "fix"
    set = "clamped"
    [[load]]
    type = "edge_force"
    set = ["tip", "top"]
    density = [0.0, 0.5, 2.0]
    [[load]]
    type = "edge_moment"
    set = "tip"
    density = [0.0, -1.0, 0.0]
    [[load]]
    type = "surface_force"
    density = [0.0, 0.0, -3.0]
    [[load]]
    type = "pressure"
    value = 7.0
    [[output]]
    name = "w"
    near = [2.0, 0.5, 0.0]
    component = "z"
    """)


def test_the_one_line_loads_build_what_the_toml_reader_builds(tmp_path):
    import tomllib
    scene = scene_from_document(tomllib.loads(PLATE), tmp_path / "plate.toml")
    mesh = scene.model.body.mesh
    loads = [*fb.edge_force(mesh, ["tip", "top"], [0.0, 0.5, 2.0]), *fb.edge_moment(mesh, "tip", [0.0, -1.0, 0.0]),
             *fb.surface_force(mesh, [0.0, 0.0, -3.0]), fb.pressure(mesh, 7.0)]
    model = fb.Model(fb.ShellBody(mesh, scene.model.body.material), [fb.clamp(mesh, "clamped")], loads)
    np.testing.assert_array_equal(model.dead, scene.model.dead)
    np.testing.assert_array_equal(model.fixed, scene.model.fixed)
    assert [p.pressure for p in model.pressures] == [p.pressure for p in scene.model.pressures] == [7.0]


def test_distributed_loads_sum_to_density_times_size():
    mesh = fb.strip(2.0, 1.0, 4, 2)
    forces = fb.edge_force(mesh, ["tip", "top"], [0.0, 0.0, 2.0])
    assert sum(load.force[2] for load in forces) == pytest.approx(2.0 * (1.0 + 2.0), rel=1e-13)
    assert all(len(load.nodes) == 1 for load in forces)
    moments = fb.edge_moment(mesh, mesh.edge_set("tip"), [0.0, 3.0, 0.0])
    assert sum(load.moment[1] for load in moments) == pytest.approx(3.0, rel=1e-13)
    weight = fb.surface_force(mesh, [0.0, 0.0, -1.5])
    assert sum(load.force[2] for load in weight) == pytest.approx(-1.5 * 2.0, rel=1e-13)


def test_bad_load_and_support_arguments_are_named():
    mesh = fb.strip(2.0, 1.0, 2, 1)
    with pytest.raises(MeshError, match="unknown edge set 'tipp'; this mesh has edge sets: bottom, clamped, tip, top"):
        fb.edge_force(mesh, "tipp", [0, 0, 1])
    with pytest.raises(ValueError, match="edge sets lists 'tip' twice"):
        fb.edge_force(mesh, ["tip", "tip"], [0, 0, 1])
    with pytest.raises(ValueError, match="edge force density must be a 3-vector"):
        fb.edge_force(mesh, "tip", [0, 1])
    with pytest.raises(ValueError, match="unknown element set 'skin'"):
        fb.pressure(mesh, 1.0, "skin")
    with pytest.raises(ValueError, match="pressure must be a finite number, got nan"):
        fb.pressure(mesh, float("nan"))
    with pytest.raises(ValueError, match=r"node 99 does not exist; the mesh has nodes 0..14"):
        fb.clamp(mesh, [0, 99])
    with pytest.raises(ValueError, match="unknown node set 'wall'"):
        fb.fix(mesh, "wall", "z")
    with pytest.raises(ValueError, match="unknown constraint component"):
        fb.fix(mesh, "clamped", "w")
    assert fb.fix(mesh, ["clamped", "tip"], ("x", "z")).nodes.tolist() == \
        sorted(set(mesh.node_set("clamped")) | set(mesh.node_set("tip")))


# -- the solves -----------------------------------------------------------------------------------------------

def cantilever(nx: int = 4):
    mesh = fb.strip(10.0, 1.0, nx, 1)
    body = fb.ShellBody(mesh, fb.ShellMaterial(young=1.2e6, poisson=0.0, thickness=0.1))
    return mesh, fb.Model(body, [fb.clamp(mesh, "clamped")], fb.edge_force(mesh, "tip", [0.0, 0.0, 4.0]))


def test_solve_static_gives_what_the_scene_runner_gives():
    mesh, model = cantilever()
    solution = fb.solve_static(model, steps=4)
    summary = fb.run_scene(fb.load_scene("cantilever_end_shear", nx=4, steps=4))
    tip = mesh.nearest_node([10.0, 0.5, 0.0])
    assert solution.converged and solution.message == "completed"
    np.testing.assert_array_equal(solution.load_factors, summary.history["load_factor"])
    assert [s.x[tip, 2] - mesh.nodes[tip, 2] for s in solution.states] == summary.history["W_tip"]
    assert solution.displacements()[tip, 2] == summary.history["W_tip"][-1]
    assert solution.stats.iterations == summary.result.stats.iterations
    assert solution.load_factor == 1.0 and len(solution.states) == 4
    assert solution.displacements()[tip, 2] == pytest.approx(6.698, rel=1e-2)   # Sze et al. at P = 4 (4 elements)


def test_solve_static_arguments_and_arc_length():
    mesh, model = cantilever(2)
    with pytest.raises(TypeError, match="model must be a flexbody Model"):
        fb.solve_static(mesh)
    with pytest.raises(ValueError, match="method must be 'load_control' or 'arc_length', got 'newton'"):
        fb.solve_static(model, method="newton")
    with pytest.raises(ValueError, match="steps must be an integer >= 1, got 0"):
        fb.solve_static(model, steps=0)
    with pytest.raises(ValueError, match="arc length chooses its own load factors"):
        fb.solve_static(model, [0.5, 1.0], method="arc_length")
    seen = []
    solution = fb.solve_static(model, method="arc_length", arc_increment=0.25, max_load_factor=0.5,
                               keep_states=False, check_stability=False, on_step=lambda rec, state: seen.append(rec))
    assert solution.converged and solution.load_factor == pytest.approx(0.5, abs=1e-12)
    assert solution.states == [] and len(seen) == len(solution.load_factors) >= 2


def test_solve_dynamic_gives_what_the_scene_runner_gives():
    from integrators.generalized_alpha import AlphaSettings
    scene = fb.load_scene("swinging_strip", nx=4, end_time=0.012)
    summary = fb.run_scene(scene)
    mesh = fb.strip(1.0, 0.1, 4, 1)
    model = fb.Model(fb.ShellBody(mesh, fb.ShellMaterial(2.1e11, 0.0, 0.01, density=7850.0)),
                     [fb.clamp(mesh, "clamped")])
    solution = fb.solve_dynamic(model, end_time=0.012, time_step=1.2e-3, gravity=(0.0, 0.0, -9.81),
                                settings=AlphaSettings(max_cutbacks=4))
    tip = mesh.nearest_node([1.0, 0.05, 0.0])
    assert solution.converged and solution.time == pytest.approx(0.012, rel=1e-12)
    np.testing.assert_allclose(solution.times, summary.history["time"], rtol=0, atol=1e-15)
    assert [s.x[tip, 2] for s in solution.states] == summary.history["w_tip"]
    energy = solution.energies()
    assert abs(energy["total"][0]) < 1e-12 * energy["kinetic"].max() and energy["kinetic"][-1] > 0
    assert abs(energy["total"][-1]) < 1e-3 * energy["kinetic"].max()        # gravity and the clamp do no work
    xdot, omega = solution.nodal_velocities()
    assert xdot.shape == omega.shape == (mesh.n_nodes, 3) and np.all(xdot[mesh.node_set("clamped")] == 0)


def test_solve_dynamic_arguments_are_named():
    mesh = fb.strip(10.0, 1.0, 2, 1)
    model = fb.Model(fb.ShellBody(mesh, fb.ShellMaterial(1.2e6, 0.0, 0.1, density=1.0)), [fb.clamp(mesh, "clamped")])
    with pytest.raises(ValueError, match="time_step must not exceed end_time"):
        fb.solve_dynamic(model, 0.1, 0.2)
    with pytest.raises(ValueError, match=r"velocity must be a finite array of shape \(15, 3\), got shape \(3,\)"):
        fb.solve_dynamic(model, 0.1, 0.01, velocity=[1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="rho_inf must lie in"):
        fb.solve_dynamic(model, 0.1, 0.01, rho_inf=2.0)


def test_load_scene_by_name():
    scene = fb.load_scene("cantilever_end_shear", nx=2, steps=1)
    assert isinstance(scene, fb.Scene) and scene.parameters["nx"] == 2
    with pytest.raises(fb.SceneError, match="unknown scene 'no_such_scene'"):
        fb.load_scene("no_such_scene")
    with pytest.raises(fb.SceneError, match="unknown parameter"):
        fb.load_scene("cantilever_end_shear", nz=3)
    with pytest.raises(fb.SceneError, match="scene must be a built-in scene name or a scene file path"):
        fb.load_scene(3)


def test_the_api_adds_nothing_to_the_kernel_cache_digest():
    """The numba cache's digest follows the import statements of the kernel modules, flexbody/__init__.py
    included: the public names must not be imported there (an edit of any API module would recompile)."""
    from flexbody.kernel_cache import PACKAGE, kernel_sources
    sources = {p.relative_to(PACKAGE).as_posix() for p in kernel_sources()}
    assert "__init__.py" in sources
    assert not sources & {"solve.py", "assembly.py", "loads.py", "constraints.py", "results.py", "dynamics.py",
                          "scenes/scene.py", "scenes/sources.py", "mesh/io.py"}, sorted(sources)


def test_the_type_stub_names_every_public_name():
    import ast
    from pathlib import Path
    stub = ast.parse((Path(fb.__file__).with_suffix(".pyi")).read_text())
    names = {alias.asname for node in stub.body if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert names - {None} == set(fb.__all__) - {"__version__"}
    for node in stub.body:
        if isinstance(node, ast.ImportFrom) and node.module != "typing":
            assert fb._PUBLIC[node.names[0].asname] == node.module
