"""``cut="auto"`` measured: analytic tori (5k, 20k), a genus-2 implicit surface, the shared
closed head (genus 0) and the shared open surfaces (seams from their holes to their rim).

For each: seams (genus, loops, length over sqrt(area)), flips, overlap (shapely union of the
chart triangles), scale-factor spread (95th/5th percentile), time; and the angle error over
the true triangles inside the chart: each true triangle takes, of its points' uv copies
(a seam point has one per side), the combination with the smallest uv perimeter; a triangle
whose best perimeter is still over 3x the median ratio of uv to 3D perimeter is crossed by a
seam and left out (its share reported). Beside it, igl.lscm on the true mesh cut by the same
method (tree-cotree on the true mesh: seams of the same construction, not the same edges).

    OMP_NUM_THREADS=1 python benchmarks/bench_atlas.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from pcgeom import parametrize
from pcgeom.io import read_points
from pcgeom.maps.atlas import chart_map, overlap_area
from pcgeom.maps.atlas_eval import triangle_uv
from pcgeom.maps.seams import cut_graph, cut_open
from pcgeom.metrics import angle_distortion
from pcgeom.synthetic_closed import closed_surface


def angle_inside(P, faces, T, crossed):
    F = faces[~crossed]
    V = P[F].reshape(-1, 3)
    U = T[~crossed].reshape(-1, 2)
    rep = angle_distortion(V, np.arange(len(V)).reshape(-1, 3), U)
    return rep.mean_abs, rep.flipped


def lscm_true(P, faces):
    E, cut, info = cut_graph(P, faces)
    Fc, origin = cut_open(faces, E, cut, len(P))
    t = time.perf_counter()
    U, _ = chart_map(P[origin], Fc)
    V = P[origin]
    rep = angle_distortion(V, Fc, U)
    area = 0.5 * np.linalg.norm(np.cross(P[faces[:, 1]] - P[faces[:, 0]],
                                         P[faces[:, 2]] - P[faces[:, 0]]), axis=1).sum()
    return rep.mean_abs, rep.flipped, info["length"] / np.sqrt(area)


def run(name, P, faces):
    t = time.perf_counter()
    r = parametrize(P, "free", cut="auto", progress=False)
    sec = time.perf_counter() - t
    rec = r.history[-1]
    U = r.corner_uv.reshape(-1, 2)
    ov = overlap_area(U, np.arange(len(U)).reshape(-1, 3))
    line = (f"{name:28s} {len(P):6d}  g{rec['seams']['genus']} b{rec['seams'].get('boundary_loops', 0)} "
            f"paths {rec['seams']['loops']}  "
            f"flips {rec['flips']['count']}  overlap {ov:.1e}  spread {rec['stretch']:.2f}  "
            f"seam/sqrtA {rec['seam_length']:.2f}  {sec:.1f} s")
    if faces is not None:
        T, crossed = triangle_uv(P, faces,
                                      r.mesh_faces, r.corner_uv)
        ang, fl = angle_inside(P, faces, T, crossed)
        la, lf, ls = lscm_true(P, faces)
        line += (f"  | inside: angle {ang:.4f} flips {fl}, seam-crossed {100 * crossed.mean():.2f}%"
                 f"  | igl.lscm true mesh cut: angle {la:.4f} flips {lf} seam/sqrtA {ls:.2f}")
    print(line, flush=True)


def genus2(n: int, seed: int = 0) -> np.ndarray:
    """About ``n`` points on the genus-2 implicit surface
    ``(x (x - 1)^2 (x - 2) + y^2)^2 + z^2 = 0.03``: random points of its box projected onto it
    (Newton along the gradient), thinned to a minimum distance (no true faces)."""
    from scipy.spatial import cKDTree

    def f(P):
        x, y, z = P.T
        return (x * (x - 1) ** 2 * (x - 2) + y ** 2) ** 2 + z ** 2 - 0.03

    def grad(P, h=1e-6):
        return np.column_stack([(f(P + d) - f(P - d)) / (2 * h) for d in np.eye(3) * h])

    rng = np.random.default_rng(seed)
    P = rng.uniform([-0.3, -1, -0.4], [2.3, 1, 0.4], size=(40 * n, 3))
    for _ in range(30):
        g = grad(P)
        P = P - (f(P) / np.maximum((g * g).sum(1), 1e-12))[:, None] * g
    P = P[np.abs(f(P)) < 1e-9]
    keep = np.ones(len(P), dtype=bool)
    tree = cKDTree(P)
    for i in rng.permutation(len(P)):
        if keep[i]:
            keep[tree.query_ball_point(P[i], 0.62 * np.sqrt(6.0 / n))] = False
            keep[i] = True
    return P[keep]


def main():
    for n in (5000, 20000):
        s = closed_surface("torus", n)
        run(f"torus uniform", s.points, s.faces)
    s = closed_surface("torus", 5000, sampling="scan")
    run("torus scan", s.points, s.faces)
    for n in (5000, 20000):
        P = genus2(n)
        run("genus-2 implicit (no faces)", P, None)
    data = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    for name in ("closed_david_head_choi", "face_3holes_small_choi", "peaks_7holes_choi",
                 "face_human_choi", "peaks_three_cgal"):
        if (data / f"{name}.ply").exists():
            c = read_points(data / f"{name}.ply")
            run(name, c.points, c.faces)


if __name__ == "__main__":
    sys.exit(main())
