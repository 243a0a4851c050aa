"""The built-in scenes are registered once (flexbody.scenes.registry), with their metadata, and every tool
reads them from there."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

from flexbody.cli import main
from flexbody.cli.bench import default_bench_scenes
from flexbody.scenes import build, open_scene
from flexbody.scenes.builtin import BUILTIN, DYNAMIC
from flexbody.scenes.registry import SCENES, BuiltinScene, bench_scenes, builtin_scene, exudyn_scenes, names

REPO = Path(__file__).resolve().parents[2]

#: string literals naming a built-in scene outside the registry and the builders, and why they may
ALLOWED_LITERALS = {
    "flexbody/cli/parser.py": {"cantilever_end_moment"},   # DEFAULT_SCENE, read when the parser is built
    # the exudyn adapter's own model builders, one per scene with a plate model, and its membrane-in-exudyn run
    "flexbody/adapters/exudyn/references_static.py": {"slit_annular_plate", "pullout_cylinder", "hemisphere"},
    "flexbody/adapters/exudyn/ode2.py": {"spinning_membrane"},
}
BUILDERS = ("flexbody/scenes/registry.py", "flexbody/scenes/benchmark_scenes.py", "flexbody/scenes/dynamic_scenes.py")


def _small(entry: BuiltinScene) -> dict:
    """Distinct small values of the density parameters (so that their order shows)."""
    return {k: 4 + 2 * i for i, k in enumerate(entry.density)}


@pytest.mark.parametrize("name", list(SCENES))
def test_an_entry_builds_its_scene(name):
    entry = SCENES[name]
    assert entry.name == name and entry.builder.__name__ == name and entry.summary
    extra = dict(settle_time=0.0) if name == "tumbling_plate" else {}
    scene = entry.build(**_small(entry), **extra)
    assert scene.name == name and scene.kind == entry.kind
    assert {k: scene.parameters[k] for k in entry.density} == _small(entry)


@pytest.mark.parametrize("name", list(SCENES))
def test_density_parameters_are_integer_keywords_of_the_builder(name):
    """And they are the ones the rule for a user's ``build`` (integer keywords named n...) would find, as
    before the registry."""
    entry = SCENES[name]
    params = inspect.signature(entry.builder).parameters
    heuristic = tuple(k for k, p in params.items() if k.startswith("n") and isinstance(p.default, int)
                      and not isinstance(p.default, bool) and k != "n_sides")
    assert entry.density == heuristic
    assert open_scene(name).density == {k: params[k].default for k in entry.density}


def test_the_compatible_names_come_from_the_registry():
    assert list(BUILTIN) == list(SCENES) and all(BUILTIN[n] is SCENES[n].builder for n in SCENES)
    assert DYNAMIC == names("dynamic") == ("spinning_plate", "spinning_membrane", "spinning_sail",
                                           "tumbling_plate", "swinging_strip")
    assert names("static") == ("cantilever_end_moment", "cantilever_end_shear", "slit_annular_plate",
                               "pullout_cylinder", "hemisphere")
    assert list(default_bench_scenes()) == list(bench_scenes()) == [*names("static"), *names("dynamic")]
    assert exudyn_scenes("dynamic") == ("spinning_plate",)


def test_unknown_names_and_bad_entries_are_one_line():
    with pytest.raises(KeyError, match="unknown scene 'nope'; built-in scenes: cantilever_end_moment"):
        builtin_scene("nope")
    with pytest.raises(KeyError, match="unknown scene 'nope'"):
        build("nope")
    with pytest.raises(ValueError, match="kind must be 'static' or 'dynamic'"):
        BuiltinScene("x", "quasi-static", ("nx",))
    with pytest.raises(ValueError, match="bench meshes may set only the density parameters"):
        BuiltinScene("x", "static", ("nx",), (dict(nx=2, thickness=0.1),))


def test_list_shows_every_registered_scene(capsys):
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == list(SCENES)
    assert all(line.endswith(SCENES[line.split()[0]].summary) for line in lines)


def _scene_literals(path: Path) -> set[str]:
    """The string constants of a module that are built-in scene names (not counting ``__all__``, which names
    the builder functions a module exports)."""
    tree = ast.parse(path.read_text())
    exported = {id(sub) for node in ast.walk(tree) if isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets)
                for sub in ast.walk(node.value)}
    return {node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and node.value in SCENES and id(node) not in exported}


def test_no_other_module_spells_a_builtin_scene_name():
    found = {}
    for path in sorted((REPO / "flexbody").rglob("*.py")):
        rel = path.relative_to(REPO).as_posix()
        if rel in BUILDERS:
            continue
        extra = _scene_literals(path) - ALLOWED_LITERALS.get(rel, set())
        if extra:
            found[rel] = sorted(extra)
    assert not found, f"built-in scene names outside flexbody.scenes.registry: {found}"


def test_the_exudyn_adapter_reads_its_tables_from_the_registry():
    """The adapter's models, tolerances and meshes are the registry's (the values it had as its own tables)."""
    pytest.importorskip("exudyn")
    from flexbody.adapters.exudyn import options, references_static
    strip = ("beam3d", "beam2d", "plate")
    assert options.MODELS == {"cantilever_end_moment": strip, "cantilever_end_shear": strip,
                              "slit_annular_plate": ("plate",), "pullout_cylinder": ("plate",),
                              "hemisphere": ("plate",), "spinning_plate": ("plate",)}
    assert options.DYNAMIC_SCENES == ("spinning_plate",)
    assert {n: e.exudyn_rtol for n, e in SCENES.items() if e.exudyn_rtol is not None} == {
        "slit_annular_plate": 1e-6, "pullout_cylinder": 1e-6, "hemisphere": 1e-5}
    assert not hasattr(references_static, "_RTOL_SCENE")
    for name in exudyn_scenes():
        entry = SCENES[name]
        scene = entry.build(**_small(entry))
        nx, ny = (scene.parameters[k] for k in entry.exudyn_mesh)
        assert options._default_mesh(scene, "plate") == (nx, ny), name
        if "beam2d" in entry.exudyn_models:
            assert options._default_mesh(scene, "beam2d") == (2 * nx, 1), name
