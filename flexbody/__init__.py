"""flexbody: flexible multibody dynamics with a geometrically exact six-node triangular shell on SE(3).

The core (``flexbody.lie``, ``flexbody.mesh``, ``flexbody.shell``, ``flexbody.body`` and the
``integrators`` package) never imports the outputs, the adapters or the command line.
"""

# First, before any kernel is compiled or loaded: numba's cache goes to a per-user directory, never into the
# installed package (see flexbody.kernel_cache).
from flexbody import kernel_cache as _kernel_cache  # noqa: F401

__version__ = "0.1.0"
