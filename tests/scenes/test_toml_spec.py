"""The table specs of the scene files: the docs' key tables are generated from them, ``--set`` takes its bare
keys from them, the reader allows exactly a variant's keys, and the specs agree with the code they feed."""

import inspect
from pathlib import Path

import pytest

from flexbody.scenes import toml_spec as spec
from flexbody.scenes.toml_document import resolve_key
from flexbody.scenes.toml_key_tables import GROUPS, regions, render, rewrite
from flexbody.scenes.toml_scene import SceneError, load_toml_scene

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "scenes.md"
PLATE = (REPO / "examples" / "clamped_plate.toml").read_text()


def test_the_key_tables_of_docs_scenes_md_are_those_of_the_specs():
    text = DOC.read_text(encoding="utf-8")
    assert sorted(regions(text)) == sorted(GROUPS)
    assert rewrite(text) == text, "docs/scenes.md lags the specs: run python tools/scene_key_tables.py"


def test_every_spec_is_in_a_generated_table():
    shown = {id(table) for group in GROUPS for table in GROUPS[group]()}
    paths = {table.path for group in GROUPS for table in GROUPS[group]()}
    assert {t.path for t in spec.all_specs()} <= paths
    assert all(id(t) in shown for t in spec.all_specs() if t.path not in ("analysis.newton", "analysis.integrator"))


def test_the_check_mode_fails_on_a_stale_copy(tmp_path):
    import importlib.util
    tool = importlib.util.spec_from_file_location("scene_key_tables", REPO / "tools" / "scene_key_tables.py")
    module = importlib.util.module_from_spec(tool)
    tool.loader.exec_module(module)
    stale = tmp_path / "scenes.md"
    stale.write_text(DOC.read_text(encoding="utf-8").replace("| `thickness` |", "| `thick` |", 1), encoding="utf-8")
    assert module.main(["--check", "--doc", str(stale)]) == 1
    assert module.main(["--doc", str(stale)]) == 0
    assert stale.read_text(encoding="utf-8") == DOC.read_text(encoding="utf-8")
    assert module.main(["--check", "--doc", str(stale)]) == 0


def test_a_region_naming_no_group_is_an_error():
    with pytest.raises(ValueError, match="names no table group"):
        rewrite("<!-- generated: scene keys nothing -->\n<!-- end generated -->\n")
    with pytest.raises(ValueError, match="has no"):
        rewrite("<!-- generated: scene keys static -->\n")


def test_every_table_renders_a_row_per_key():
    text = render("static") + render("dynamic")
    for key in spec.MATERIAL.keys + spec.DYNAMIC.keys + spec.LOAD.keys:
        assert key.kind == "selection" or f"`{key.name}`" in text


def test_set_takes_its_bare_keys_from_the_specs():
    doc = {"mesh": {"generator": "strip", "nx": 2}, "material": {"young": 1.0}}
    for table in spec.SET_BY_NAME:
        for key in table.keys:
            if key.kind in ("table", "tables", "selection") or key.name == "type":
                with pytest.raises(SceneError, match="unknown parameter"):
                    resolve_key(doc, key.name, "here")
            else:
                assert resolve_key(doc, key.name, "here") == f"{table.path}.{key.name}"
    assert resolve_key(doc, "width", "here") == "mesh.width"       # the generator's parameters


def test_the_arc_length_keys_are_the_integrators_options_with_their_defaults():
    from integrators.static import ARC_LENGTH_OPTIONS, arc_length
    assert spec.ARC_LENGTH_KEYS == ARC_LENGTH_OPTIONS
    defaults = inspect.signature(arc_length).parameters
    for name in ARC_LENGTH_OPTIONS:
        assert float(spec.ANALYSIS[name].shown) == defaults[name].default
    assert spec.ANALYSIS["arc_increment"].default == defaults["initial_increment"].default


def test_the_settings_tables_are_the_dataclass_fields():
    from dataclasses import fields

    from integrators.generalized_alpha import AlphaSettings
    from integrators.newton import NewtonSettings
    assert spec.newton_spec().names() == tuple(f.name for f in fields(NewtonSettings))
    assert spec.integrator_spec().names() == tuple(f.name for f in fields(AlphaSettings)
                                                   if f.name not in ("rho_inf", "policy", "adaptive"))
    assert not set(spec.integrator_spec().names()) & set(spec.DYNAMIC.names())


def test_the_element_and_pulse_choices_are_the_codes():
    from flexbody.shell.variants import VARIANT_KEYS
    from flexbody.time_functions import Pulse
    assert spec.ELEMENT["tying"].choices == VARIANT_KEYS
    assert spec.TIME_FUNCTION["shape"].choices == Pulse.SHAPES


@pytest.mark.parametrize("kind, keys", [
    ("fix", "type, set, nodes, near, plane, ring, components"),
    ("symmetry", "type, set, nodes, near, plane, ring, normal"),
])
def test_an_unknown_key_lists_the_keys_of_the_tables_variant(tmp_path, kind, keys):
    path = tmp_path / "plate.toml"
    text = PLATE.replace('[[bc]]\n', '[[bc]]\ncolour = 1\n', 1)
    if kind == "symmetry":
        text = text.replace('type = "fix"', 'type = "symmetry"\nnormal = [1, 0, 0]', 1)
    path.write_text(text)
    with pytest.raises(SceneError, match=f"unknown key 'bc.0.colour'; keys allowed in \\[bc.0\\]: {keys}$"):
        load_toml_scene(path)


def test_a_ramp_time_function_builds(tmp_path):
    """``time_function = { type = "ramp", time = T }`` was refused ("unknown key ... time") before the specs."""
    text = (REPO / "examples" / "spinning_membrane.toml").read_text()
    path = tmp_path / "ramp.toml"
    csv = "spinning_membrane_reference.csv"
    (tmp_path / csv).write_text((REPO / "examples" / csv).read_text())
    path.write_text(text + '\n[[load]]\ntype = "surface_force"\ndensity = [0, 0, 1]\n'
                           'time_function = { type = "ramp", time = 0.5 }\n')
    factor = load_toml_scene(path).analysis.load_factor
    assert factor(0.25)[1] == pytest.approx(0.5) and factor(1.0)[1] == 1.0
