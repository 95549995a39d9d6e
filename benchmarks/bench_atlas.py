"""``cut="auto"`` measured: analytic tori (5k, 20k) and the shared closed head (genus 0).

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

import itertools
import sys
import time
from pathlib import Path

import numpy as np

from pcgeom import parametrize
from pcgeom.io import read_points
from pcgeom.maps.atlas import chart_map, overlap_area
from pcgeom.maps.seams import cut_graph, cut_open
from pcgeom.metrics import angle_distortion
from pcgeom.synthetic_closed import closed_surface


def true_triangle_uv(P, faces, mesh_faces, corner_uv):
    """Per true triangle, the uv of its corners (best copies) and whether a seam crosses it."""
    rows = mesh_faces.ravel()
    U = corner_uv.reshape(-1, 2)
    keys, first = np.unique(np.column_stack([rows, U]), axis=0, return_index=True)
    pt = keys[:, 0].astype(int)
    copies = [[] for _ in range(len(P))]
    for p, u in zip(pt, keys[:, 1:]):
        copies[p].append(u)
    T = np.full((len(faces), 3, 2), np.nan)
    for t, f in enumerate(faces):
        opts = [copies[v] if copies[v] else [np.array([np.nan, np.nan])] for v in f]
        best, bp = None, np.inf
        for combo in itertools.product(*opts):
            c = np.array(combo)
            per = np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1).sum()
            if per < bp:
                best, bp = c, per
        T[t] = best
    p3 = np.linalg.norm(P[faces] - np.roll(P[faces], 1, axis=1), axis=2).sum(axis=1)
    p2 = np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2).sum(axis=1)
    ratio = p2 / p3
    crossed = ~np.isfinite(ratio) | (ratio > 3 * np.nanmedian(ratio))
    return T, crossed


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
    line = (f"{name:28s} {len(P):6d}  g{rec['seams']['genus']} loops {rec['seams']['loops']}  "
            f"flips {rec['flips']['count']}  overlap {ov:.1e}  spread {rec['stretch']:.2f}  "
            f"seam/sqrtA {rec['seam_length']:.2f}  {sec:.1f} s")
    if faces is not None:
        T, crossed = true_triangle_uv(P, faces,
                                      r.mesh_faces, r.corner_uv)
        ang, fl = angle_inside(P, faces, T, crossed)
        la, lf, ls = lscm_true(P, faces)
        line += (f"  | inside: angle {ang:.4f} flips {fl}, seam-crossed {100 * crossed.mean():.2f}%"
                 f"  | igl.lscm true mesh cut: angle {la:.4f} flips {lf} seam/sqrtA {ls:.2f}")
    print(line, flush=True)


def main():
    for n in (5000, 20000):
        s = closed_surface("torus", n)
        run(f"torus uniform", s.points, s.faces)
    s = closed_surface("torus", 5000, sampling="scan")
    run("torus scan", s.points, s.faces)
    head = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "closed_david_head_choi.ply"
    if head.exists():
        c = read_points(head)
        run("closed_david_head_choi", c.points, c.faces)


if __name__ == "__main__":
    sys.exit(main())
