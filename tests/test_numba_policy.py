"""The jit policy of flexbody._numba: the version guard, and that the private flags reach the compiled code."""

import numba
import numpy as np
import pytest

from flexbody import _numba


def test_installed_numba_is_in_the_tested_range_and_the_private_flags_are_active():
    assert _numba.version_warning(numba.__version__) is None
    assert _numba.NOALIAS and _numba.NO_NRT
    assert _numba.FAST_FLAGS["_noalias"] is True and _numba.FAST_FLAGS["_nrt"] is False


@pytest.mark.parametrize("version, outside", [("0.59.1", True), ("0.60.0", False), ("0.68.1", False),
                                              ("0.69.0rc1", True), ("1.0.0", True)])
def test_version_guard(version, outside):
    message = _numba.version_warning(version)
    assert (message is not None) == outside
    if outside:
        assert version in message


def _add_into(a, b, out):
    for i in range(out.shape[0]):
        out[i] = a[i] + b[i]
        _numba.prefetch(a, i, False)


def test_fast_kernels_have_noalias_arguments_and_prefetch():
    fast = numba.njit(**{**_numba.FAST_FLAGS, "cache": False})(_add_into)
    plain = numba.njit(cache=False)(_add_into)
    a, b, out = np.arange(4.0), np.ones(4), np.empty(4)
    for kernel in (fast, plain):
        kernel(a, b, out)
        np.testing.assert_array_equal(out, a + 1.0)
    ir_fast = next(iter(fast.inspect_llvm().values()))
    ir_plain = next(iter(plain.inspect_llvm().values()))
    assert "llvm.prefetch" in ir_fast
    # the three data pointers are declared noalias in the fast kernel only
    assert ir_fast.count("noalias") > ir_plain.count("noalias")
    assert "NRT_incref" not in ir_fast
