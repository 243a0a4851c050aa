"""Checked arrays for the public entry points of the numba kernels.

numba does not check array shapes or bounds: a kernel fed an array of the wrong shape reads or writes past
its end (wrong numbers or a segfault). Every public function that hands arrays to a kernel checks them here
first, once per call and outside the loops: inputs are converted to contiguous float64 (or int64) arrays of
the expected shape, outputs must already be writeable arrays of the right dtype and shape.
"""

from __future__ import annotations

import numpy as np


def _shape_text(shape: tuple) -> str:
    return "(" + ", ".join(str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def kernel_input(a, shape_tail: tuple, name: str, rows: int | None = None, dtype=np.float64) -> np.ndarray:
    """``a`` as a contiguous array of ``dtype`` and shape (m, *shape_tail), m = ``rows`` if given.

    Raises
    ------
    ValueError
        Naming ``name``, the expected and the actual shape (or the conversion that failed).
    """
    try:
        arr = np.ascontiguousarray(a, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array: {str(exc).splitlines()[0]}") from None
    expected = (rows if rows is not None else "m", *shape_tail)
    if arr.ndim != len(expected) or arr.shape[1:] != tuple(shape_tail) or (rows is not None and len(arr) != rows):
        raise ValueError(f"{name} must have shape {_shape_text(expected)}, got {arr.shape}")
    return arr


def kernel_output(a, shape: tuple, name: str, dtype=np.float64) -> np.ndarray:
    """``a`` itself, checked to be a writeable array of ``dtype`` and ``shape`` (a kernel writes into it);
    a ``None`` in ``shape`` allows any size along that axis."""
    fits = isinstance(a, np.ndarray) and a.ndim == len(shape) and all(
        s is None or s == t for s, t in zip(shape, a.shape))
    if not fits or a.dtype != dtype or not a.flags.writeable:
        shape = tuple("n" if s is None else s for s in shape)
        got = (f"a {'read-only ' if not a.flags.writeable else ''}{a.dtype} array of shape {a.shape}"
               if isinstance(a, np.ndarray) else type(a).__name__)
        raise ValueError(f"{name} must be a writeable {np.dtype(dtype)} array of shape {_shape_text(shape)}, "
                         f"got {got}")
    return a
