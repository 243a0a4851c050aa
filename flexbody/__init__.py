"""flexbody: flexible multibody dynamics with a geometrically exact six-node triangular shell on SE(3).

The core (``flexbody.lie``, ``flexbody.mesh``, ``flexbody.shell``, ``flexbody.body`` and the
``integrators`` package) never imports the outputs, the adapters or the command line.
"""

__version__ = "0.1.0"
