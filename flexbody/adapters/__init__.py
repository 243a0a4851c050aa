"""Adapters to other codes. Each adapter imports its third-party package only inside its own (sub)package.

- ``flexbody.adapters.exudyn``: exudyn reference models of the built-in scenes and the side-by-side
  comparison behind ``flexbody compare SCENE --with exudyn`` (needs ``pip install 'flexbody[exudyn]'``).

Importing this package imports no third-party code; the core (lie, mesh, shell, body, integrators, scenes)
never imports an adapter.
"""
