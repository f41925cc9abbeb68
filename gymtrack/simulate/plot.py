"""Top and side views of a simulated routine: cameras, apparatus, performance space, plane and
every trajectory (the target highlighted).

Paper: Fig. 4 (a)-(b) draws the same two views to show why two opposite cameras triangulate
badly. matplotlib is an optional extra (``pip install gymtrack[plot]``); it is imported here
only, when a plot is asked for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import GymtrackError

ROLE_COLOURS = {"coach": "tab:orange", "judge": "tab:green", "gymnast": "tab:purple", "spectator": "tab:gray"}


def _matplotlib():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover - depends on the installation
        raise GymtrackError("--plot needs matplotlib: pip install 'gymtrack[plot]'") from None
    return plt


def plot_routine(sim, out: str | Path) -> tuple[Path, Path]:
    """Write ``plot_top.png`` (x-y) and ``plot_side.png`` (the plane's horizontal axis against z)
    of ``sim`` (a :class:`~gymtrack.simulate.routine.SimulatedRoutine`) into ``out``."""
    plt = _matplotlib()
    from .venue import plane_axes

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    app = sim.app
    s = np.asarray(app.performance_space)
    normal, along = plane_axes(app)
    C = sim.rig.centres
    paths = []
    for view in ("top", "side"):
        fig, ax = plt.subplots(figsize=(11, 7) if view == "top" else (11, 5))
        if view == "top":
            X = lambda p: (np.asarray(p)[..., 0], np.asarray(p)[..., 1])  # noqa: E731
            ax.add_patch(plt.Rectangle((s[0], s[1]), s[3] - s[0], s[4] - s[1], fill=False, ls="--", color="k", label="performance space"))
            # the plane's trace on the floor
            ext = np.sort(np.array([[s[0], s[1]], [s[3], s[4]]]) @ along[:2])
            t = np.array([ext[0] - 2.0, ext[1] + 2.0])
            p0 = np.asarray(app.plane_point)
            ax.plot(p0[0] + t * along[0], p0[1] + t * along[1], color="pink", lw=2, label="vertical plane")
            for blk in app.blocks:
                ax.add_patch(plt.Rectangle(blk.lo[:2], blk.hi[0] - blk.lo[0], blk.hi[1] - blk.lo[1], color="saddlebrown", alpha=0.6))
            for bar in app.bars:
                ax.plot([bar.start[0], bar.end[0]], [bar.start[1], bar.end[1]], color="saddlebrown", lw=3)
        else:
            X = lambda p: (np.asarray(p) @ along, np.asarray(p)[..., 2])  # noqa: E731
            corners = np.array([[s[0], s[1]], [s[3], s[4]]])
            a = np.sort(corners @ along[:2])
            ax.add_patch(plt.Rectangle((a[0], s[2]), a[1] - a[0], s[5] - s[2], fill=False, ls="--", color="k", label="performance space"))
            for blk in app.blocks:
                lo, hi = np.array(blk.lo), np.array(blk.hi)
                xs = np.sort([lo @ along, hi @ along])
                ax.add_patch(plt.Rectangle((xs[0], lo[2]), xs[1] - xs[0], hi[2] - lo[2], color="saddlebrown", alpha=0.6))
            for bar in app.bars:
                ax.plot(*X(np.array([bar.start, bar.end])), color="saddlebrown", lw=3, marker="o", ms=4)
        for i in range(1, len(sim.person_id)):
            m = sim.alive[i]
            col = ROLE_COLOURS.get(str(sim.role[i]), "gray")
            ax.plot(*X(sim.centre[i, m]), lw=0.6, alpha=0.6, color=col)
            ax.plot(*X(sim.centre[i, m][:1]), marker="o", ms=3, color=col)  # where the person starts
        for role, col in ROLE_COLOURS.items():
            ax.plot([], [], color=col, label=role)
        tc = sim.centre[0]
        ax.plot(*X(tc), color="red", lw=1.0, label="target")
        perf = sim.performing
        ax.plot(*X(np.where(perf[:, None], tc, np.nan)), color="red", lw=2.0)
        cx, cy = X(C)
        ax.scatter(cx, cy, marker="^", s=80, color="blue", zorder=5, label="cameras")
        for k, cam in enumerate(sim.rig):
            ax.annotate(cam.name, (cx[k], cy[k]), textcoords="offset points", xytext=(5, 5))
            d = cam.optical_axis
            ex, ey = X(np.array([C[k], C[k] + 3.0 * d]))
            ax.plot(ex, ey, color="blue", lw=1)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)" if view == "top" else "along the plane (m)")
        ax.set_ylabel("y (m)" if view == "top" else "z (m)")
        ax.set_title(f"{sim.apparatus}, seed {sim.seed}, n_cam {sim.n_cam}: {view} view")
        ax.legend(loc="upper right", fontsize=7)
        ax.grid(alpha=0.3)
        path = out / f"plot_{view}.png"
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths[0], paths[1]
