"""The jit policy of flexbody._numba: the version guard, and that the private flags reach the compiled code."""

import dis
import importlib
import inspect
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import numba
import numba.core.cpu
import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from flexbody import _numba, kernel_cache
from flexbody.lie import kernels as lie_kernels

ROOT = Path(__file__).resolve().parent.parent


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


# ------------------------------------------------------------------------------------------------------------
# One set of flags per dispatcher: the machine code (and every result bit) does not depend on which kernel was
# compiled first, nor on what the cache holds
# ------------------------------------------------------------------------------------------------------------

def _kernel_dispatchers() -> list:
    """Every numba dispatcher that flexbody's kernel modules define (kernel_cache.kernel_sources)."""
    found = []
    for path in kernel_cache.kernel_sources():
        parts = path.relative_to(kernel_cache.PACKAGE).with_suffix("").parts
        name = ".".join(("flexbody",) + (parts[:-1] if parts[-1] == "__init__" else parts))
        module = importlib.import_module(name)
        found += [value for value in vars(module).values()
                  if isinstance(value, CPUDispatcher) and value.py_func.__module__ == name]
    return found


def _called_dispatchers(dispatcher) -> set:
    """The dispatchers that the Python function of ``dispatcher`` names: globals, and attributes of modules
    (``lk.log_into``), read from its bytecode."""
    func = dispatcher.py_func
    found = set()
    codes = [func.__code__]
    while codes:
        code = codes.pop()
        codes += [c for c in code.co_consts if isinstance(c, types.CodeType)]
        instructions = list(dis.get_instructions(code))
        for i, instruction in enumerate(instructions):
            if instruction.opname != "LOAD_GLOBAL":
                continue
            value = func.__globals__.get(instruction.argval)
            for following in instructions[i + 1:]:
                if not (isinstance(value, types.ModuleType) and following.opname in ("LOAD_ATTR", "LOAD_METHOD")):
                    break
                value = getattr(value, following.argval, None)
            if isinstance(value, CPUDispatcher):
                found.add(value)
    return found


def _is_fast(dispatcher) -> bool:
    return dispatcher.targetoptions.get("error_model") == "numpy"


def test_the_flags_numba_passes_down_to_callees_are_those_every_kernel_sets():
    # numba 0.60-0.68: CPUTargetOptions.finalize takes these from the calling kernel when a callee leaves them
    # unset ("nrt" is the jit option "_nrt"); forceinline is inherited too, and set by no flexbody kernel
    source = inspect.getsource(numba.core.cpu.CPUTargetOptions.finalize)
    inherited = set(re.findall(r"inherit_if_not_set\(\s*[\"'](\w+)[\"']", source))
    assert inherited - {"forceinline"} == {name.lstrip("_") for name in _numba.INHERITED}
    dispatchers = _kernel_dispatchers()
    assert len(dispatchers) > 50
    for dispatcher in dispatchers:
        options = dispatcher.targetoptions
        assert set(_numba.INHERITED) <= set(options), f"{dispatcher.__qualname__} inherits its caller's flags"
        assert "forceinline" not in options


def test_the_fast_kernels_call_only_fast_helpers():
    """A helper that a fast kernel calls is compiled under the fast policy (``lie.kernels`` has fast twins of
    the plain helpers), or inlined; the plain twins stay plain."""
    dispatchers = _kernel_dispatchers()
    fast_calls = 0
    for caller in filter(_is_fast, dispatchers):
        for callee in _called_dispatchers(caller):
            assert _is_fast(callee), f"the fast {caller.__qualname__} calls the plain {callee.__qualname__}"
            fast_calls += 1
    assert fast_calls > 20
    assert not _is_fast(lie_kernels.coefficients) and _is_fast(lie_kernels.coefficients_fast)
    assert lie_kernels.coefficients_fast.py_func.__code__ is lie_kernels.coefficients.py_func.__code__


_COMPILE_IN_ORDER = """
import hashlib, sys
import numpy as np
from flexbody.lie import kernels as lk, so3
from flexbody.shell.kernels import points
rng = np.random.default_rng(1)
n = 300
frames = np.stack([so3.exp(v) for v in rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6, 0.3, size=(n, 1))])
dtheta = rng.normal(size=(n, 2)) * 10.0 ** rng.uniform(-6, 0.3, size=(n, 1))   # below and above the series switch
out = np.empty_like(frames)
Pd = rng.normal(size=(7, 3)) * 10.0 ** rng.uniform(-3, 0.3, size=(7, 1))
Pco = np.zeros((7, 9))
dn, Ti, ninv, M = np.zeros((6, 3)), np.zeros((6, 3, 3)), np.zeros((6, 2)), np.zeros((3, 3))


def plain(digest):                               # update_frames_into -> update_frame_into -> coefficients ...
    lk.update_frames_into(frames, dtheta, out)
    digest.update(out.tobytes())


def fast(digest):                                # element-kernel stages -> coefficients, log_into ...
    points._point_coefficients(np.arange(7), Pd, Pco)
    digest.update(Pco.tobytes())
    for e in range(0, n - 6, 6):
        points._node_setup(frames[e:e + 6], dn, Ti, ninv, M)
        digest.update(dn.tobytes() + Ti.tobytes() + ninv.tobytes())


digests = {}
for stage in sys.argv[1].split(","):
    digests[stage] = hashlib.sha256()
    {"plain": plain, "fast": fast}[stage](digests[stage])
print(" ".join(f"{stage}={digests[stage].hexdigest()[:16]}" for stage in sorted(digests)))
"""


def test_results_do_not_depend_on_the_compile_order_or_the_cache(tmp_path):
    """The SO(3) helpers that both plain code and the element kernels call, compiled first for one or the
    other, into an empty cache and then loaded from it: the same bits."""
    def run(cache: str, order: str) -> str:
        environ = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
        environ.update(XDG_CACHE_HOME=str(tmp_path / cache), NUMBA_NUM_THREADS="1",
                       PYTHONPATH=os.pathsep.join([str(ROOT), environ.get("PYTHONPATH", "")]))
        environ.pop("NUMBA_DISABLE_JIT", None)
        out = subprocess.run([sys.executable, "-c", _COMPILE_IN_ORDER, order], env=environ, capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip().splitlines()[-1]

    compiled = run("plain-first", "plain,fast")
    assert run("fast-first", "fast,plain") == compiled
    assert run("fast-first", "plain,fast") == compiled     # loaded from the cache the fast kernels filled first
    assert run("plain-first", "fast,plain") == compiled
