"""docs/fig_atlas.png: a bare torus cloud (5000 points) with ``cut="auto"``: the atlas in the
unit square (seam edges red), and the surface with a 16 x 16 checkerboard in the atlas's
per-corner uv. docs/fig_atlas_finger.png: the same for the finger (5000 points: a disk with a
long thin tube, whose one free chart shrinks the tube), whose atlas has several charts, and
docs/fig_atlas_charts.png, its charts and seams (``pcgeom.apps.plot_atlas``, what ``--plot``
draws). docs/fig_atlas_obj.png: the OBJ that ``pcgeom reconstruct`` writes for a cut map of the
genus-2 pretzel (5000 bare points; ``pcgeom param --cut auto`` then ``pcgeom reconstruct
--texture checker:16``), read back by trimesh and drawn from two sides with the checkerboard
PNG written beside it sampled at each triangle's uv, the seams (the OBJ's uv-split edges) red.

    python benchmarks/fig_atlas.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from pcgeom import parametrize  # noqa: E402
from pcgeom.apps.texture import CHECKER_COLOURS, checker_parity  # noqa: E402
from pcgeom.mesh import boundary_loops  # noqa: E402
from pcgeom.synthetic_closed import closed_surface  # noqa: E402


def main(docs=Path(__file__).resolve().parents[1] / "docs"):
    from pcgeom.apps.plot_atlas import plot_atlas
    from pcgeom.synthetic_atlas import finger

    s = closed_surface("torus", 5000)
    figure(s, parametrize(s.points, "free", cut="auto", progress=False),
           docs / "fig_atlas.png", "torus, 5000 bare points: the checkerboard of the atlas",
           (35, 30))
    f = finger(5000)
    r = parametrize(f.points, "free", cut="auto", progress=False)
    figure(f, r, docs / "fig_atlas_finger.png",
           "finger, 5000 bare points: the checkerboard of the atlas", (30, -60))
    plot_atlas(f.points, r.mesh_faces, r.corner_uv, docs / "fig_atlas_charts.png",
               title="finger, 5000 bare points, --cut auto --plot")
    print(docs / "fig_atlas_charts.png")
    obj_figure(docs / "fig_atlas_obj.png")


def obj_figure(out, genus: int = 2, n: int = 5000):
    """The reconstructed OBJ of a cut map, textured with its own checkerboard PNG."""
    import tempfile

    import trimesh

    from pcgeom import cli
    from pcgeom.io import write_ply_atomic
    from pcgeom.synthetic_atlas import pretzel

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_ply_atomic(tmp / "p.ply", pretzel(genus, n))
        assert cli.main(["param", str(tmp / "p.ply"), "--cut", "auto", "--quiet",
                         "--out", str(tmp / "p.npz")]) == 0
        assert cli.main(["reconstruct", str(tmp / "p.ply"), "--map", str(tmp / "p.npz"),
                         "--out", str(tmp / "p.obj"), "--texture", "checker:16",
                         "--quiet"]) == 0
        m = trimesh.load(tmp / "p.obj", process=False)
        image = plt.imread(tmp / "p_checker.png")
    V, F, uv = np.asarray(m.vertices), np.asarray(m.faces), np.asarray(m.visual.uv)
    c = uv[F].mean(axis=1)
    h, w = image.shape[:2]
    colours = image[np.clip(((1 - c[:, 1]) * h).astype(int), 0, h - 1),
                    np.clip((c[:, 0] * w).astype(int), 0, w - 1), :3]
    # The seams: the edges of one triangle only, once the OBJ's vertices are split per uv.
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(edges, axis=0, return_counts=True)
    seams = keys[counts == 1]
    normals = np.asarray(m.face_normals)
    if ((V[F].mean(axis=1) - V.mean(axis=0)) * normals).sum() < 0:
        normals = -normals  # outward
    fig = plt.figure(figsize=(13, 5.6))
    lo, hi = V.min(axis=0), V.max(axis=0)
    mid, lim = (lo + hi) / 2, 0.36 * float((hi - lo).max())
    for k, view in enumerate([(50, -70), (-50, 110)]):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        elev, azim = np.radians(view[0]), np.radians(view[1])
        eye = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim),
                        np.sin(elev)])
        front = normals @ eye > 0
        ax.add_collection3d(Poly3DCollection(V[F[front]], facecolors=colours[front],
                                             edgecolors=colours[front], linewidths=0.2))
        seen = np.zeros(len(V), dtype=bool)
        seen[F[front].ravel()] = True
        for a, b in seams[seen[seams].all(axis=1)]:
            ax.plot(*V[[a, b]].T, color="crimson", lw=1.6, zorder=10)
        for i, set_lim in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            set_lim(mid[i] - lim, mid[i] + lim)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=view[0], azim=view[1])
        ax.set_axis_off()
    fig.suptitle(f"pcgeom reconstruct on a --cut auto map, genus-{genus} pretzel ({n} bare "
                 f"points): the OBJ read by trimesh ({len(F)} triangles) with its checkerboard "
                 "PNG; seams red")
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.93, wspace=0)
    fig.savefig(out, dpi=110)
    print(out)


def figure(s, r, out, title, view):
    C = r.corner_uv.reshape(-1, 2)
    CF = np.arange(len(C)).reshape(-1, 3)
    colours = np.array(CHECKER_COLOURS)[checker_parity(C, CF, 16)] / 255.0
    # The seams: the cut mesh's boundary, as point rows.
    keys, inv = np.unique(np.column_stack([r.mesh_faces.reshape(-1, 1), C]), axis=0,
                          return_inverse=True)
    Fc = inv.reshape(-1, 3)
    loops = [np.array(loop) for loop in boundary_loops(Fc)]
    fig = plt.figure(figsize=(12, 5.6))
    ax = fig.add_subplot(1, 2, 1)
    ax.add_collection(PolyCollection(C[CF], facecolors=colours, edgecolors="none"))
    for loop in loops:
        ring = keys[np.r_[loop, loop[:1]], 1:]
        ax.plot(ring[:, 0], ring[:, 1], color="crimson", lw=1.2)
    ax.plot([0, 1, 1, 0, 0], [0, 0, 1, 1, 0], color="k", lw=0.8)
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.set_aspect("equal")
    rec = r.history[-1]
    ax.set_title(f"atlas: {rec['charts']} chart(s), {rec['flips']['count']} flipped, spread "
                 f"{rec['stretch']:.1f}, seams {rec['seam_length']:.2f} sqrt(area)")
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    P = s.points
    # Only the triangles that face the viewer (matplotlib sorts polygons, not pixels).
    elev, azim = np.radians(view[0]), np.radians(view[1])
    eye = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)])
    front = (s.normals[r.mesh_faces].mean(axis=1) @ eye) > 0
    ax3.add_collection3d(Poly3DCollection(P[r.mesh_faces[front]], facecolors=colours[front],
                                          edgecolors=colours[front], linewidths=0.2))
    lo, hi = P.min(axis=0), P.max(axis=0)
    c, lim = (lo + hi) / 2, float((hi - lo).max()) / 2
    ax3.set_xlim(c[0] - lim, c[0] + lim)
    ax3.set_ylim(c[1] - lim, c[1] + lim)
    ax3.set_zlim(c[2] - lim, c[2] + lim)
    ax3.set_box_aspect((1, 1, 1))
    ax3.view_init(elev=view[0], azim=view[1])
    ax3.set_axis_off()
    ax3.set_title(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    import sys

    if sys.argv[1:] == ["--obj"]:  # the reconstructed OBJ's figure alone
        obj_figure(Path(__file__).resolve().parents[1] / "docs" / "fig_atlas_obj.png")
    else:
        main()
