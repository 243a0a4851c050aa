"""Lie groups SO(3) and SE(3): numpy reference maps (``so3``, ``se3``) and numba kernels (``kernels``).

``from flexbody.lie import so3, se3`` gives the readable reference; ``flexbody.lie.kernels`` holds the
allocation-free ``@njit`` versions used by the element kernels (imported on demand, so the reference does
not pay numba's import time).
"""

from flexbody.lie import se3, so3

__all__ = ["so3", "se3"]
