"""flexbody's one jit policy: the numba decorators of every kernel, and the only code that touches numba's
private API.

Decorators (all cached in :data:`flexbody.kernel_cache.CACHE_DIR` when it is usable):

- :data:`plain`: numba's defaults (reference counting, Python error model, no fastmath), set explicitly
  (:data:`PLAIN_FLAGS`, below). Kernels that allocate (workspaces, results) and the small SO(3)/SE(3)
  building blocks of :mod:`flexbody.lie.kernels` for plain callers.
- :data:`released`: :data:`plain` that releases the GIL (the sparse scatter, called from threads).
- :data:`fast`: the per-element and per-point kernels, which allocate nothing: :data:`FAST_FLAGS`, i.e.
  numpy's error model (a division by zero gives inf/nan, no exception check), FMA contraction allowed
  (results agree with the numpy reference to round-off), no reference counting (``_nrt=False``; otherwise
  every array argument costs an atomic incref/decref per call) and ``noalias`` array arguments (below).
- :data:`inline`: :data:`fast` inlined at numba-IR level into its callers (small helpers of the point loops).
- :data:`entry`: :data:`fast` without the GIL: the element loops over a chunk of elements, called from Python
  (:func:`flexbody.chunks.run_chunks` runs several chunks on threads). They replace numba's ``parallel=True``
  loops, whose parfor compilation cost a first run about 20 s of CPU (re-optimizing every inlined kernel once
  more) for the element kernels alone, and which one-thread runs (all the built-in scenes) never needed.
- :data:`parallel`: numba's defaults plus ``parallel=True`` (no flexbody kernel uses it now).
- :func:`prefetch`: an intrinsic that prefetches the cache line of one array element (a hint, never a fault).
- :data:`uint`: ``numba.uint64``, for unsigned inner-loop indices with run-time bounds (lets LLVM vectorize).
- :func:`twin`: a second dispatcher of one Python function under another policy (its callees re-bound to their
  twins), so that a helper called from kernels of both policies is compiled under each once, by one source.

One set of flags per dispatcher: numba compiles a callee the first time a caller's compilation needs it, and
a flag the callee leaves unset (``nrt``, ``fastmath``, ``error_model``: :data:`INHERITED`) is then taken from
that caller; the callee's machine code (cached, and linked into every later caller) would depend on which
caller was compiled first, hence on the compile order and the cache state. So every decorator here sets the
:data:`INHERITED` flags itself, and a helper that both :data:`fast` and :data:`plain` kernels call has a
:func:`twin` for each (``tests/test_numba_policy.py`` checks both).

``noalias``: numba has a compiler flag that declares the data pointers of array arguments ``noalias`` (its
parfors lowering sets it), but no jit option maps to it. This module adds that mapping (``_noalias``) to
numba's ``CPUTargetOptions``, once per process, when numba has the pieces; it changes nothing for functions
that do not ask for it. The contract of a :data:`fast` kernel: no two of its array arguments overlap
(workspaces are distinct arrays, inputs are only read). Without it LLVM must assume that every store may
change every array: it reloads values and guards vector loops with run-time overlap checks (the element
kernel is about 20 % slower).

Version guard: the private pieces (``CPUTargetOptions``, ``TargetOptions.Mapping``, ``Flags.noalias``,
``_nrt``, ``cgutils.get_or_insert_function``) are known to work for numba in :data:`TESTED_NUMBA`
(pyproject.toml pins the same range). With a numba outside it, importing this module warns once
(:func:`version_warning`); whatever private piece is missing is then dropped (:data:`NOALIAS`,
:data:`NO_NRT` say what is active), which keeps the results and costs speed. ``tests/test_numba_policy.py``
checks that the flags reach the compiled code.
"""

from __future__ import annotations

import types
import warnings

import llvmlite.binding
import numba
import numba.core.cgutils
import numba.core.compiler
import numba.core.cpu
import numba.core.options
import numba.extending
from llvmlite import ir

from flexbody.kernel_cache import CACHE

#: numba versions whose private API this module was checked against: [low, high)
TESTED_NUMBA = ((0, 60), (0, 69))


def _version_tuple(version: str) -> tuple[int, int]:
    """(major, minor) of a version string such as "0.68.1" or "0.69.0rc1"."""
    parts = []
    for piece in version.split(".")[:2]:
        digits = "".join(c for c in piece if c.isdigit()) or "0"
        parts.append(int(digits))
    return parts[0], parts[1] if len(parts) > 1 else 0


def version_warning(version: str) -> str | None:
    """The warning for a numba ``version`` outside :data:`TESTED_NUMBA` (None: inside)."""
    low, high = TESTED_NUMBA
    if low <= _version_tuple(version) < high:
        return None
    return (f"flexbody: numba {version} is outside the tested range {low[0]}.{low[1]} to <{high[0]}.{high[1]}; "
            f"the kernels' private compiler flags (noalias, no reference counting) are used only if present")


_message = version_warning(numba.__version__)
if _message is not None:
    warnings.warn(_message, RuntimeWarning, stacklevel=2)

#: ``_nrt=False`` is a jit option of this numba (the fast kernels then run without reference counting)
NO_NRT: bool = hasattr(numba.core.cpu.CPUTargetOptions, "_nrt")
#: the ``_noalias`` jit option is available (mapped here onto numba's ``noalias`` compiler flag)
NOALIAS: bool = hasattr(numba.core.compiler.Flags, "noalias") and hasattr(numba.core.options.TargetOptions,
                                                                         "Mapping")
if NOALIAS and not hasattr(numba.core.cpu.CPUTargetOptions, "_noalias"):
    numba.core.cpu.CPUTargetOptions._noalias = numba.core.options.TargetOptions.Mapping("noalias")

#: the flags that numba's ``CPUTargetOptions.finalize`` takes from the caller when a callee leaves them unset
#: (jit option names; ``forceinline`` too, which no flexbody kernel sets anywhere)
INHERITED = ("_nrt", "fastmath", "error_model") if NO_NRT else ("fastmath", "error_model")

#: the jit options of the kernels with numba's defaults, set explicitly (:data:`INHERITED`)
PLAIN_FLAGS: dict = dict(cache=CACHE, error_model="python", fastmath=False)
if NO_NRT:
    PLAIN_FLAGS["_nrt"] = True

#: the jit options of the allocation-free kernels (module docstring)
FAST_FLAGS: dict = dict(cache=CACHE, error_model="numpy", fastmath={"contract"})
if NO_NRT:
    FAST_FLAGS["_nrt"] = False
if NOALIAS:
    FAST_FLAGS["_noalias"] = True

plain = numba.njit(**PLAIN_FLAGS)
released = numba.njit(nogil=True, **PLAIN_FLAGS)
fast = numba.njit(**FAST_FLAGS)
inline = numba.njit(inline="always", **FAST_FLAGS)
entry = numba.njit(nogil=True, **FAST_FLAGS)
parallel = numba.njit(parallel=True, **PLAIN_FLAGS)
uint = numba.uint64


def twin(decorator, dispatcher, name: str, **callees):
    """``decorator`` (:data:`fast`, ...) applied to the Python function of ``dispatcher``, as ``name``.

    The function is copied with its globals, the names in ``callees`` re-bound (to the twins of the
    dispatchers it calls, so that they too are compiled under the twin's policy). ``name`` becomes its
    ``__name__`` and ``__qualname__``: numba names a function's cache files for its module, qualified name
    and first line, and the twin's machine code must not share them with the original's (numba's cache
    index does not tell the flags apart). The copy's globals are those of the module when ``twin`` is
    called: make the twin after everything its function refers to.
    """
    func = dispatcher.py_func
    namespace = dict(func.__globals__)
    namespace.update(callees)
    copy = types.FunctionType(func.__code__, namespace, name, func.__defaults__, func.__closure__)
    copy.__qualname__ = name
    copy.__doc__ = func.__doc__
    copy.__kwdefaults__ = func.__kwdefaults__
    return decorator(copy)

# llvm.prefetch is overloaded on the pointer type: "p0" with opaque pointers (LLVM >= 15), "p0i8" before
_PREFETCH_NAME = "llvm.prefetch.p0" if llvmlite.binding.llvm_version_info >= (15,) else "llvm.prefetch.p0i8"


@numba.extending.intrinsic
def prefetch(typingctx, arr, idx, write):
    """Prefetch (into L2) the cache line of element idx of arr's data (flat index), to read or, write=True, to write.

    A hint only (never faults, changes no result): the element loop prefetches the data of the elements ahead.
    ``write`` must be a literal bool.
    """
    if not (isinstance(arr, numba.types.Array) and isinstance(idx, numba.types.Integer)
            and isinstance(write, numba.types.BooleanLiteral)):
        return None
    rw = 1 if write.literal_value else 0

    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        size = context.get_abi_sizeof(context.get_data_type(signature.args[0].dtype))
        ptr = builder.gep(builder.bitcast(ary.data, i8p), [builder.mul(args[1], ir.Constant(args[1].type, size))])
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = numba.core.cgutils.get_or_insert_function(builder.module, fnty, _PREFETCH_NAME)
        builder.call(fn, [ptr, ir.Constant(i32, rw), ir.Constant(i32, 2), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return numba.types.void(arr, idx, write), codegen
