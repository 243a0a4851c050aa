"""The modal problem of a scene for ``flexbody modes``: about its reference state, an equilibrium on its
static path, or its steady spin."""

from __future__ import annotations

from flexbody.cli.errors import CliError
from flexbody.cli.progress import run_with_progress


def scene_spin(scene):
    """(omega (3,), center (3,)) of a spinning dynamic scene, or (None, None).

    A steady-spin start gives both; a driven hub (prescribed motion) turns at its rate at the end of the run,
    measured by a one-sided difference of Q(t), about the axis through the centroid of its nodes."""
    import numpy as np

    from flexbody.spinning import SteadySpinStart
    if scene.kind != "dynamic":
        return None, None
    a = scene.analysis
    if isinstance(a.initial_state, SteadySpinStart):
        s = a.initial_state
        center = None if s.center is None else np.asarray(s.center, float)
        return np.asarray(s.angular_velocity, float), center
    for p in a.prescribed:
        t = a.end_time
        delta = 1e-6 * max(t, 1e-3)
        Q0, Q1 = (np.asarray(p.motion(t - k * delta)[0], float) for k in (1, 0))
        W = (Q1 - Q0) / delta @ Q1.T
        rate = np.array([W[2, 1], W[0, 2], W[1, 0]])
        if np.linalg.norm(rate) > 0:
            return rate, scene.model.body.mesh.nodes[p.nodes].mean(axis=0)
    return None, None



def modal_problem_of_scene(scene, omega: float | None = None, load_factor=None, quiet: bool = True):
    """The :class:`flexbody.modal.ModalProblem` of a scene.

    Static scenes: about the reference state (``load_factor`` None or 0), the equilibrium at a load factor
    (a load-controlled path through the scene's load levels below it), or the end of the scene's path
    ("end"). Dynamic scenes: about the steady spin of a spinning scene (its rate, or ``omega`` rad/s about its
    axis; ``omega`` = 0: at rest), else about the reference state (without the loads and gravity; ``omega``
    > 0 spins it about the z-axis through its mass centre)."""
    import numpy as np

    from flexbody import modal
    from flexbody.dynamics import DynamicModel
    if scene.kind == "static":
        if omega is not None:
            raise CliError("--omega needs a dynamic scene (a static scene has no mass at rest to spin)")
        model = scene.model
        if not model.body.material.density > 0:
            raise CliError(f"a modal analysis needs the mass: the material density of {scene.name} is "
                           f"{model.body.material.density!r}; set it (--set density=VALUE, material.density)")
        dyn = DynamicModel(model)
        if load_factor in (None, 0.0):
            return modal.modal_problem_at_rest(dyn)
        if load_factor == "end":
            summary = run_with_progress(scene, quiet=quiet)
            result = summary.result
        else:
            from integrators.static import load_control
            levels = [f for f in scene.analysis.load_factors if 0 < f < load_factor] + [load_factor]
            result = load_control(model, levels, settings=scene.analysis.newton)
        if not result.converged:
            raise CliError(f"the static path did not reach the load factor: {result.message}")
        return modal.modal_problem_at_rest(dyn, result.state, result.load_factor)
    if load_factor not in (None, 0.0):
        raise CliError("--load-factor needs a static scene")
    a = scene.analysis
    dyn = DynamicModel(scene.model, point_masses=list(a.point_masses), mass=a.mass)
    spin, center = scene_spin(scene)
    if omega is not None:
        axis = np.array([0.0, 0.0, 1.0]) if spin is None else spin / np.linalg.norm(spin)
        spin = omega * axis
    if spin is None or not np.any(spin):
        return modal.modal_problem_at_rest(dyn)
    try:
        return modal.modal_problem_in_spin(dyn, spin, center)
    except ValueError as exc:
        raise CliError(str(exc).splitlines()[0]) from None
