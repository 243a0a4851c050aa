"""The plots of ``flexbody modes --plot``: the mode shapes of one analysis, or the Campbell diagram of a
sweep."""

from __future__ import annotations

from flexbody.cli.errors import CliError


def _pyplot():
    """matplotlib's pyplot (non-interactive), or a CliError if matplotlib is not installed."""
    from flexbody.outputs.report import _pyplot as pyplot
    plt = pyplot()
    if plt is None:
        raise CliError("--plot needs matplotlib: pip install 'flexbody[dev]' (or matplotlib)")
    return plt


def plot_mode_shapes(path: str, record: dict, modes, at_most: int = 6) -> None:
    """The first ``at_most`` mode shapes: the displacement normal to the body's mean plane (or its magnitude,
    for a body that is not flat) on the mesh projected on that plane."""
    import numpy as np
    plt = _pyplot()
    p = modes.problem
    x = p.state.x
    c = x.mean(axis=0)
    _, _, vt = np.linalg.svd(x - c, full_matrices=False)
    e1, e2, normal = vt
    flat = np.ptp((x - c) @ normal) <= 1e-6 * np.ptp(x, axis=0).max()
    tri = p.dynamic.model.body.mesh.elements[:, :3]
    k = min(at_most, len(modes.frequencies))
    cols = min(k, 3)
    fig, axes = plt.subplots((k + cols - 1) // cols, cols, figsize=(4 * cols, 3.6 * ((k + cols - 1) // cols)),
                             squeeze=False)
    for i, ax in enumerate(axes.ravel()):
        if i >= k:
            ax.axis("off")
            continue
        u = modes.nodal_displacements(i)
        value = u @ normal if flat else np.linalg.norm(u, axis=1)
        top = float(np.abs(value).max()) or 1.0
        ax.tripcolor((x - c) @ e1, (x - c) @ e2, tri, value, shading="gouraud", cmap="RdBu_r", vmin=-top, vmax=top)
        ax.set_aspect("equal")
        ax.set_title(f"mode {i + 1}: {record['frequencies_hz'][i]:.4g} Hz")
        ax.set_xticks([]), ax.set_yticks([])
    fig.suptitle(f"{record['scene']} ({record['frame']} frame)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_campbell(path: str, sweep: dict) -> None:
    """Frequencies (Hz) against the swept value; for a spin-rate sweep also the lines n Omega (n = 1..4)."""
    import numpy as np
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    values = np.asarray(sweep["values"], float)
    count = min(len(f) for f in sweep["frequencies_rad_s"])
    F = np.array([f[:count] for f in sweep["frequencies_rad_s"]]) / (2 * np.pi)
    for j in range(count):
        ax.plot(values, F[:, j], "o-", ms=3, lw=1)
    if sweep["parameter"] == "omega":
        for n in range(1, 5):
            ax.plot(values, n * values / (2 * np.pi), "k:", lw=0.8)
            ax.annotate(f"{n}$\\Omega$", (values[-1], n * values[-1] / (2 * np.pi)), fontsize=8)
        ax.set_xlabel("spin rate $\\Omega$ (rad/s)")
    else:
        ax.set_xlabel(sweep["parameter"])
    ax.set_ylabel(f"frequency (Hz, {sweep['frame']} frame)")
    ax.set_title(f"Campbell diagram: {sweep['scene']}")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
