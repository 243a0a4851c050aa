"""Element variants as objects (flexbody.shell.variants): the scene keys, the deprecated ``tying`` keyword,
capabilities, maps built once, and the body dispatching through the variant."""

import copy
import dataclasses
import pickle
import warnings

import numpy as np
import pytest

from flexbody.assembly import Model
from flexbody.body import ShellBody
from flexbody.dynamics import DynamicModel
from flexbody.mesh import generators
from flexbody.shell import maps
from flexbody.shell.reference.material import assumed_strain_maps
from flexbody.shell.kernels.mitc7 import maps as mitc7_maps
from flexbody.shell.material import ShellMaterial
from flexbody.shell.variants import MITC6, MITC7, VARIANT_KEYS, ElementVariant, NoTying, variant_from_key
from tests.shell.test_element import deformed_state

VARIANTS = [MITC6(), MITC6(membrane="point"), NoTying(), MITC7()]
MESH = generators.strip(1.0, 0.6, 2, 1)
MATERIAL = ShellMaterial(2.0e5, 0.3, 0.02, density=7.8)


@pytest.mark.parametrize("key, variant", [(True, MITC6()), ("mean", MITC6()), ("point", MITC6(membrane="point")),
                                          (False, NoTying()), ("mitc7", MITC7()), (np.True_, MITC6())])
def test_scene_keys(key, variant):
    assert variant_from_key(key) == variant
    assert variant_from_key(variant) is variant
    assert variant_from_key(variant.key) == variant                        # the key round-trips


@pytest.mark.parametrize("bad", ["mitc9", "MITC7", None, 1, 0.0, "true"])
def test_bad_keys_fail_in_one_line_naming_the_value(bad):
    with pytest.raises(ValueError) as exc:
        variant_from_key(bad)
    message = str(exc.value)
    assert message == f"tying must be true, false or one of 'mean', 'point', 'mitc7', got {bad!r}"
    assert all(repr(k) in message for k in VARIANT_KEYS)


def test_bad_membrane_scheme():
    with pytest.raises(ValueError, match="MITC6 membrane must be one of 'mean', 'point', got 'middle'"):
        MITC6(membrane="middle")


def test_names_keys_and_capabilities():
    assert [v.name for v in VARIANTS] == ["MITC6", "MITC6 (point membrane tying)", "no tying", "MITC7"]
    assert [v.key for v in VARIANTS] == [True, "point", False, "mitc7"]
    assert all(isinstance(v, ElementVariant) for v in VARIANTS)
    for v in VARIANTS:
        mitc6_like = not isinstance(v, MITC7)
        assert v.supports_mixed_iteration == v.supports_stress_forces == v.supports_linearized_stresses == mitc6_like
        assert v.supports_wrinkling == mitc6_like
        assert v.condenses_bubble == (not mitc6_like)
    assert len({MITC6(), MITC6(membrane="mean")}) == 1 and MITC6() != NoTying()
    with pytest.raises(AttributeError):
        MITC6().membrane = "point"                                          # frozen


def test_maps_built_once_read_only_and_as_before():
    expected = [assumed_strain_maps("mean"), assumed_strain_maps("point"), assumed_strain_maps(None, None),
                assumed_strain_maps("mean", "mitc7")]
    for v, A in zip(VARIANTS, expected):
        np.testing.assert_array_equal(v.maps, A)
        assert v.maps is v.maps and v.compressed_maps is v.compressed_maps
        assert not v.maps.flags.writeable
    assert isinstance(MITC6().compressed_maps, maps.CompressedMaps)
    v = MITC6()
    assert maps.compress_maps(v.compressed_maps) is v.compressed_maps    # passed through, not re-hashed
    w = MITC7()
    assert isinstance(w.compressed_maps, mitc7_maps.MapNonzeros)
    assert mitc7_maps.as_map_nonzeros(w.compressed_maps) is w.compressed_maps
    for a, b in zip(w.compressed_maps, mitc7_maps.as_map_nonzeros(np.array(w.maps))):
        np.testing.assert_array_equal(a, b)


def test_variants_pickle():
    for v in VARIANTS:
        v.maps, v.compressed_maps                                          # cached on the object
        assert pickle.loads(pickle.dumps(v)) == v


@pytest.mark.parametrize("variant", VARIANTS, ids=repr)
def test_deprecated_tying_keyword_maps_to_the_variant(variant):
    with pytest.warns(DeprecationWarning, match="tying.*deprecated.*element="):
        old = ShellBody(MESH, MATERIAL, tying=variant.key)
    assert old.element == variant
    with pytest.warns(DeprecationWarning, match=r"ShellBody\(element=.*deprecated.*element="):
        positional = ShellBody(MESH, MATERIAL, variant.key)                # the old third positional argument
    assert positional.element == variant
    new = ShellBody(MESH, MATERIAL, element=variant)
    state = deformed_state(new, np.random.default_rng(2), amplitude=0.02, rot=0.2)
    f0, K0 = new.element_forces(state)
    f1, K1 = old.element_forces(state)
    np.testing.assert_array_equal(f0, f1)
    np.testing.assert_array_equal(K0, K1)
    assert new.element_name == variant.name


def test_the_new_keyword_does_not_warn_and_bad_values_fail_in_one_line():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ShellBody(MESH, MATERIAL, element=MITC7())
        ShellBody(MESH, MATERIAL)
    with pytest.raises(ValueError, match="tying must be true, false or one of 'mean', 'point', 'mitc7', got 'x'"):
        ShellBody(MESH, MATERIAL, tying="x")
    with pytest.raises(ValueError, match="element must be true, false or one of .* got 'mitc7 '"):
        ShellBody(MESH, MATERIAL, element="mitc7 ")                        # a (deprecated) scene key
    with pytest.raises(TypeError, match=r"element must be an element variant .*MITC7\(\), NoTying\(\)\), got 7"):
        ShellBody(MESH, MATERIAL, element=7)
    with pytest.raises(ValueError, match=r"give the element variant once: element=MITC7\(\) and tying='point'"):
        ShellBody(MESH, MATERIAL, element=MITC7(), tying="point")


def test_mitc7_says_what_it_does_not_provide():
    body = ShellBody(MESH, MATERIAL, element=MITC7())
    state = body.initial_state()
    for call, what in [(lambda: body.mixed_element_forces(state, np.zeros((4, 7, 8))), "the mixed Newton iteration"),
                       (lambda: body.stress_forces(state, np.zeros((4, 7, 8))), "forces of given stresses"),
                       (lambda: body.stresses(state), "linearized stresses")]:
        with pytest.raises(ValueError) as exc:
            call()
        assert str(exc.value).startswith(f"the MITC7 element (tying = 'mitc7') does not provide {what}")
        assert "\n" not in str(exc.value)


@pytest.mark.parametrize("variant", VARIANTS, ids=repr)
def test_dynamic_strain_energy_goes_through_the_variant(variant):
    """DynamicModel's energy (numba strains) and the body's (numpy element) agree; a stretched state has some."""
    body = ShellBody(MESH, MATERIAL, element=variant)
    state = deformed_state(body, np.random.default_rng(3), amplitude=0.02, rot=0.2)
    numpy_energy = body.strain_energy(state)
    assert numpy_energy > 0.0
    assert abs(DynamicModel(Model(body, [])).strain_energy(state) - numpy_energy) <= 1e-12 * numpy_energy
    assert body.strain_energy(body.initial_state(), strain_kernel="numba") < 1e-20 * numpy_energy
    with pytest.raises(ValueError, match="strain_kernel must be 'numba' or 'reference', got 'fast'"):
        body.strain_energy(state, strain_kernel="fast")


def test_bodies_copy_replace_and_pickle():
    body = ShellBody(MESH, MATERIAL, element=MITC7())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert dataclasses.replace(body, kernel="reference").element == MITC7()
    assert copy.deepcopy(body).element == MITC7()
    assert pickle.loads(pickle.dumps(body)).element_name == "MITC7"


def test_mitc7_bubbles_are_the_bodys_own():
    """The warm start lives on the body, not on the (shared, immutable) variant object."""
    shared = MITC7()
    a, b = ShellBody(MESH, MATERIAL, element=shared), ShellBody(MESH, MATERIAL, element=shared)
    a.element_forces(deformed_state(a, np.random.default_rng(4), amplitude=0.02, rot=0.2), want_tangent=False)
    assert np.any(a._element_state != 0.0) and not np.any(b._element_state)
