"""Tracked outputs of a scene: the scalars recorded at every converged (static) or recorded (dynamic) step.

Each has a ``name`` and ``value(model, state)``; one that reads velocities (``uses_velocity``) has
``motion_value(dyn, state, velocity)`` instead. :func:`check_outputs` names a bad node index when the scene
is made.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexbody.assembly import Model
from flexbody.frames import unit_vector


@dataclass(frozen=True)
class Output:
    """A tracked scalar: the displacement of one node along a fixed direction, times ``scale``.

    The direction is normalised (any finite nonzero vector, huge components included); a node index is
    checked against the mesh when the :class:`Scene` is made.

    Example: Output("W_A", node=12, direction=(0, 0, 1)) is the z-displacement of node 12.
    """

    name: str
    node: int
    direction: tuple[float, float, float]
    scale: float = 1.0

    def __post_init__(self) -> None:
        if isinstance(self.node, (bool, np.bool_)) or not isinstance(self.node, (int, np.integer)):
            raise ValueError(f"output {self.name!r} node must be a node index, got {self.node!r}")
        object.__setattr__(self, "node", int(self.node))
        unit = unit_vector(self.direction, f"output {self.name!r} direction")
        object.__setattr__(self, "direction", tuple(float(v) for v in unit))
        _check_scale(self)

    def node_indices(self) -> tuple[int, ...]:
        """The nodes this output reads (checked against the mesh when the scene is made)."""
        return (self.node,)

    def value(self, model: Model, state) -> float:
        u = state.x[self.node] - model.body.mesh.nodes[self.node]
        return self.scale * float(u @ np.asarray(self.direction, float))



def _check_scale(output) -> None:
    scale = output.scale
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale):
        raise ValueError(f"output {output.name!r} scale must be a finite number, got {scale!r}")


@dataclass(frozen=True)
class RadialDisplacement:
    """The mean radial displacement of some nodes about an axis through ``center``, times ``scale``.

    u_r = mean_I (|P (x_I - c)| - |P (X_I - c)|) with P the projection normal to ``axis``: invariant under
    rotations about the axis, so it measures the stretch of a spinning body in any of its positions.
    """

    name: str
    nodes: tuple[int, ...]
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    scale: float = 1.0

    def __post_init__(self) -> None:
        nodes = np.atleast_1d(np.asarray(self.nodes))
        if nodes.size == 0 or nodes.ndim != 1 or not np.issubdtype(nodes.dtype, np.integer):
            raise ValueError(f"output {self.name!r} nodes must be a non-empty list of node indices, "
                             f"got {self.nodes!r}")
        object.__setattr__(self, "nodes", tuple(int(i) for i in nodes))
        unit_vector(self.axis, f"output {self.name!r} axis")
        c = np.asarray(self.center, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise ValueError(f"output {self.name!r} center must be a finite 3-vector, got {self.center!r}")
        _check_scale(self)

    def node_indices(self) -> tuple[int, ...]:
        """The nodes this output reads (checked against the mesh when the scene is made)."""
        return self.nodes

    def _radius(self, x: np.ndarray) -> np.ndarray:
        n = unit_vector(self.axis, f"output {self.name!r} axis")
        r = x - np.asarray(self.center, float)
        return np.linalg.norm(r - np.outer(r @ n, n), axis=1)

    def value(self, model: Model, state) -> float:
        idx = np.asarray(self.nodes, dtype=int)
        X = model.body.mesh.nodes[idx]
        return self.scale * float(np.mean(self._radius(state.x[idx]) - self._radius(X)))


@dataclass(frozen=True)
class AngularVelocity:
    """A global component (0, 1, 2 = x, y, z) of the body's rigid angular velocity (dynamic scenes only).

    The mass-weighted least-squares fit of the nodal velocities
    (:meth:`flexbody.dynamics.DynamicModel.rigid_angular_velocity`): a kinematic measure, independent of
    the momenta.
    """

    name: str
    component: int
    uses_velocity = True

    def value(self, model: Model, state) -> float:
        raise ValueError(f"output {self.name!r} (an angular velocity) needs a dynamic analysis")

    def motion_value(self, dyn, state, velocity: np.ndarray) -> float:
        return float(dyn.rigid_angular_velocity(state, velocity)[self.component])




def check_outputs(outputs: list, n_nodes: int) -> None:
    """Every output's nodes exist: a bad index is named when the scene is made, not at the first step."""
    for out in outputs:
        for i in getattr(out, "node_indices", lambda: ())():
            if not 0 <= i < n_nodes:
                raise ValueError(f"output {out.name!r} names node {i}, but the mesh has nodes 0..{n_nodes - 1}")

